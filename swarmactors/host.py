"""The robot host: many robot actors in one asyncio loop over one Zenoh session.

A host joins the world (``world/join``), receives its robots (ids assigned by
the world), subscribes to ``down/{host}`` and registers with one query on
``up/{host}``. In lockstep each step is then one put on ``up/{host}`` carrying
all its robots' outputs of the tick; the next tick's inputs arrive as one put
on ``down/{host}`` (not as a query's reply: Zenoh keeps a query's state until
its timeout). In realtime the host publishes frames on ``up/{host}`` the moment
its robots send them and handles deliveries as they arrive on ``down/{host}``.

A robot whose hook raises is crashed (the error goes to the world and into
result.json); a robot whose step does not finish within ``watchdog_s`` is
crashed as ``watchdog``; the other robots carry on.
"""

from __future__ import annotations

import asyncio
import inspect
import logging
import os
import sys
import time
import traceback
from collections.abc import Collection, Iterator, Sequence
from typing import Any

import msgspec
import numpy as np

from swarmactors.behavior import Behavior, Context, Frame, Sensed
from swarmactors.knownmap import KnownMap
from swarmactors.plugins import RefusedBehavior, resolve_behavior
from swarmactors.precise_timer import LoopTimer, PreciseTimer, plain_loop, precise_loop
from swarmactors.robot_clock import robot_clock
from swarmactors.tasks import TaskSet
from transport import Keys, Link, MalformedMessage, pack, seal, unseal
from transport.auth import run_secret_from_env, verifies
from transport.messages import (
    PROTOCOL_VERSION,
    Deliveries,
    Downlink,
    FrameIn,
    Inputs,
    JoinReply,
    JoinRequest,
    RobotDescr,
    RobotOut,
    RunInfo,
    Stop,
    Uplink,
    decode,
    encode,
)

log = logging.getLogger(__name__)


# realtime: robots stepped (or handed frames) per event-loop callback: RT_SLICE on hosts of up to RT_SMALL_HOST
# robots, RT_SLICE_LARGE on bigger ones; between two slices the loop hands over the deliveries that fell due.
# Measured on a quiet machine (docs/benchmarks.md, "Realtime (issue 22): ... sliced hosts"): N = 1000, K = 2
# (500 robots a host) p50 / p99 of latency - c 2.1 / 7.7 ms unsliced, 1.35 / 5.6 with 128, 1.17 / 4.9 with 64;
# N = 100, K = 2: 16 gives the lower p50 (0.17 against 0.25 ms with 64).
RT_SLICE = 16
RT_SLICE_LARGE = 64
RT_SMALL_HOST = 256
# realtime: how long the thread holding the GIL keeps it when another thread waits (Python's default is 5 ms;
# Zenoh's callback threads need it to hand frames over on time)
RT_SWITCH_INTERVAL_S = 0.0002
# realtime: how a host waits for a delivery's due time: "loop", the event loop's own timers made precise
# (precise_timer.precise_loop; falls back to "thread" on a loop it cannot change), or "thread", a timer thread
# that posts to the loop (precise_timer.PreciseTimer). Benchmarks compare the two with SWARMACTORS_RT_TIMER.
RT_TIMER = os.environ.get("SWARMACTORS_RT_TIMER", "loop")
# Benchmarks only (benchmarks/latency_probe.py): with SWARMACTORS_RT_STAMPS=1 a realtime host records, per frame
# (key src << 32 | seq: an int, no tuple for the garbage collector to track), the wall time (time.time()) at which
# its downlink reached the loop, and in RT_BATCH, for the hand-over under way, when the timer fired for it, when
# the loop began it, and the run's epoch. Cheap on purpose (one dict entry per frame and message, three numbers
# per hand-over), so as not to change what it measures.
RT_STAMPS: dict[int, float] | None = {} if os.environ.get("SWARMACTORS_RT_STAMPS") == "1" else None
RT_BATCH = [0.0, 0.0, 0.0]


class WorldLost(RuntimeError):
    """The world went away (its liveliness token vanished, or it stopped answering) or lost this host."""


