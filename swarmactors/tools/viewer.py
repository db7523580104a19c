"""The web viewer: an aiohttp server for the page under ``swarmactors/static``.

Three sources feed the same page:

* ``LiveSource.in_process`` - ``swarmactors run/world … --view``: the world's
  own tick records (a sink beside the trace writer), so positions, status,
  events, frames and drops are exact;
* ``LiveSource.remote`` - ``swarmactors view --connect ENDPOINT``: the world's
  ``state`` and ``events`` streams over Zenoh (best-effort: a slow viewer loses
  snapshots, never ticks);
* ``ReplaySource`` - ``swarmactors replay TRACE --view`` (and a ``--view`` run
  once it has ended): a trace file, with a time slider.

Every action of a live viewer (pause, resume, step, speed, kill, move …) is a
query on the world's ``control`` queryable, so the world applies it at the
start of a tick and records it in the trace like a scenario event. Speed is
paced with ``run_to``, which the world does not record: pacing never changes
what happens in a lockstep run.

Every request but the page and its static files needs the server's per-run token (``?token=`` in the URL
it prints, or the ``X-Swarmactors-Token`` header), and every request's ``Host`` must name this machine
(``LOCAL_NAMES``, an IP address, or the host the server was bound to): see "Security" in docs/viewer.md.

Each page has its own sending task that sends the newest frame at most
``MAX_FPS`` times a second and skips the ones it had no time for; a page that
stalls or disconnects costs the run nothing.
"""

from __future__ import annotations

import asyncio
import contextlib
import hmac
import ipaddress
import json
import logging
import secrets
import signal
import socket
import sys
import time
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from aiohttp import WSMsgType, web

from swarmactors.robot.tasks import TaskSet
from swarmactors.tools.scene import Scene, events_toml
from transport import Endpoints, Keys, Link, QueryError, pack, unpack
from transport.keys import CONTROL_ANY
from transport.messages import ACTIONS

log = logging.getLogger(__name__)

MAX_FPS = 30
STATUS_EVERY_S = 0.5
CONTROL_TIMEOUT_S = 5.0
FIND_TIMEOUT_S = 2.0
WORLD_ACTIONS = tuple(a for a in ACTIONS if a != "add")  # what the page may ask of the world
DEFAULT_RATE = 10.0  # ticks per second when ▶ is pressed (None: as fast as the world goes)
TOKEN_HEADER = "X-Swarmactors-Token"
LOCAL_NAMES = ("localhost",)  # host names always accepted in a Host header, beside IP addresses


class ViewerError(RuntimeError):
    """The viewer cannot do what was asked (no such run, world unreachable, …)."""


# ---------------------------------------------------------------- sources
class Source:
    """What the server shows and where page commands go."""

    scene: Scene
    notify: Callable[[], None] = staticmethod(lambda: None)

    def frame(self) -> dict:
        return self.scene.frame(self.extra())

    def extra(self) -> dict:
        return {}

    def robot(self, rid: int) -> dict:
        return self.scene.robot(rid)

    def events_toml(self) -> str:
        return events_toml(self.scene.control_events(), self.scene.run_id)

    async def command(self, msg: dict) -> dict:
        return {"ok": False, "error": "nothing to control"}

    async def start(self) -> None:
        pass

    async def close(self) -> None:
        pass


class WaitingSource(Source):
    """Before the run has opened its world."""

    def __init__(self, message: str = "waiting for the run to start"):
        self.scene = Scene(mode="live")
        self.message = message

    def extra(self) -> dict:
        return {"message": self.message, "controls": False}


