"""The robot host: many robot actors in one asyncio loop over one Zenoh session.

A host joins the world (``world/join``), receives its robots (ids assigned by
the world), and runs them. In lockstep each step is one Zenoh query on
``up/{host}`` carrying all its robots' outputs of the previous tick; the reply
carries the next tick's inputs. In realtime the host publishes frames on
``up/{host}`` the moment its robots send them and handles deliveries as they
arrive on ``down/{host}``.

A robot whose hook raises is crashed (the error goes to the world and into
result.json); a robot whose step does not finish within ``watchdog_s`` is
crashed as ``watchdog``; the other robots carry on.
"""

from __future__ import annotations

import asyncio
import inspect
import logging
import time
import traceback
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from swarmactors.behavior import Behavior, Context, Frame, Sensed
from swarmactors.plugins import BEHAVIORS, resolve
from transport import Keys, Link, MalformedMessage, pack, seal, unpack

log = logging.getLogger(__name__)


class Robot:
    """One robot actor: its behaviours, its context, and what it will send."""

    def __init__(self, descr: dict, seed: int, clock: str):
        self.id = int(descr["id"])
        self.ctx = Context(self.id, np.random.default_rng([seed, self.id]), clock)
        self.ctx._encode = pack
        self.ctx.pose = np.array(descr["pose"], dtype=float)
        self.behaviors: list[Behavior] = []
        self.report_names: list[str] = []  # the name each behaviour's report goes under
        self.started = False
        self.error: str | None = None
        self.error_sent = False
        self.alive = True
        self.sent_status: dict[str, Any] = {}
        self.bad_bodies = 0
        try:
            for spec in descr.get("behaviors", []):
                params = {k: v for k, v in spec.items() if k not in ("use", "as")}
                b = resolve(BEHAVIORS, spec["use"])(**params)
                self.behaviors.append(b)
                self.report_names.append(spec.get("as") or type(b).name or spec["use"])
        except Exception as exc:  # a behaviour that cannot be built crashes its robot, not the host
            self.fail(exc)
        self._catch_all = [b.on_frame for b in self.behaviors if not b.kinds]
        self._by_kind: dict[str, list] = {}

    def handlers(self, kind: str) -> list:
        """The on_frame hooks for ``kind``: behaviours that own it, or own no kind at all."""
        hs = self._by_kind.get(kind)
        if hs is None:
            hs = self._by_kind[kind] = [b.on_frame for b in self.behaviors if b.kinds and kind in b.kinds]
            hs += self._catch_all
        return hs

    # -- one step --------------------------------------------------------
    def calls(self, frames: list[Frame], sensed) -> Iterator[tuple]:
        """The hook calls of one step, in order: start, frames (by src, seq), due timers, tick."""
        ctx = self.ctx
        if not self.started:
            self.started = True
            for b in self.behaviors:
                yield b.on_start, (ctx,)
        for frame in frames:
            for h in self.handlers(frame.kind):
                yield h, (ctx, frame)
        for fn in self.due_timers():
            yield fn, ()
        for b in self.behaviors:
            yield b.on_tick, (ctx, sensed)

    def frame_calls(self, frame: Frame) -> Iterator[tuple]:
        for h in self.handlers(frame.kind):
            yield h, (self.ctx, frame)

    def due_timers(self) -> list:
        timers = self.ctx._timers
        if not timers:
            return []
        now = self.ctx.now
        due = sorted(t for t in timers if t[0] <= now)
        self.ctx._timers = [t for t in timers if t[0] > now]
        return [fn for _, _, fn in due]

    def outputs(self) -> list:
        """``[id, velocity, frames, status changes, error]`` and reset the outbox."""
        ctx = self.ctx
        frames, ctx._outbox = ctx._outbox, []
        vel, ctx._velocity = ctx._velocity, None
        changed = None
        if ctx._status:
            sent = self.sent_status
            changed = {k: v for k, v in ctx._status.items() if k not in sent or sent[k] != v} or None
            if changed:
                sent.update(changed)
        if self.error:
            self.error_sent = True
        return [self.id, vel, frames, changed, self.error]

    def fail(self, exc: BaseException | str) -> None:
        if isinstance(exc, BaseException):
            tb = traceback.extract_tb(exc.__traceback__)
            where = f" at {tb[-1].filename.rsplit('/', 1)[-1]}:{tb[-1].lineno}" if tb else ""
            self.error = f"{exc.__class__.__name__}: {exc}{where}"
        else:
            self.error = exc
        self.alive = False
        log.warning("robot %d crashed: %s", self.id, self.error)

    def report(self) -> dict:
        rep: dict[str, Any] = {}
        for name, b in zip(self.report_names, self.behaviors):
            try:
                rep[name] = b.report()
            except Exception as exc:  # a broken report must not lose the others
                rep[name] = {"report_error": f"{exc.__class__.__name__}: {exc}"}
        if self.error:
            rep["_error"] = self.error
        if self.ctx.logs:
            rep["_log"] = self.ctx.logs[-50:]
        if self.bad_bodies:
            rep["_bad_bodies"] = self.bad_bodies
        return rep