class Robot:
    """One robot actor: its behaviours, its context, and what it will send."""

    def __init__(self, descr: RobotDescr, run: RunInfo, allow: Collection[str] = ()):
        self.id = descr.id
        self.ctx = Context(self.id, np.random.default_rng([run.seed, self.id]), run.clock, dt=run.dt,
                           radio_range=descr.range, sensing_range=descr.sensing, kind=descr.kind)
        self.ctx._encode = pack
        self.ctx.pose = np.array(descr.pose, dtype=float)
        if descr.knows_map and run.map is not None:
            self.ctx._map = KnownMap.from_spec(run.map)  # its own copy
        self.ctx._own_clock = robot_clock(descr.clock_offset, descr.clock_drift, run.clock, run.dt)
        self.ctx._sensing_frame = descr.sensing_frame
        self.local = descr.sensing_frame == "local"
        self.behaviors: list[Behavior] = []
        self.report_names: list[str] = []  # the name each behaviour's report goes under
        self.started = False
        self.error: str | None = None
        self.traceback: str | None = None  # the full traceback of the exception that crashed it (result.json)
        self.error_sent = False
        self.alive = True
        self.sent_status: dict[str, Any] = {}
        self.bad_bodies = 0
        try:
            for spec in descr.behaviors:
                # only allowed Behavior subclasses are imported or called (plugins.resolve_behavior)
                cls = resolve_behavior(spec.get("use"), allow)
                if descr.sensing_frame not in cls.frames:
                    raise ValueError(f"behaviour {spec.get('use')!r} does not support sensing_frame = "
                                     f"{descr.sensing_frame!r} (it supports {', '.join(cls.frames)})")
                params = {k: v for k, v in spec.items() if k not in ("use", "as")}
                b = cls(**params)
                self.behaviors.append(b)
                self.report_names.append(spec.get("as") or type(b).name or spec["use"])
        except RefusedBehavior as exc:  # the world counts it under its own cause (world.uplink)
            self.fail(str(exc))
        except Exception as exc:  # a behaviour that cannot be built crashes its robot, not the host
            self.fail(exc)
        self._catch_all = [b.on_frame for b in self.behaviors if not b.kinds]
        self._by_kind: dict[str, list] = {}
        self._batch_hooks = [b.on_batch for b in self.behaviors if type(b).on_batch is not Behavior.on_batch]
        self._tick_hooks = [b.on_tick for b in self.behaviors]

    def handlers(self, kind: str) -> list:
        """The on_frame hooks for ``kind``: behaviours that own it, or own no kind at all."""
        hs = self._by_kind.get(kind)
        if hs is None:
            hs = self._by_kind[kind] = [b.on_frame for b in self.behaviors if b.kinds and kind in b.kinds]
            hs += self._catch_all
        return hs

    # -- one step --------------------------------------------------------
    # Each of these generators calls the hooks itself, in order, and yields only the awaitable a hook
    # returned (an ``async def`` hook): ``run_calls`` awaits it and resumes the generator. A plain hook
    # costs its own call and nothing else (no tuple per call, no check beyond ``is not None``).
    def start_calls(self) -> Iterator[Any]:
        """``on_start`` of every behaviour, once, before any other hook."""
        if not self.started:
            self.started = True
            ctx = self.ctx
            for b in self.behaviors:
                r = b.on_start(ctx)
                if r is not None and inspect.isawaitable(r):
                    yield r

    def calls(self, frames: list[Frame], sensed) -> Iterator[Any]:
        """The hooks of one lockstep step, in order: start, frames (by src, seq), batch, due timers, tick."""
        ctx = self.ctx
        if not self.started:
            yield from self.start_calls()
        by_kind = self._by_kind
        for frame in frames:
            hs = by_kind.get(frame.kind)
            if hs is None:
                hs = self.handlers(frame.kind)
            for h in hs:
                r = h(ctx, frame)
                if r is not None and inspect.isawaitable(r):
                    yield r
        if frames and self._batch_hooks:
            yield from self.batch_calls()
        if ctx._timers:
            for fn in self.due_timers():
                r = fn()
                if r is not None and inspect.isawaitable(r):
                    yield r
        for h in self._tick_hooks:
            r = h(ctx, sensed)
            if r is not None and inspect.isawaitable(r):
                yield r

    def frame_calls(self, frames: list[Frame]) -> Iterator[Any]:
        """Realtime: the hooks for one delivery batch: each frame, then ``on_batch`` (``on_start`` first)."""
        yield from self.start_calls()
        ctx = self.ctx
        for frame in frames:
            for h in self.handlers(frame.kind):
                r = h(ctx, frame)
                if r is not None and inspect.isawaitable(r):
                    yield r
        yield from self.batch_calls()

    def timer_calls(self, fn) -> Iterator[Any]:
        """Realtime: one due timer."""
        r = fn()
        if r is not None and inspect.isawaitable(r):
            yield r

    def batch_calls(self) -> Iterator[Any]:
        ctx = self.ctx
        for h in self._batch_hooks:
            r = h(ctx)
            if r is not None and inspect.isawaitable(r):
                yield r

    def due_timers(self) -> list:
        timers = self.ctx._timers
        if not timers:
            return []
        now = self.ctx.now
        due = sorted(t for t in timers if t[0] <= now)
        self.ctx._timers = [t for t in timers if t[0] > now]
        return [fn for _, _, fn in due]

    def outputs(self) -> RobotOut:
        """This robot's outputs since the last call (velocity, frames, status changes, error); resets the outbox."""
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
        return RobotOut(self.id, vel, frames, changed, self.error)

    def fail(self, exc: BaseException | str) -> None:
        if isinstance(exc, BaseException):
            tb = traceback.extract_tb(exc.__traceback__)
            where = f" at {tb[-1].filename.rsplit('/', 1)[-1]}:{tb[-1].lineno}" if tb else ""
            self.error = f"{exc.__class__.__name__}: {exc}{where}"
            self.traceback = "".join(traceback.format_exception(exc))
        else:
            self.error = exc
        self.alive = False
        log.info("robot %d crashed: %s", self.id, self.error)  # the run's summary counts them in one line

    def report(self) -> dict:
        rep: dict[str, Any] = {}
        for name, b in zip(self.report_names, self.behaviors, strict=True):
            try:
                rep[name] = b.report()
            except Exception as exc:  # a broken report must not lose the others
                rep[name] = {"report_error": f"{exc.__class__.__name__}: {exc}"}
        if self.error:
            rep["_error"] = self.error
        if self.traceback:
            rep["_traceback"] = self.traceback
        if not self.started:  # never stepped: its behaviours could not be built, or the run ended first
            rep["_started"] = False
        if self.ctx.logs:
            rep["_log"] = self.ctx.logs[-50:]
        if self.bad_bodies:
            rep["_bad_bodies"] = self.bad_bodies
        return rep