class LiveSource(Source):
    """A running world: its streams or its own records, and its ``control`` queryable."""

    def __init__(self, link: Link, keys: Keys, scene: Scene, clock: str):
        self.link = link
        self.keys = keys
        self.scene = scene
        self.clock = clock
        self.world_status: dict = {}
        self.gone = False
        self.rate: float | None = DEFAULT_RATE
        self.playing = False
        self.last_error: str | None = None
        self._tasks = TaskSet("viewer source")
        self._pacer: asyncio.Task | None = None
        self._target = 0
        self._failures = 0

    # -- construction ---------------------------------------------------
    @classmethod
    def in_process(cls, world, link: Link, sc: dict) -> LiveSource:
        """Fed by a sink on ``world`` (in the world's process): exact records, frames included."""
        scene = Scene(run_id=world.keys.run_id, clock=world.clock.name, ticks=world.ticks, scenario=sc, mode="live")
        src = cls(link, world.keys, scene, world.clock.name)
        world.sinks.append(_SceneSink(src, world))
        return src

    @classmethod
    def remote(cls, link: Link, keys: Keys, status: dict) -> LiveSource:
        """Fed by the world's ``state`` and ``events`` streams over Zenoh."""
        scene = Scene(run_id=keys.run_id, clock=status.get("clock", "lockstep"), ticks=status.get("ticks"),
                      mode="live", frames_available=False)
        scene.objects = dict(status.get("objects") or {})
        src = cls(link, keys, scene, scene.clock)
        src.world_status = status

        def on_state(_key: str, payload: bytes) -> None:
            scene.feed_state(payload)
            src.notify()

        def on_event(_key: str, payload: bytes) -> None:
            try:
                scene.feed_event(payload)
            except ValueError as exc:
                log.warning("viewer: %s", exc)
                return
            src.notify()

        link.subscribe(keys.state, on_state)
        link.subscribe(keys.events, on_event)
        return src

    # -- lifecycle --------------------------------------------------------
    async def start(self) -> None:
        self._tasks.spawn(self._poll_status())

    async def close(self) -> None:
        self._pacer = None
        await self._tasks.close()

    async def _poll_status(self) -> None:
        """Keep the world's status (paused, finished …) and notice a world that stopped answering."""
        while True:
            try:
                reply = await self.control("status")
                seen = ("paused", "started", "finished", "alive", "unclaimed")
                if any(reply.get(k) != self.world_status.get(k) for k in seen):
                    self.notify()  # the page shows these: send a new frame even if no tick happened
                self.world_status = reply
                self._failures = 0
                if self.gone:
                    self.gone = False
                    self.notify()
                if reply.get("finished"):
                    self.scene.finished = True
            except (QueryError, ValueError):
                self._failures += 1
                if self._failures >= 3 and not self.gone:
                    self.gone = True
                    self.playing = False
                    self.notify()
            await asyncio.sleep(STATUS_EVERY_S)

    # -- commands ------------------------------------------------------------
    async def control(self, cmd: str, **fields: Any) -> dict:
        """One query on the world's ``control`` queryable; its answer."""
        answer = unpack(await self.link.query(self.keys.control, pack({"cmd": cmd, **fields}),
                                              timeout=CONTROL_TIMEOUT_S), what="control answer")
        if not isinstance(answer, dict):
            raise ValueError("control answer is not a map")
        return answer

    async def command(self, msg: dict) -> dict:
        cmd = msg.get("cmd")
        try:
            if cmd in ("play", "pause", "step", "speed"):
                if self.clock != "lockstep":
                    return {"ok": False, "error": f"{cmd} needs the lockstep clock (this run is {self.clock})"}
                return await self._pace_command(cmd, msg)
            if cmd == "kill":
                return await self.control("kill", args=[int(msg["id"])])
            if cmd == "move":
                return await self.control("move", args={"object": str(msg["object"]),
                                                        "pos": [float(v) for v in msg["pos"]]})
            if cmd in WORLD_ACTIONS:
                return await self.control(cmd, args=msg.get("args", True))
        except (KeyError, TypeError, ValueError) as exc:
            return {"ok": False, "error": f"{cmd}: {exc}"}
        except QueryError as exc:
            return {"ok": False, "error": f"the world did not answer: {exc}"}
        return {"ok": False, "error": f"unknown command {cmd!r}"}

    async def _pace_command(self, cmd: str, msg: dict) -> dict:
        if cmd == "speed":
            rate = msg.get("rate")
            if rate is not None and (not isinstance(rate, (int, float)) or rate <= 0):
                return {"ok": False, "error": f"speed: {rate!r} is not a positive number of ticks per second"}
            self.rate = None if rate is None else float(rate)
            if self.playing:
                return await self._pace_command("play", {})
            self.notify()
            return {"ok": True, "rate": self.rate}
        self._stop_pacer()
        if cmd == "pause":
            self.playing = False
            answer = await self.control("pause")
        elif cmd == "step":
            self.playing = False
            answer = await self.control("step")
        else:
            self.playing = True
            if self.rate is None:
                answer = await self.control("resume")
            else:
                self._target = self._next_tick()
                self._pacer = self._tasks.spawn(self._pace())
                answer = {"ok": True, "rate": self.rate}
        self.notify()
        return answer

    def _next_tick(self) -> int:
        return 0 if self.scene.t is None else self.scene.t + 1

    def _stop_pacer(self) -> None:
        if self._pacer is not None:
            self._pacer.cancel()
            self._pacer = None

    async def _pace(self) -> None:
        """Run about ``rate`` ticks a second with ``run_to`` (not recorded: the run stays the same)."""
        interval = max(0.05, 1.0 / self.rate)
        per = self.rate * interval
        carry = 0.0
        try:
            while self.playing:
                carry += per
                n, carry = int(carry), carry - int(carry)
                nxt = self._next_tick()
                self._target = min(max(self._target, nxt) + n, nxt + max(2 * n, 1))
                await self.control("run_to", tick=self._target)
                await asyncio.sleep(interval)
        except (QueryError, ValueError) as exc:
            self.last_error = str(exc)
            self.playing = False
            self.notify()

    def extra(self) -> dict:
        ws = self.world_status
        message = None
        if self.gone:
            message = ("the run has ended: its world no longer answers" if self.scene.t is not None
                       else "the world does not answer")
        elif not ws.get("started", True):
            message = f"waiting for robot hosts ({ws.get('unclaimed', '?')} robots unclaimed)"
        elif ws.get("finished") or self.scene.finished:
            message = "the run has finished"
        return {"controls": not self.gone and not self.scene.finished, "playing": self.playing,
                "rate": self.rate, "paused": bool(ws.get("paused")), "gone": self.gone, "message": message,
                "alive": ws.get("alive"), "robots_total": ws.get("robots"), "error": self.last_error}