def run_calls(robot: Robot, calls: Iterator[tuple]) -> Any:
    """Run hook calls until one returns an awaitable; return the rest as a coroutine, or None."""
    try:
        for fn, args in calls:
            result = fn(*args)
            if result is not None and inspect.isawaitable(result):
                return _finish(robot, result, calls)
    except Exception as exc:
        robot.fail(exc)
    return None


async def _finish(robot: Robot, first, rest: Iterator[tuple]) -> None:
    try:
        await first
        for fn, args in rest:
            result = fn(*args)
            if result is not None and inspect.isawaitable(result):
                await result
    except asyncio.CancelledError:
        raise
    except Exception as exc:
        robot.fail(exc)


class SensedView(Sequence):
    """What a robot sensed this tick, as ``Sensed`` items built only when read."""

    __slots__ = ("_ids", "_flat", "_dims")

    def __init__(self, ids: list[int], flat: list[float], dims: int):
        self._ids, self._flat, self._dims = ids, flat, dims

    def __len__(self) -> int:
        return len(self._ids)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(len(self)))]
        d = self._dims
        return Sensed(self._ids[i], np.array(self._flat[i * d : (i + 1) * d]))

    @property
    def ids(self) -> list[int]:
        return self._ids

    def positions(self) -> np.ndarray:
        """All sensed positions as an (n, dims) array."""
        return np.array(self._flat, dtype=float).reshape(len(self._ids), self._dims)


def decode_table(robots: dict[int, Robot], table: list) -> list[Frame | None]:
    """Decode each frame body of a downlink once; None for an undecodable body."""
    out: list[Frame | None] = []
    for src, kind, seq, body, sent in table:
        try:
            out.append(Frame(src, kind, unpack(body, what="frame body"), seq, sent))
        except MalformedMessage:
            out.append(None)
    return out