def run_calls(robot: Robot, calls: Iterator[Any]) -> Any:
    """Run hooks (``Robot.calls`` and the like) until one returns an awaitable; the rest as a coroutine, or None.

    A hook that raises crashes its robot, and the robot's later hooks of this step are not called.
    """
    try:
        for first in calls:
            return _finish(robot, first, calls)
    except Exception as exc:
        robot.fail(exc)
    return None


async def _finish(robot: Robot, first, rest: Iterator[Any]) -> None:
    try:
        await first
        for awaitable in rest:
            await awaitable
    except asyncio.CancelledError:
        raise
    except Exception as exc:
        robot.fail(exc)


class SensedView(Sequence):
    """What a robot sensed this tick, as ``Sensed`` items built only when read.

    Under local sensing each neighbour's numbers are (range, bearing[, elevation]), turned into a body-frame
    vector for ``pos``.
    """

    __slots__ = ("_ids", "_flat", "_dims", "_local")

    def __init__(self, ids: list[int], flat: list[float], dims: int, local: bool = False):
        self._ids, self._flat, self._dims, self._local = ids, flat, dims, local

    def __len__(self) -> int:
        return len(self._ids)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(len(self)))]
        d = self._dims
        row = self._flat[i * d : (i + 1) * d]
        if self._local:
            return Sensed(self._ids[i], _cartesian(np.array([row]), d)[0], row[0], row[1])
        return Sensed(self._ids[i], np.array(row))

    @property
    def ids(self) -> list[int]:
        return self._ids

    def positions(self) -> np.ndarray:
        """All sensed positions (body-frame vectors under local sensing) as an (n, dims) array."""
        rows = np.array(self._flat, dtype=float).reshape(len(self._ids), self._dims)
        return _cartesian(rows, self._dims) if self._local else rows


def _cartesian(rows: np.ndarray, dims: int) -> np.ndarray:
    """(range, bearing[, elevation]) rows as body-frame vectors (x ahead, y left[, z up])."""
    r, b = rows[:, 0], rows[:, 1]
    e = rows[:, 2] if dims > 2 else np.zeros(len(rows))
    out = [r * np.cos(e) * np.cos(b), r * np.cos(e) * np.sin(b)] + ([r * np.sin(e)] if dims > 2 else [])
    return np.column_stack(out)