class _SceneSink:
    """A world sink (beside the trace writer) that feeds a live scene; cheap on every tick."""

    def __init__(self, source: LiveSource, world):
        self.source = source
        self.world = world

    def record(self, rec: dict) -> None:
        scene = self.source.scene
        scene.feed_record(rec)
        for ev in rec.get("ev", ()):
            for rid in ev.get("added", ()):
                scene.ranges[rid] = float(self.world.sim.robots.range[rid])
        if scene.ticks is not None and rec["t"] + 1 >= scene.ticks:
            scene.finished = True
        self.source.notify()


class ReplaySource(Source):
    """A trace file; the cursor moves with the slider or plays at a rate."""

    def __init__(self, replay, at_end: bool = False):
        self.replay = replay
        self.t = replay.last if at_end else replay.first
        self.scene = replay.scene_at(self.t)
        self.playing = False
        self.rate: float | None = 10.0
        self._player: asyncio.Task | None = None
        self._tasks = TaskSet("replay source")

    def frame(self) -> dict:
        return self.scene.frame(self.extra())

    def frame_at(self, t: int) -> dict:
        return self.replay.scene_at(t).frame(self.extra())

    def extra(self) -> dict:
        return {"controls": False, "playing": self.playing, "rate": self.rate,
                "replay": {"first": self.replay.first, "last": self.replay.last, "t": self.t},
                "message": self.replay.note}

    def events_toml(self) -> str:
        return events_toml(self.replay.full_scene().control_events(), self.scene.run_id)

    def seek(self, t: int) -> None:
        self.t = max(self.replay.first, min(self.replay.last, int(t)))
        self.scene = self.replay.scene_at(self.t)
        self.notify()

    async def command(self, msg: dict) -> dict:
        cmd = msg.get("cmd")
        if cmd == "seek":
            try:
                self.seek(int(msg["t"]))
            except (KeyError, TypeError, ValueError) as exc:
                return {"ok": False, "error": f"seek: {exc}"}
            return {"ok": True, "t": self.t}
        if cmd == "speed":
            rate = msg.get("rate")
            self.rate = None if rate is None else float(rate)
            self.notify()
            return {"ok": True}
        if cmd == "play":
            if self.t >= self.replay.last:
                self.seek(self.replay.first)
            self.playing = True
            if self._player is None or self._player.done():
                self._player = self._tasks.spawn(self._play())
            self.notify()
            return {"ok": True}
        if cmd in ("pause", "step"):
            self.playing = False
            if cmd == "step":
                self.seek(self.t + 1)
            self.notify()
            return {"ok": True, "t": self.t}
        return {"ok": False, "error": f"{cmd}: a replay shows a finished run; controls act on live runs"}

    async def _play(self) -> None:
        last = time.monotonic()
        carry = 0.0
        while self.playing and self.t < self.replay.last:
            await asyncio.sleep(1.0 / MAX_FPS)
            now = time.monotonic()
            carry += (now - last) * (self.rate or MAX_FPS)
            last = now
            if carry >= 1:
                self.seek(self.t + int(carry))
                carry -= int(carry)
        self.playing = False
        self.notify()

    async def close(self) -> None:
        self._player = None
        await self._tasks.close()