class RobotHost:
    """Joins the world and runs its robots until the world says stop."""

    def __init__(self, link: Link, keys: Keys, count: int | None = None):
        self.link = link
        self.keys = keys
        self.count = count
        self.robots: dict[int, Robot] = {}
        self.name = ""
        self.key = b""
        self.run_info: dict = {}
        self.tick = -1

    async def join(self, timeout: float = 60.0) -> None:
        req = pack({"count": self.count})
        deadline = time.monotonic() + timeout
        while True:
            try:
                reply = await self.link.query(self.keys.join, req, timeout=5.0)
                break
            except Exception as exc:
                if time.monotonic() > deadline:
                    raise RuntimeError(f"could not join {self.keys.join}: {exc}") from None
                await asyncio.sleep(0.2)
        info = unpack(reply, what="join reply")
        self.name = info["host"]
        self.key = info["key"]
        self.run_info = info["run"]
        for descr in info["robots"]:
            self._adopt(descr)
        self.link.declare_token(self.keys.alive(self.name))

    def _adopt(self, descr: dict) -> None:
        robot = Robot(descr, self.run_info["seed"], self.run_info["clock"])
        self.robots[robot.id] = robot

    async def run(self) -> None:
        if not self.name:
            await self.join()
        if self.run_info["clock"] == "lockstep":
            await self._run_lockstep()
        else:
            await self._run_realtime()

    # -- inputs common to both clocks -----------------------------------
    def _uplink(self, msg: dict) -> bytes:
        """An uplink message, sealed with this host's key (transport.auth)."""
        return seal(self.key, pack(msg))

    def _take_membership(self, msg: dict) -> None:
        for rid in msg.get("dead", ()):
            robot = self.robots.get(rid)
            if robot is not None:
                robot.alive = False
        for descr in msg.get("new", ()):
            self._adopt(descr)

    def _set_inputs(self, robot: Robot, pose: list, now: float, objects: dict) -> None:
        ctx = robot.ctx
        ctx.pose = np.array(pose, dtype=float)
        ctx.now = now
        ctx.tick = self.tick
        ctx.objects = objects

    # -- lockstep --------------------------------------------------------------
    async def _run_lockstep(self) -> None:
        uplink = self.keys.up(self.name)
        timeout = 24 * 3600.0  # the world's watchdog, not this query, bounds a step
        msg = unpack(await self.link.query(uplink, self._uplink({"h": self.name, "t": -1, "r": []}), timeout=timeout))
        while not (msg.get("stop") or msg.get("bye")):
            self.tick = msg["t"]
            out = await self._step_lockstep(msg)
            msg = unpack(await self.link.query(uplink, self._uplink({"h": self.name, "t": self.tick, "r": out}),
                                               timeout=timeout))
        if not (msg.get("gone") or msg.get("bye")):
            await self._send_reports(uplink)

    async def _step_lockstep(self, msg: dict) -> list:
        self._take_membership(msg)
        now, objects = msg["now"], msg.get("objects", {})
        frames = decode_table(self.robots, msg.get("frames", ()))
        bad = {k for k, f in enumerate(frames) if f is None}
        dims = len(msg["in"][0][1]) - 1 if msg["in"] else 2
        pending: dict[asyncio.Task, Robot] = {}
        stepped: list[Robot] = []
        for rid, pose, (ids, flat), refs in msg["in"]:
            robot = self.robots.get(rid)
            if robot is None or not robot.alive:
                if robot is not None and robot.error and not robot.error_sent:
                    stepped.append(robot)  # tell the world once why this robot is gone
                continue
            self._set_inputs(robot, pose, now, objects)
            inbox = [frames[k] for k in refs]
            if bad and not bad.isdisjoint(refs):
                robot.bad_bodies += sum(1 for f in inbox if f is None)
                inbox = [f for f in inbox if f is not None]
            rest = run_calls(robot, robot.calls(inbox, SensedView(ids, flat, dims)))
            if rest is not None:
                pending[asyncio.ensure_future(rest)] = robot
            stepped.append(robot)
        if pending:
            done, late = await asyncio.wait(pending, timeout=self.run_info["watchdog_s"])
            for task in late:
                task.cancel()
                pending[task].fail(f"watchdog: step of tick {self.tick} exceeded {self.run_info['watchdog_s']} s")
        return [robot.outputs() for robot in stepped]

    async def _send_reports(self, uplink: str) -> None:
        reports = {rid: r.report() for rid, r in self.robots.items()}
        try:
            await self.link.query(uplink, self._uplink({"h": self.name, "t": self.tick + 1, "r": [], "rep": reports}),
                                  timeout=30.0)
        except Exception as exc:
            log.warning("final report not acknowledged: %s", exc)

    # -- realtime ----------------------------------------------------------------
    async def _run_realtime(self) -> None:
        uplink = self.keys.up(self.name)
        self._stopped = asyncio.Event()
        self._epoch: float | None = None
        self._tasks: set[asyncio.Task] = set()
        self.link.subscribe(self.keys.down(self.name), self._on_down)
        await self.link.query(uplink, self._uplink({"h": self.name, "t": -1, "r": []}), timeout=30.0)
        # The epoch arrives with every tick's inputs; the registration reply predates the start.
        await self._stopped.wait()
        for task in list(self._tasks):
            task.cancel()
        await self._send_reports(uplink)

    def _rt_now(self) -> float:
        return time.time() - (self._epoch or time.time())

    def _on_down(self, key: str, payload: bytes) -> None:
        try:
            msg = unpack(payload, what="downlink")
        except MalformedMessage as exc:
            log.warning("%s", exc)
            return
        if msg.get("stop"):
            self._stopped.set()
            return
        touched: list[Robot] = []
        if "d" in msg:
            now = self._rt_now()
            for rid, src, kind, seq, body, sent in msg["d"]:
                robot = self.robots.get(rid)
                if robot is None or not robot.alive:
                    continue
                (frame,) = decode_table(self.robots, [[src, kind, seq, body, sent]])
                if frame is None:
                    robot.bad_bodies += 1
                    continue
                robot.ctx.now = now
                self._rt_run(robot, robot.frame_calls(frame))
                touched.append(robot)
        if "in" in msg:
            if "epoch" in msg:
                self._epoch = msg["epoch"]
            self.tick = msg["t"]
            self._take_membership(msg)
            objects = msg.get("objects", {})
            for rid, pose, (ids, flat), _ in msg["in"]:
                robot = self.robots.get(rid)
                if robot is None or not robot.alive:
                    if robot is not None and robot.error and not robot.error_sent:
                        touched.append(robot)
                    continue
                self._set_inputs(robot, pose, self._rt_now(), objects)
                self._rt_run(robot, robot.calls([], SensedView(ids, flat, len(pose) - 1)))
                touched.append(robot)
        self._rt_flush(touched)

    def _rt_run(self, robot: Robot, calls: Iterator[tuple]) -> None:
        rest = run_calls(robot, calls)
        if rest is None:
            return
        task = asyncio.ensure_future(asyncio.wait_for(rest, self.run_info["watchdog_s"]))
        self._tasks.add(task)

        def done(t: asyncio.Task) -> None:
            self._tasks.discard(t)
            if not t.cancelled() and isinstance(t.exception(), TimeoutError):
                robot.fail(f"watchdog: a hook exceeded {self.run_info['watchdog_s']} s")
            self._rt_flush([robot])

        task.add_done_callback(done)

    def _rt_flush(self, robots: list[Robot]) -> None:
        rows = [r.outputs() for r in dict.fromkeys(robots)]
        rows = [row for row in rows if row[1] is not None or row[2] or row[3] or row[4]]
        if rows:
            self.link.publish(self.keys.up(self.name), self._uplink({"h": self.name, "t": self.tick, "r": rows}))
