"""The live Foxglove feed: ``run … --foxglove [PORT]``, ``view --foxglove`` and ``replay TRACE --foxglove``.

A ``FoxgloveFeed`` is a Foxglove WebSocket server (the ``foxglove-sdk`` package, bound to 127.0.0.1 unless told
otherwise) on which ``SwarmTopics`` publishes the topics of an MCAP export (docs/foxglove.md). It is an observer,
like the web viewer, and follows one of:

* a running world's scene (``follow``): in the world's process for ``run --foxglove`` (the viewer's sink beside
  the trace writer: exact positions, status, events and frames), or the world's ``state`` and ``events`` streams
  over Zenoh for ``view --foxglove`` (best-effort, no frame rows). It publishes the newest scene at most
  ``MAX_RATE`` times a second and spends at most ``DUTY`` of the time doing it (a publication that took d
  seconds waits d / DUTY before the next), and nothing while no client subscribes, so the run is never held
  up: the SDK sends from its own threads and drops the oldest messages of a client that reads too slowly;
* a trace (``play``): every tick record in order, at ``rate`` ticks a second, as the MCAP export writes them.

A client that subscribes gets the current scene at once, with the world and the bodies, as if latched.
Needs the ``[foxglove]`` extra; robot hosts never import it.
"""

from __future__ import annotations

import asyncio
import logging
import sys
import time
from collections.abc import Callable
from pathlib import Path

from swarmactors.robot.tasks import TaskSet
from swarmactors.tools.foxglove_topics import CHANNELS, SwarmTopics, channel_specs, sdk, tick_ns

log = logging.getLogger(__name__)

DEFAULT_PORT = 8765  # Foxglove's usual WebSocket port
MAX_RATE = 30.0  # publications per second, at most, of a followed scene
DUTY = 0.05  # share of the time a followed scene's publications may take
REPLAY_RATE = 10.0  # ticks per second of a played trace (the web viewer's default)


class FoxgloveFeed:
    """A Foxglove WebSocket server with the swarm's channels, and the task that publishes on them."""

    def __init__(self, host: str = "127.0.0.1", port: int = DEFAULT_PORT, name: str = "swarmactors"):
        self.host, self.port, self.name = host, port, name
        self.url = ""
        self.published = 0  # publications (updates of the scene) so far
        self._server = None
        self._context = None
        self._channels: dict = {}
        self._resend = False  # a client subscribed: send the current scene, world and bodies again
        self._subscribed: asyncio.Event | None = None  # set (from the server's thread) when a client subscribes
        self._tasks = TaskSet("foxglove feed")
        self._driver: asyncio.Task | None = None

    # ------------------------------------------------------------ lifecycle
    def start(self) -> str:
        """Start serving, from a coroutine (subscriptions wake the feed's tasks); returns the ``ws://`` address.

        The address has the real port when 0 was asked.
        """
        fg = sdk()
        from foxglove.websocket import Capability, ServerListener

        self._context = context = fg.Context()  # kept: channels and server live while their context does
        for spec in channel_specs():
            schema = fg.Schema(name=spec.schema_name, encoding=spec.schema_encoding, data=spec.schema)
            self._channels[spec.topic] = fg.Channel(spec.topic, schema=schema, message_encoding=spec.encoding,
                                                    context=context)
        feed, loop = self, asyncio.get_running_loop()
        self._subscribed = asyncio.Event()

        class Listener(ServerListener):
            def on_subscribe(self, client, channel) -> None:  # called on a thread of the SDK
                feed._resend = True
                loop.call_soon_threadsafe(feed._subscribed.set)

        try:
            self._server = fg.start_server(name=self.name, host=self.host, port=self.port, context=context,
                                           capabilities=[Capability.Time], server_listener=Listener())
        except Exception as exc:  # the SDK's error when the address is taken or unusable
            raise OSError(f"cannot serve Foxglove on {self.host}:{self.port}: {exc}") from None
        host = self.host if self.host not in ("0.0.0.0", "::", "") else "127.0.0.1"
        self.url = f"ws://{host}:{self._server.port}"
        return self.url

    async def close(self) -> None:
        self._driver = None
        await self._tasks.close()
        if self._server is not None:
            self._server.stop()
            self._server = None

    def _watched(self) -> bool:
        return any(ch.has_sinks() for ch in self._channels.values())

    def _send(self, messages: list[tuple[str, int, bytes]], now_ns: int) -> None:
        for topic, ns, data in messages:
            self._channels[topic].log(data, log_time=ns)
        if self._server is not None:
            self._server.broadcast_time(now_ns)
        self.published += 1

    def _switch(self, coro) -> None:
        if self._driver is not None:
            self._driver.cancel()
        self._driver = self._tasks.spawn(coro)

    # ------------------------------------------------------------ drivers
    def follow(self, source) -> None:
        """Publish the scene of ``source`` (a ``viewer.LiveSource``) as it changes, until another driver."""
        self._switch(self._follow(source))

    async def _follow(self, source) -> None:
        topics, last = None, None
        while True:
            started = time.perf_counter()
            scene = source.scene
            scene.sync()
            if topics is None or self._resend:
                topics, self._resend, last = SwarmTopics(getattr(source, "scenario", None) or {}), False, None
                topics.ranges.update(scene.ranges)
            if scene.t is not None and scene.t != last and self._watched():
                newest = scene.recent[-1] if scene.recent else None
                rec = newest if newest is not None and newest["t"] == scene.t else None
                self._send(topics.update(scene, rec), tick_ns(scene.t, topics.dt))
                last = scene.t
            spent = time.perf_counter() - started
            await asyncio.sleep(max(1.0 / MAX_RATE, spent / DUTY - spent))

    def play(self, trace: Path, rate: float = REPLAY_RATE, verify: bool = True) -> None:
        """Publish every tick record of ``trace`` at ``rate`` ticks a second once a client subscribes.

        A client that subscribes after the end starts it again from the first tick.
        """
        self._switch(self._play(trace, rate, verify))

    async def _play(self, trace: Path, rate: float, verify: bool) -> None:
        from swarmactors.tools.mcap_export import result_beside
        from swarmactors.tools.replay import Replay
        from swarmactors.tools.scene import Scene

        replay = Replay(trace, verify=verify)
        header = replay.header
        sc = header.get("scenario") or {}
        result = result_beside(Path(trace), header.get("run_id"))
        try:
            while True:
                self._subscribed.clear()
                if not self._watched():
                    await self._subscribed.wait()
                    await asyncio.sleep(0.05)  # the SDK attaches the client's sink just after telling us
                self._resend = False
                topics = SwarmTopics(sc)
                scene = Scene(run_id=header.get("run_id", ""), clock=header.get("clock", "lockstep"),
                              scenario=sc, mode="replay")
                if result is not None:
                    ranges = {int(k): r["range"] for k, r in result.get("robots", {}).items() if "range" in r}
                    scene.ranges.update(ranges)
                    topics.ranges.update(ranges)
                start, first = time.monotonic(), replay.first
                for rec in replay.records:
                    delay = start + (rec["t"] - first) / rate - time.monotonic()
                    if delay > 0:
                        await asyncio.sleep(delay)
                    scene.feed_record(rec)
                    self._send(topics.update(scene, rec, every_tick=True), tick_ns(rec["t"], topics.dt))
                    scene.events = []
                    if self._resend:  # a client came in during the replay: it gets the world and bodies now
                        self._resend = False
                        topics.objects_key = topics.bodies_key = None
                self._subscribed.clear()
                await self._subscribed.wait()  # at the end: start again when a client subscribes
        finally:
            replay.records.close()