# ---------------------------------------------------------------- the server
class ViewerServer:
    """Serves the page, its static files, a WebSocket per page and a small JSON API."""

    def __init__(self, host: str = "127.0.0.1", port: int = 8050, source: Source | None = None):
        self.host = host
        self.port = port
        self.source: Source = source or WaitingSource()
        self.source.notify = self.notify
        self.version = 0
        self._changed = asyncio.Event()
        self._cache: tuple[int, str] | None = None
        self._runner: web.AppRunner | None = None
        self._pages: set[web.WebSocketResponse] = set()
        self.token = secrets.token_urlsafe(24)  # per server, so per run: 192 random bits
        self.base = ""  # http://HOST:PORT/
        self.url = ""  # the base with ?token=…: the address to open
        self._names: frozenset[str] = frozenset(LOCAL_NAMES)

    # -- source switching ---------------------------------------------------
    async def set_source(self, source: Source) -> None:
        old, self.source = self.source, source
        source.notify = self.notify
        await old.close()
        await source.start()
        self.notify()

    def notify(self) -> None:
        """The scene changed: wake every page's sender (each takes the newest frame when it is ready)."""
        self.version += 1
        self._changed.set()

    def frame_text(self) -> str:
        if self._cache is None or self._cache[0] != self.version:
            self._cache = (self.version, json.dumps(self.source.frame()))
        return self._cache[1]

    # -- lifecycle ------------------------------------------------------------
    async def start(self) -> str:
        self._names = frozenset({*LOCAL_NAMES, self.host.strip("[]").lower(), socket.gethostname().lower(),
                                 socket.getfqdn().lower()} - {""})
        app = web.Application(middlewares=[self._guard])
        app.router.add_get("/", self._index)
        app.router.add_get("/favicon.ico", self._no_icon)
        app.router.add_get("/static/{name}", self._static)
        app.router.add_get("/ws", self._ws)
        app.router.add_get("/api/frame", self._api_frame)
        app.router.add_get("/api/space", self._api_space)
        app.router.add_get("/api/robot/{rid}", self._api_robot)
        app.router.add_get("/api/events.toml", self._api_events)
        app.router.add_post("/api/command", self._api_command)
        self._runner = web.AppRunner(app, access_log=None, handle_signals=False)
        await self._runner.setup()
        site = web.TCPSite(self._runner, self.host, self.port)
        try:
            await site.start()
        except OSError as exc:
            await self._runner.cleanup()
            raise ViewerError(f"cannot serve the viewer on {self.host}:{self.port}: {exc.strerror or exc}") from None
        port = self._runner.addresses[0][1]  # the real port when 0 was asked
        host = self.host if self.host not in ("0.0.0.0", "::", "") else "127.0.0.1"
        self.base = f"http://{_url_host(host)}:{port}/"
        self.url = f"{self.base}?token={self.token}"
        await self.source.start()
        return self.url

    async def close(self) -> None:
        await self.source.close()
        # a page that stopped reading never answers the closing handshake: do not wait for it
        await asyncio.gather(*(asyncio.wait_for(ws.close(), 1.0) for ws in list(self._pages)),
                             return_exceptions=True)
        if self._runner is not None:
            await self._runner.cleanup()

    # -- access ------------------------------------------------------------------
    def host_allowed(self, host_header: str) -> bool:
        """A ``Host`` that names this machine: an IP address, ``localhost``, the bound host or this host's name.

        A browser sends the name it resolved, so a page of evil.example whose name was rebound to 127.0.0.1
        sends ``Host: evil.example`` and is refused (DNS rebinding). The port is not checked: an SSH tunnel
        (``ssh -L 9000:localhost:8050``) legitimately reaches the server on another port.
        """
        name = _host_name(host_header)
        if not name:
            return False
        try:
            ipaddress.ip_address(name)
            return True
        except ValueError:
            pass
        return name in self._names

    def token_ok(self, request: web.Request) -> bool:
        """The request carries this server's token (header or ``?token=``), compared in constant time."""
        given = request.headers.get(TOKEN_HEADER) or request.query.get("token") or ""
        return hmac.compare_digest(given.encode(), self.token.encode())

    @web.middleware
    async def _guard(self, request: web.Request, handler):
        """Host allowlist for every request; the token for everything but the page and its static files."""
        if not self.host_allowed(request.headers.get("Host", "")):
            return web.Response(status=403, text=f"Host {request.headers.get('Host', '')!r} is not this "
                                                 "machine: refused (open the address the viewer printed)\n")
        page_only = request.match_info.handler in (self._index, self._no_icon, self._static)  # no run data
        if not page_only and not self.token_ok(request):
            return web.Response(status=403, text="this viewer needs its token: open the address it printed "
                                                 "(…/?token=…) or send the X-Swarmactors-Token header\n")
        return await handler(request)

    # -- handlers ----------------------------------------------------------------
    async def _index(self, request: web.Request) -> web.Response:
        return web.Response(text=_static_text("viewer.html"), content_type="text/html")

    async def _no_icon(self, request: web.Request) -> web.Response:
        return web.Response(status=204)

    async def _static(self, request: web.Request) -> web.Response:
        name = request.match_info["name"]
        types = {".js": "application/javascript", ".css": "text/css", ".html": "text/html"}
        kind = types.get(Path(name).suffix)
        if kind is None or "/" in name or name.startswith("."):
            raise web.HTTPNotFound()
        try:
            return web.Response(text=_static_text(name), content_type=kind)
        except FileNotFoundError:
            raise web.HTTPNotFound() from None

    async def _api_frame(self, request: web.Request) -> web.Response:
        t = request.query.get("t")
        if t is not None and isinstance(self.source, ReplaySource):
            try:
                return web.json_response(self.source.frame_at(int(t)))
            except ValueError:
                raise web.HTTPBadRequest(text=f"t={t!r} is not a tick") from None
        return web.Response(text=self.frame_text(), content_type="application/json")

    async def _api_space(self, request: web.Request) -> web.Response:
        """The world's static space (obstacles, map, bodies, flying robots): fetched once by the page."""
        return web.json_response(self.source.scene.space or {})

    async def _api_robot(self, request: web.Request) -> web.Response:
        try:
            rid = int(request.match_info["rid"])
        except ValueError:
            raise web.HTTPBadRequest(text="robot id must be an integer") from None
        return web.json_response(self.source.robot(rid))

    async def _api_events(self, request: web.Request) -> web.Response:
        return web.Response(text=self.source.events_toml(), content_type="text/plain")

    async def _api_command(self, request: web.Request) -> web.Response:
        _same_origin(request)
        try:
            msg = await request.json()
        except ValueError:
            raise web.HTTPBadRequest(text="the body must be a JSON object") from None
        if not isinstance(msg, dict):
            raise web.HTTPBadRequest(text="the body must be a JSON object")
        return web.json_response(await self.source.command(msg))

    async def _ws(self, request: web.Request) -> web.WebSocketResponse:
        _same_origin(request)
        ws = web.WebSocketResponse(heartbeat=20)
        await ws.prepare(request)
        self._pages.add(ws)
        sender = asyncio.get_running_loop().create_task(self._send_frames(ws))  # awaited below
        try:
            async for msg in ws:
                if msg.type != WSMsgType.TEXT:
                    continue
                try:
                    cmd = json.loads(msg.data)
                except ValueError:
                    continue
                if isinstance(cmd, dict):
                    answer = await self.source.command(cmd)
                    await ws.send_str(json.dumps({"type": "reply", "id": cmd.get("id"), **answer}, default=str))
        finally:
            sender.cancel()
            await asyncio.gather(sender, return_exceptions=True)
            self._pages.discard(ws)
        return ws

    async def _send_frames(self, ws: web.WebSocketResponse) -> None:
        """Send the newest frame whenever there is one, at most MAX_FPS a second; skip what came between."""
        sent = -1
        try:
            while not ws.closed:
                if self.version == sent:
                    self._changed.clear()
                    await self._changed.wait()
                    continue
                sent = self.version
                await ws.send_str(self.frame_text())
                await asyncio.sleep(1.0 / MAX_FPS)
        except (ConnectionError, RuntimeError):  # the page went away
            pass