_body_decoder = msgspec.msgpack.Decoder()


def decode_body(f: FrameIn, rab: list[float] | None = None) -> Frame | None:
    """A received frame with its body decoded (and its range and bearing); None for an undecodable body."""
    try:
        return Frame(f.src, f.kind, _body_decoder.decode(f.body), f.seq, f.sent, None if rab is None else tuple(rab))
    except msgspec.DecodeError:
        return None


def _unless_timeout(exc: BaseException) -> None:
    if not isinstance(exc, TimeoutError):
        log.error("robot task failed: %r", exc, exc_info=exc)


_UNSEEN = object()
_replace = msgspec.structs.replace


class FrameTable:
    """A downlink's frames, decoded once per host and handed out so that robots share nothing.

    A body is decoded once; an immutable one (a number, string, bytes, None) is shared by every receiver,
    a list or map is decoded again for each further receiver, so no robot sees another's changes.
    """

    __slots__ = ("_frames", "_given", "_again")

    def __init__(self, frames: list[FrameIn]):
        self._frames = frames
        self._given: list[Any] = [_UNSEEN] * len(frames)  # the first receiver's Frame (None: undecodable)
        self._again: list[bytes | None] = [None] * len(frames)  # the body to decode for further receivers

    def _first(self, k: int) -> Frame | None:
        f = self._frames[k]
        frame = self._given[k] = decode_body(f)
        if frame is not None and isinstance(frame.body, (list, dict)):
            self._again[k] = f.body
        return frame

    def frame(self, k: int) -> Frame | None:
        frame = self._given[k]
        if frame is _UNSEEN:
            return self._first(k)
        again = self._again[k]
        return frame if again is None else _replace(frame, body=_body_decoder.decode(again))

    def inbox(self, refs: list[int]) -> tuple[list[Frame], int]:
        """One robot's frames (its slice of the table, in order) and how many had a body that does not decode."""
        given, again = self._given, self._again
        out: list[Frame] = []
        bad = 0
        for k in refs:
            frame = given[k]
            if frame is _UNSEEN:
                frame = self._first(k)
            elif again[k] is not None:
                frame = _replace(frame, body=_body_decoder.decode(again[k]))
            if frame is None:
                bad += 1
            else:
                out.append(frame)
        return out, bad