def channels_help() -> str:
    """One line per topic, for the command line's help and the docs."""
    return "\n".join(f"  {topic}: {what}" for topic, (_, what) in CHANNELS.items())


# ---------------------------------------------------------------- entry points
class FoxgloveSession:
    """``run/world … --foxglove``: the feed beside the world in one event loop; after the run, the last tick."""

    def __init__(self, host: str, port: int, announce: Callable[[str], None] = print):
        self.feed = FoxgloveFeed(host, port)
        self.announce = announce
        self.loop = asyncio.new_event_loop()
        self.result = None

    def run(self, sc: dict, out_dir: Path, endpoints, run_id: str, processes: int, local_host: bool,
            on_tick=None):
        self.result = self.loop.run_until_complete(self._run(sc, out_dir, endpoints, run_id, processes, local_host,
                                                             on_tick))
        return self.result

    async def _run(self, sc, out_dir, endpoints, run_id, processes, local_host, on_tick):
        from swarmactors.runs.launcher import run_world
        from swarmactors.tools.viewer import LiveSource

        url = self.feed.start()
        self.announce(f"foxglove: {url}  (in Foxglove: Open connection, Foxglove WebSocket, this address)")

        def on_open(world, link) -> None:
            source = LiveSource.in_process(world, link, sc)
            source.scenario = sc
            self.feed.follow(source)

        try:
            return await run_world(sc, out_dir, endpoints, run_id, processes=processes, local_host=local_host,
                                   on_tick=on_tick, on_open=on_open)
        except BaseException:
            await self.feed.close()
            raise

    def linger(self) -> None:
        """Keep serving the run's last tick until Ctrl-C (not after an interrupted run), then close."""
        try:
            if self.result is not None and not self.result["interrupted"]:
                self.announce(f"foxglove: {self.feed.url} shows the run's last tick; the whole run: swarmactors "
                              "export RUN --format mcap, or replay RUN --foxglove; Ctrl-C to quit")
                from swarmactors.tools.viewer import _until_interrupted

                self.loop.run_until_complete(_until_interrupted())
        finally:
            self.loop.run_until_complete(self.feed.close())
            self.loop.close()


async def serve_remote(endpoint: str, run_id: str | None, host: str, port: int,
                       announce: Callable[[str], None] = print) -> None:
    """``swarmactors view --foxglove``: a live run found over Zenoh, until Ctrl-C."""
    from swarmactors.tools.viewer import _until_interrupted, open_remote

    link, source = await open_remote(endpoint, run_id)
    with link:
        feed = FoxgloveFeed(host, port)
        url = feed.start()
        announce(f"foxglove: {url}  (run {source.keys.run_id} at {endpoint}; Ctrl-C to quit)")
        feed.follow(source)
        try:
            await _until_interrupted()
        finally:
            await feed.close()


async def serve_replay(trace: Path, host: str, port: int, rate: float = REPLAY_RATE,
                       announce: Callable[[str], None] = print, verify: bool = True) -> None:
    """``swarmactors replay TRACE --foxglove``: the trace played at ``rate`` ticks a second, until Ctrl-C."""
    from swarmactors.tools.viewer import _until_interrupted

    feed = FoxgloveFeed(host, port)
    url = feed.start()
    announce(f"foxglove: {url}  (replay of {trace} at {rate:g} ticks/s once a client subscribes; Ctrl-C to quit)")
    feed.play(trace, rate, verify)
    try:
        await _until_interrupted()
    finally:
        await feed.close()


def warn_if_exposed(host: str) -> None:
    if host not in ("127.0.0.1", "localhost", "::1"):
        print(f"warning: the Foxglove feed on {host} shows the swarm to anyone who reaches it", file=sys.stderr)