def _same_origin(request: web.Request) -> None:
    """Refuse commands from pages of other sites (a browser sends their Origin)."""
    origin = request.headers.get("Origin")
    if origin and urlsplit(origin).netloc != request.host:
        raise web.HTTPForbidden(text=f"origin {origin} may not control this viewer")


def _host_name(host_header: str) -> str:
    """The host part of a ``Host`` header, lower case, without brackets or port ('' if malformed)."""
    h = host_header.strip().lower()
    if h.startswith("["):
        end = h.find("]")
        name, rest = h[1:end], h[end + 1:]
        ok = end > 0 and (not rest or (rest[0] == ":" and rest[1:].isdigit()))
        return name if ok else ""
    name, _, port = h.partition(":")
    return name if not port or port.isdigit() else ""


def _url_host(host: str) -> str:
    return f"[{host}]" if ":" in host and not host.startswith("[") else host


def _static_text(name: str) -> str:
    return resources.files("swarmactors").joinpath("static", name).read_text(encoding="utf-8")


# ---------------------------------------------------------------- entry points
class ViewSession:
    """``run/world … --view``: the viewer beside the world, in one event loop, then a replay of the trace."""

    def __init__(self, host: str, port: int, announce: Callable[[str], None] = print):
        self.host, self.port, self.announce = host, port, announce
        self.loop = asyncio.new_event_loop()
        self.server: ViewerServer | None = None

    def run(self, sc: dict, out_dir: Path, endpoints: Endpoints, run_id: str, processes: int, local_host: bool,
            on_tick=None):
        """Run the scenario with the viewer; lockstep runs start paused after tick 0."""
        self.server = ViewerServer(self.host, self.port)
        return self.loop.run_until_complete(
            run_with_viewer(self.server, sc, out_dir, endpoints, run_id, processes=processes, local_host=local_host,
                            on_tick=on_tick, announce=self.announce))

    def linger(self) -> None:
        """Keep serving (the run's replay) until Ctrl-C, then close."""
        if self.server is None:
            return
        self.announce(f"viewer: {self.server.url} shows the run's trace; Ctrl-C to quit")
        try:
            self.loop.run_until_complete(_until_interrupted())
        finally:
            self.loop.run_until_complete(self.server.close())
            self.loop.close()