class RobotHost:
    """Joins the world and runs its robots until the world says stop."""

    def __init__(self, link: Link, keys: Keys, count: int | None = None, allow: Collection[str] = (),
                 run_secret: bytes | None = None):
        """``allow``: the modules whose Behavior subclasses this host may build, beside registered entry points.

        ``run_secret`` (default: ``SWARMACTORS_RUN_SECRET``) authenticates the join reply; without it the join
        reply, and so the key that authenticates downlinks, is taken on trust.
        """
        self.allow = frozenset(allow)
        self.run_secret = run_secret if run_secret is not None else run_secret_from_env()
        self.bad_downlinks = 0  # downlinks and join replies dropped because they did not verify
        self.link = link
        self.keys = keys
        self.count = count
        self.robots: dict[int, Robot] = {}
        self.name = ""
        self.key = b""
        self.run_info: RunInfo | None = None
        self.tick = -1
        self.gone = False  # the world answered a step with Stop(gone): it had lost this host
        self._rt_slice = RT_SLICE  # realtime: robots per event-loop callback (set again when the run starts)

    async def join(
        self,
        timeout: float = 60.0,  # noqa: ASYNC109 — a deadline for retries; each join query keeps its own 5 s timeout
    ) -> None:
        req = encode(JoinRequest(self.count))
        deadline = time.monotonic() + timeout
        while True:
            try:
                reply = await self.link.query(self.keys.join, req, timeout=5.0,
                                              accept=self._verify_join if self.run_secret else None)
                if self.run_secret:
                    reply = unseal(self.run_secret, reply, what="join reply")
                break
            except Exception as exc:
                log.info("join of %s failed: %s", self.keys.join, exc)
                if time.monotonic() > deadline:
                    raise RuntimeError(f"could not join {self.keys.join}: {exc}") from None
                await asyncio.sleep(0.2)
        info = decode(reply, JoinReply, what="join reply")
        if info.version != PROTOCOL_VERSION:  # e.g. lockstep steps changed from queries to puts in version 3
            raise RuntimeError(f"the world speaks protocol version {info.version} and this host {PROTOCOL_VERSION}: "
                               "run the same swarmactors version on both")
        self.name = info.host
        self.key = info.key
        self.run_info = info.run
        for descr in info.robots:
            self._adopt(descr)
        self.link.declare_token(self.keys.alive(self.name))

    def _adopt(self, descr: RobotDescr) -> None:
        robot = Robot(descr, self.run_info, self.allow)
        self.robots[robot.id] = robot

    async def run(self) -> None:
        """Run the robots until the world says stop; WorldLost when the world dies first.

        The host watches the world's liveliness token: when it vanishes (the world's process died, or its
        session lease expired) the robots stop at once and WorldLost is raised, in either clock.
        """
        if not self.name:
            await self.join()
        world_gone = asyncio.Event()
        self.link.watch_liveliness(self.keys.world_alive, lambda _key, alive: alive or world_gone.set())
        clock = asyncio.ensure_future(self._run_lockstep() if self.run_info.clock == "lockstep"
                                      else self._run_realtime())
        watch = asyncio.ensure_future(world_gone.wait())
        try:
            await asyncio.wait({clock, watch}, return_when=asyncio.FIRST_COMPLETED)
            if not clock.done():  # the world's token went: a run that was ending anyway may still finish
                await asyncio.wait({clock}, timeout=0.5)
        finally:
            watch.cancel()
            if not clock.done():
                clock.cancel()
                await asyncio.wait({clock}, timeout=1.0)
        if clock.done() and not clock.cancelled() and (clock.exception() is None or not world_gone.is_set()):
            return clock.result()  # the run's own end (or its own error)
        raise WorldLost(f"lost the world of run {self.keys.run_id!r} at tick {self.tick}: its liveliness token "
                        "vanished (the world died, or its session dropped this host after a silence longer than "
                        "the lease, 2·watchdog_s + 5 s)")

    # -- common to both clocks -----------------------------------
    def _uplink(self, tick: int, rows: list[RobotOut] = (), reports: dict | None = None) -> bytes:
        """An uplink message, sealed with this host's key (transport.auth)."""
        return seal(self.key, encode(Uplink(self.name, tick, list(rows), reports)))

    def _take_membership(self, msg: Inputs) -> None:
        for rid in msg.dead:
            robot = self.robots.get(rid)
            if robot is not None:
                robot.alive = False
        for descr in msg.new:
            self._adopt(descr)

    def _set_inputs(self, robot: Robot, pose, now: float, objects: dict, known: list[str] | None,
                    rays: list[float] | None = None) -> None:
        """A robot's inputs of a tick into its context; ``pose`` (a list or an array row) is copied."""
        ctx = robot.ctx
        ctx._rays = None if rays is None else tuple(rays)
        ctx.pose = pose.copy() if type(pose) is np.ndarray else np.array(pose, dtype=float)  # its own array
        ctx._set_time(self.tick, now)
        # each robot its own dict, with the objects it knows (an empty one left empty is kept)
        if objects:
            ctx.objects = {name: list(pos) for name, pos in objects.items() if known is None or name in known}
        elif ctx.objects:
            ctx.objects = {}

    def _verify_join(self, data: bytes) -> bool:
        return self._verify(self.run_secret, data)

    def _verify(self, key: bytes, data: bytes) -> bool:
        """A reply or downlink sealed under ``key``; anything else is counted and dropped."""
        if verifies(key, data):
            return True
        self.bad_downlinks += 1
        log.warning("host %s dropped a downlink that fails authentication (%d so far)", self.name, self.bad_downlinks)
        return False

    async def _ask(self, uplink: str, data: bytes, timeout: float) -> Downlink:  # noqa: ASYNC109 — a Zenoh query's own timeout
        """One query on ``up/{host}`` (registration, final reports) and its authentic reply, decoded."""
        reply = await self.link.query(uplink, data, timeout=timeout, accept=lambda d: self._verify(self.key, d))
        return decode(unseal(self.key, reply, what="downlink"), Downlink, what="downlink")

    # -- lockstep --------------------------------------------------------------
    async def _run_lockstep(self) -> None:
        """Register, then step each tick's inputs from ``down/{host}`` and put the outputs on ``up/{host}``."""
        uplink = self.keys.up(self.name)
        self._inbox: asyncio.Queue[Downlink] = asyncio.Queue()
        self.link.subscribe(self.keys.down(self.name), self._on_down)
        msg = await self._ask(uplink, self._uplink(-1), 30.0)  # an Ack, or Stop(gone) if the world lost us already
        while not isinstance(msg, Stop):
            msg = await self._inbox.get()
            while isinstance(msg, Inputs):
                self.tick = msg.tick
                out = await self._step_lockstep(msg)
                self.link.publish(uplink, self._uplink(self.tick, out))
                msg = await self._inbox.get()
        self.gone = msg.gone
        if not (msg.gone or msg.bye):
            await self._send_reports(uplink)

    def _lockstep_down(self, msg: Downlink) -> None:
        """Queue a lockstep downlink, unless it is stale (a replay: inputs of a tick stepped, an old stop)."""
        if not isinstance(msg, Inputs | Stop):
            return
        if msg.tick <= self.tick if isinstance(msg, Inputs) else msg.tick < self.tick:
            self.bad_downlinks += 1
            log.warning("host %s dropped a stale downlink (tick %d, at tick %d)", self.name, msg.tick, self.tick)
            return
        self._inbox.put_nowait(msg)

    async def _step_lockstep(self, msg: Inputs) -> list[RobotOut]:
        self._take_membership(msg)
        now, objects = msg.now, msg.objects
        cols = msg.columns()
        poses, sptr, sids, sat, iptr, refs = (cols.poses, cols.sensed_ptr, cols.sensed_ids, cols.sensed_at,
                                              cols.inbox_ptr, cols.refs)
        known, rays, rab = msg.known, msg.rays, msg.rab
        frames = FrameTable(msg.frames)
        dims = msg.dims
        robots = self.robots
        pending: dict[asyncio.Task, Robot] = {}
        stepped: list[Robot] = []
        for i, rid in enumerate(cols.ids):
            robot = robots.get(rid)
            if robot is None or not robot.alive:
                if robot is not None and robot.error and not robot.error_sent:
                    stepped.append(robot)  # tell the world once why this robot is gone
                continue
            self._set_inputs(robot, poses[i], now, objects, None if known is None else known[i],
                             None if rays is None else rays[i])
            a, b = iptr[i], iptr[i + 1]
            if rab is not None and rab[i] is not None:  # each receiver's own range and bearing (frame.rab)
                rb = rab[i]
                inbox = [frames.frame(k) for k in refs[a:b]]
                inbox = [f if f is None else _replace(f, rab=(rb[2 * j], rb[2 * j + 1])) for j, f in enumerate(inbox)]
                if None in inbox:
                    robot.bad_bodies += inbox.count(None)
                    inbox = [f for f in inbox if f is not None]
            elif a < b:
                inbox, bad = frames.inbox(refs[a:b])
                if bad:
                    robot.bad_bodies += bad
            else:
                inbox = []
            a, b = sptr[i], sptr[i + 1]
            rest = run_calls(robot, robot.calls(inbox, SensedView(sids[a:b], sat[a * dims:b * dims], dims,
                                                                  robot.local)))
            if rest is not None:
                pending[asyncio.ensure_future(rest)] = robot
            stepped.append(robot)
        if pending:
            _, late = await asyncio.wait(pending, timeout=self.run_info.watchdog_s)
            for task in late:
                task.cancel()
                pending[task].fail(f"watchdog: step of tick {self.tick} exceeded {self.run_info.watchdog_s} s")
            if late:
                await asyncio.wait(late, timeout=1.0)  # the tasks this host started end with the step
        return [robot.outputs() for robot in stepped]

    async def _send_reports(self, uplink: str) -> None:
        reports = {rid: r.report() for rid, r in self.robots.items()}
        if self.bad_downlinks:
            for rep in reports.values():
                rep["_bad_downlinks"] = self.bad_downlinks  # this host's count, in each of its robots' report
        try:
            await self.link.query(uplink, self._uplink(self.tick + 1, (), reports), timeout=30.0)
        except Exception as exc:
            log.warning("final report not acknowledged: %s", exc)

    # -- realtime ----------------------------------------------------------------
    async def _run_realtime(self) -> None:
        uplink = self.keys.up(self.name)
        self._stopped = asyncio.Event()
        self._epoch: float | None = None
        # a hook's own errors crash its robot (run_calls); what reaches the set is the watchdog's timeout
        self._tasks = TaskSet(f"host {self.name}", on_error=_unless_timeout)
        self._loop = asyncio.get_running_loop()
        self._rt_next: tuple[Inputs, int] | None = None  # the tick being stepped, and its next robot's index
        self._rt_later: list[Robot] = []  # robots whose outputs leave at the loop's next pass (_rt_flush_soon)
        precise = RT_TIMER == "loop" and precise_loop(self._loop)
        self._timer = (LoopTimer(self._loop, self._deliver, stamped=RT_STAMPS is not None) if precise
                       else PreciseTimer(self._loop, self._deliver, self.name, stamped=RT_STAMPS is not None))
        switch = sys.getswitchinterval()
        sys.setswitchinterval(RT_SWITCH_INTERVAL_S)  # the timer and Zenoh threads get the GIL within this
        self._rt_slice = RT_SLICE if len(self.robots) <= RT_SMALL_HOST else RT_SLICE_LARGE
        for robot in self.robots.values():
            self._realtime_timers(robot)
        self.link.subscribe(self.keys.down(self.name), self._on_down)
        try:
            await self.link.query(uplink, self._uplink(-1), timeout=30.0)
            # The epoch arrives with every tick's inputs; the registration reply predates the start.
            await self._stopped.wait()
        finally:
            self._timer.close()
            if precise:
                plain_loop(self._loop)
            sys.setswitchinterval(switch)
        await self._tasks.close()
        await self._send_reports(uplink)

    def _realtime_timers(self, robot: Robot) -> None:
        """Realtime: a behaviour's timer fires at its due time, on this host's event loop."""

        def schedule(delay: float, fn) -> None:
            def fire() -> None:
                if robot.alive and not self._stopped.is_set():
                    robot.ctx._set_time(self.tick, self._rt_now())
                    self._rt_run(robot, robot.timer_calls(fn))
                    self._rt_flush_soon(robot)

            self._loop.call_later(max(0.0, delay), fire)

        robot.ctx._on_timer = schedule

    def _rt_now(self) -> float:
        return time.time() - (self._epoch or time.time())

    def _on_down(self, key: str, payload: bytes) -> None:
        """A message on ``down/{host}``: kept only when it is sealed under this host's key."""
        if not self._verify(self.key, payload):
            return
        try:
            msg = decode(unseal(self.key, payload, what="downlink"), Downlink, what="downlink")
        except MalformedMessage as exc:
            log.warning("%s", exc)
            return
        if self.run_info.clock == "lockstep":
            self._lockstep_down(msg)
            return
        if isinstance(msg, Stop):
            self._stopped.set()
            return
        if isinstance(msg, Deliveries):
            self._take_deliveries(msg)
            return
        if isinstance(msg, Inputs):
            if self._rt_next is not None:  # the previous tick's robots not stepped yet go first, all at once
                self._rt_tick(*self._rt_next, to_end=True)
            if msg.epoch is not None:
                self._epoch = msg.epoch
            self.tick = msg.tick
            self._take_membership(msg)
            for descr in msg.new:
                self._realtime_timers(self.robots[descr.id])
            self._rt_tick(msg, 0)

    def _rt_tick(self, msg: Inputs, start: int, to_end: bool = False) -> None:
        """Realtime: step the robots of one tick's inputs, a slice at a time, flushing after each slice.

        Between two slices the event loop runs whatever else is due (deliveries handed over by the precise
        timer, other hosts' frames), so a frame does not wait for a whole tick of other robots' hooks, and the
        frames of a slice leave as soon as the slice is done. Every robot is stepped once per tick's inputs,
        in order: the next tick's inputs first finish this one.
        """
        self._rt_next = None
        if self._stopped.is_set():
            return
        touched: list[Robot] = []
        end = len(msg.robots) if to_end else min(start + self._rt_slice, len(msg.robots))
        for row in msg.robots[start:end]:
            robot = self.robots.get(row.id)
            if robot is None or not robot.alive:
                if robot is not None and robot.error and not robot.error_sent:
                    touched.append(robot)
                continue
            self._set_inputs(robot, row.pose, self._rt_now(), msg.objects, row.objects, row.rays)
            ids, flat = row.sensed
            self._rt_run(robot, robot.calls([], SensedView(ids, flat, len(row.pose) - 1, robot.local)))
            touched.append(robot)
        self._rt_flush(touched)
        if end < len(msg.robots):
            self._rt_next = (msg, end)
            self._loop.call_soon(self._rt_resume, msg)

    def _rt_resume(self, msg: Inputs) -> None:
        if self._rt_next is not None and self._rt_next[0] is msg:
            self._rt_tick(*self._rt_next)

    def _take_deliveries(self, msg: Deliveries) -> None:
        """Realtime: copies already due are handed over now, the others go on the timer, one item per due time."""
        now = time.time()
        if RT_STAMPS is not None:
            RT_STAMPS.update(((f.src << 32) | f.seq, now) for f in msg.frames)
        dst, refs, due = (col.tolist() for col in msg.arrays())
        by_due: dict[float, list[int]] = {}  # each due time's copies, in the message's order
        for i, when in enumerate(due):
            got = by_due.get(when)
            if got is None:
                by_due[when] = [i]
            else:
                got.append(i)
        at_once = []
        for when, idx in by_due.items():
            copies = (msg, dst, refs, idx)
            if when <= now:
                at_once.append(copies)
            else:
                self._timer.add(when, copies)  # handed over at its due time, never earlier
        if at_once:
            self._deliver(at_once, now)

    def _deliver(self, groups: list[tuple[Deliveries, list[int], list[int], list[int]]], woke: float = 0.0) -> None:
        """Realtime: hand frames whose due time has come to their robots (one batch per robot).

        ``groups``: (a message, its receivers and frame indices as lists, the indices of its copies due now).
        ``woke``: when the timer fired for them (or they arrived already due); for the benchmarks' stamps only.
        """
        if self._stopped.is_set():
            return
        if RT_STAMPS is not None:
            RT_BATCH[:] = (woke, time.time(), self._epoch or 0.0)
        # Each robot's frames are decoded just before its hooks run, not all up front: the first robot's
        # on_frame does not wait for the whole batch's decoding. ``ctx.now`` is read per robot. Every copy's
        # body is decoded for its robot alone, so no robot sees another's changes.
        robots = self.robots
        by_robot: dict[int, list[tuple[FrameIn, list[float] | None]]] = {}
        for msg, dst, refs, idx in groups:
            table, rab = msg.frames, msg.rab
            for i in idx:
                copy = (table[refs[i]], None if rab is None else rab[i])
                got = by_robot.get(dst[i])
                if got is None:
                    by_robot[dst[i]] = [copy]
                else:
                    got.append(copy)
        touched = []
        for rid, copies in by_robot.items():
            robot = robots.get(rid)
            if robot is None or not robot.alive:
                continue
            frames = [decode_body(f, rb) for f, rb in copies]
            if None in frames:
                robot.bad_bodies += frames.count(None)
                frames = [f for f in frames if f is not None]
            if not frames:
                continue
            robot.ctx._set_time(self.tick, self._rt_now())
            self._rt_run(robot, robot.frame_calls(frames))
            touched.append(robot)
            if len(touched) == self._rt_slice:  # sent now, not after all
                self._rt_flush(touched)
                touched = []
        self._rt_flush(touched)

    def _rt_run(self, robot: Robot, calls: Iterator[tuple]) -> None:
        rest = run_calls(robot, calls)
        if rest is None:
            return
        task = self._tasks.spawn(asyncio.wait_for(rest, self.run_info.watchdog_s))

        def done(t: asyncio.Task) -> None:
            if not t.cancelled() and isinstance(t.exception(), TimeoutError):
                robot.fail(f"watchdog: a hook exceeded {self.run_info.watchdog_s} s")
            self._rt_flush_soon(robot)

        task.add_done_callback(done)

    def _rt_flush_soon(self, robot: Robot) -> None:
        """Realtime: flush ``robot``'s outputs once the loop has run the other callbacks ready now.

        Timers that fall due together fire in one pass of the event loop; their robots' frames then leave in
        one uplink instead of one each (a put per robot per timer overloads the world at N = 1000).
        """
        if not self._rt_later:
            self._loop.call_soon(self._rt_flush_later)
        self._rt_later.append(robot)

    def _rt_flush_later(self) -> None:
        robots, self._rt_later = self._rt_later, []
        self._rt_flush(robots)

    def _rt_flush(self, robots: list[Robot]) -> None:
        # a robot with nothing queued, no velocity, no status and no error to report is skipped at once
        rows = [r.outputs() for r in dict.fromkeys(robots)
                if r.ctx._outbox or r.ctx._velocity is not None or r.ctx._status or (r.error and not r.error_sent)]
        rows = [row for row in rows if row.velocity is not None or row.frames or row.status or row.error]
        if rows:
            self.link.publish(self.keys.up(self.name), self._uplink(self.tick, rows))