async def run_with_viewer(server: ViewerServer, sc: dict, out_dir: Path, endpoints: Endpoints, run_id: str, *,
                          processes: int = 0, local_host: bool = True, on_tick=None, paused: bool | None = None,
                          announce: Callable[[str], None] = print):
    """Start ``server``, run the scenario with the page fed by the world's own records, then show its trace.

    A lockstep run waits after tick 0 (``paused``, default for lockstep) until
    a page presses ▶ or sends ``play``/``step``.
    """
    from swarmactors.runs.launcher import run_world

    url = await server.start()
    if paused is None:
        paused = sc["run"]["clock"] == "lockstep"
    announce(f"viewer: {url}" + ("  (the run waits after tick 0: press ▶ in the page)" if paused else ""))
    tasks = TaskSet("viewer run")

    def on_open(world, link) -> None:
        source = LiveSource.in_process(world, link, sc)
        tasks.spawn(server.set_source(source))
        if paused:
            tasks.spawn(source.control("run_to", tick=1))

    try:
        result = await run_world(sc, out_dir, endpoints, run_id, processes=processes, local_host=local_host,
                                 on_tick=on_tick, on_open=on_open, return_on_signal=True)
    finally:
        await tasks.close()
    if result.trace_path is not None and result.trace_path.exists():
        from swarmactors.tools.replay import Replay

        try:
            await server.set_source(ReplaySource(Replay(result.trace_path), at_end=True))
        except ValueError as exc:
            log.warning("viewer: cannot replay the trace: %s", exc)
    return result


async def _until_interrupted() -> None:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    try:
        loop.add_signal_handler(signal.SIGINT, stop.set)
        loop.add_signal_handler(signal.SIGTERM, stop.set)
    except (RuntimeError, ValueError, NotImplementedError):
        pass
    try:
        await stop.wait()
    finally:
        with contextlib.suppress(Exception):
            loop.remove_signal_handler(signal.SIGINT)
            loop.remove_signal_handler(signal.SIGTERM)


async def find_runs(
    link: Link,
    timeout: float = FIND_TIMEOUT_S,  # noqa: ASYNC109 — handed to Link.query_all as Zenoh's query timeout
) -> list[dict]:
    """The status of every run whose world answers on this Zenoh network."""
    out = []
    for payload in await link.query_all(CONTROL_ANY, pack({"cmd": "status"}), timeout=timeout):
        try:
            status = unpack(payload, what="status")
        except ValueError:
            continue
        if isinstance(status, dict) and status.get("ok") and isinstance(status.get("run_id"), str):
            out.append(status)
    return sorted(out, key=lambda s: s["run_id"])


async def open_remote(endpoint: str, run_id: str | None) -> tuple[Link, LiveSource]:
    """Connect to ``endpoint`` and attach to run ``run_id`` (or the only run there); ``ViewerError`` if impossible."""
    try:
        link = Link(Endpoints(mode="client", connect=[endpoint], extra={"connect/timeout_ms": 3000}))
    except Exception as exc:  # zenoh.ZError: nothing listens there
        raise ViewerError(f"cannot reach a Zenoh router or peer at {endpoint}: {exc}".split(" at /")[0]) from None
    try:
        # A world that has just started may not have declared its control queryable yet: look for a while.
        deadline = time.monotonic() + FIND_TIMEOUT_S
        while True:
            if run_id is not None:
                keys = Keys(run_id)
                try:
                    status = unpack(await link.query(keys.control, pack({"cmd": "status"}), timeout=1.0))
                    break
                except QueryError:
                    runs = await find_runs(link, timeout=0.5)
                    if time.monotonic() < deadline:
                        await asyncio.sleep(0.2)
                        continue
                    where = f"runs there: {', '.join(s['run_id'] for s in runs)}" if runs else "no run answers there"
                    raise ViewerError(f"no run {run_id!r} answers at {endpoint} ({where})") from None
            runs = await find_runs(link, timeout=1.0)
            if len(runs) == 1:
                status = runs[0]
                keys = Keys(status["run_id"])
                break
            if len(runs) > 1:
                raise ViewerError(f"{len(runs)} runs answer at {endpoint}: "
                                  f"{', '.join(s['run_id'] for s in runs)}; choose one with --run")
            if time.monotonic() >= deadline:
                raise ViewerError(f"no swarmactors run answers at {endpoint} (is its world running?)")
            await asyncio.sleep(0.2)
        return link, LiveSource.remote(link, keys, status)
    except BaseException:
        link.close()
        raise


async def serve_remote(endpoint: str, run_id: str | None, host: str, port: int,
                       announce: Callable[[str], None] = print) -> None:
    """``swarmactors view``: serve a live run found over Zenoh until Ctrl-C."""
    link, source = await open_remote(endpoint, run_id)
    with link:
        server = ViewerServer(host, port, source)
        url = await server.start()
        announce(f"viewer: {url}  (run {source.keys.run_id} at {endpoint}; Ctrl-C to quit)")
        try:
            await _until_interrupted()
        finally:
            await server.close()


async def serve_replay(trace: Path, host: str, port: int, announce: Callable[[str], None] = print,
                       verify: bool = True) -> None:
    """``swarmactors replay TRACE --view``: the page with a time slider, until Ctrl-C (``verify`` as Replay)."""
    from swarmactors.tools.replay import Replay

    server = ViewerServer(host, port, ReplaySource(Replay(trace, verify=verify)))
    url = await server.start()
    announce(f"viewer: {url}  (replay of {trace}; Ctrl-C to quit)")
    try:
        await _until_interrupted()
    finally:
        await server.close()


def warn_if_exposed(host: str) -> None:
    if host not in ("127.0.0.1", "localhost", "::1"):
        print(f"warning: the viewer on {host} is reachable from other machines over plain HTTP: anyone who "
              "sees its address with the token can pause the run and kill robots", file=sys.stderr)
