"""The robots of one host, stepped from the world's inputs to their outputs: no Zenoh, no keys, no sealing.

``RobotRuntime`` is what a driver steps: the host session over Zenoh (``swarmactors.robot.session``), or an
in-process driver that hands it the same ``transport.messages`` structs the world would send. For the same
inputs it gives the same ``RobotOut`` rows, whoever drives it.
"""

from __future__ import annotations

import asyncio
import logging
import os
import time
from collections.abc import Callable, Collection, Iterable, Iterator
from typing import Any, Protocol

from swarmactors.robot.actor import Robot, run_calls
from swarmactors.robot.inputs import FrameTable, SensedView, decode_body, with_rab
from swarmactors.robot.tasks import TaskSet
from transport.messages import Deliveries, Inputs, RobotDescr, RobotOut, RunInfo

log = logging.getLogger(__name__)

# realtime: robots stepped (or handed frames) per event-loop callback: RT_SLICE on hosts of up to RT_SMALL_HOST
# robots, RT_SLICE_LARGE on bigger ones; between two slices the loop hands over the deliveries that fell due.
# Measured on a quiet machine (benchmarks/log/2026-12-02.md, "Every host is sliced"): N = 1000, K = 2
# (500 robots a host) p50 / p99 of latency - c 2.1 / 7.7 ms unsliced, 1.35 / 5.6 with 128, 1.17 / 4.9 with 64;
# N = 100, K = 2: 16 gives the lower p50 (0.17 against 0.25 ms with 64).
RT_SLICE = 16
RT_SLICE_LARGE = 64
RT_SMALL_HOST = 256
# Benchmarks only (benchmarks/latency_probe.py): with SWARMACTORS_RT_STAMPS=1 a realtime host records, per frame
# (key src << 32 | seq: an int, no tuple for the garbage collector to track), the wall time (time.time()) at which
# its downlink reached the loop, and in RT_BATCH, for the hand-over under way, when the timer fired for it, when
# the loop began it, and the run's epoch. Cheap on purpose (one dict entry per frame and message, three numbers
# per hand-over), so as not to change what it measures.
RT_STAMPS: dict[int, float] | None = {} if os.environ.get("SWARMACTORS_RT_STAMPS") == "1" else None
RT_BATCH = [0.0, 0.0, 0.0]

# realtime: copies of one Deliveries message due at one time (the message, its receivers and frame indices as
# lists, the indices of the copies): what ``take_deliveries`` gives the timer and the timer gives ``deliver``
DueCopies = tuple[Deliveries, list[int], list[int], list[int]]


class DueTimer(Protocol):
    """Realtime: hands each item to ``RobotRuntime.deliver`` once its wall-clock due time has passed.

    ``swarmactors.robot.precise_timer.LoopTimer`` and ``PreciseTimer`` are two (built with ``deliver`` as ``on_due``).
    """

    def add(self, due: float, item: DueCopies) -> None: ...


class RobotRuntime:
    """Steps a host's robots from inputs to outputs; the driver owns the transport and the clock.

    * ``RobotRuntime(run, allow, name)``, then ``adopt(descrs)`` with the robots the world gave this host (its
      ``JoinReply.robots``); ``robots`` maps id -> ``Robot``; ``tick`` is the last tick's inputs taken.
    * Lockstep: ``await step(inputs) -> list[RobotOut]`` for each tick's ``Inputs``: the robots that died
      (``inputs.dead``) stop, the new ones (``inputs.new``) are adopted, then every live robot of the inputs
      runs its hooks (``Robot.calls``); one row per robot stepped, or crashed since its last row. A step whose
      ``async def`` hooks take longer than ``run.watchdog_s`` crashes their robots as ``watchdog``.
    * Realtime: ``start_realtime(emit, timer)`` once, inside the running event loop; then ``take_inputs(inputs)``
      for each tick's inputs (robots stepped a slice at a time between the loop's other callbacks) and
      ``take_deliveries(msg)`` for each ``Deliveries``: copies already due are handed over at once, the others
      go to ``timer.add(due, item)``, which must call ``deliver([item, ...])`` at their due time. Rows leave
      through ``emit(rows)`` as robots produce them (after a slice, a batch, a timer). ``stop()`` ends the
      hand-overs; ``await close()`` ends the hooks' tasks.
    * ``reports()``: each robot's report by id (at the end of a run).
    """

    def __init__(self, run: RunInfo, allow: Collection[str] = (), name: str = ""):
        """``allow``: the modules whose Behavior subclasses may be built, beside registered entry points.

        ``name``: the host's, for log lines.
        """
        self.run = run
        self.name = name
        self.allow = frozenset(allow)
        self.robots: dict[int, Robot] = {}
        self.tick = -1
        self.epoch: float | None = None  # realtime: the world's start time (wall clock), from the inputs
        self.stopped = False
        self._loop: asyncio.AbstractEventLoop | None = None  # realtime only, from start_realtime
        self._emit: Callable[[list[RobotOut]], None] = lambda rows: None
        self._timer: DueTimer | None = None
        self._tasks: TaskSet | None = None
        self._slice = RT_SLICE
        self._next: tuple[Inputs, int] | None = None  # the tick being stepped, and its next robot's index
        self._later: list[Robot] = []  # robots whose outputs leave at the loop's next pass (_flush_soon)

    def adopt(self, descrs: Iterable[RobotDescr]) -> None:
        """Build the robots described (a behaviour that cannot be built crashes its robot, not the host)."""
        for descr in descrs:
            robot = self.robots[descr.id] = Robot(descr, self.run, self.allow)
            if self._loop is not None:
                self._realtime_timers(robot)

    def reports(self) -> dict[int, dict]:
        """Each robot's report (``Robot.report``), by id."""
        return {rid: r.report() for rid, r in self.robots.items()}

    def _take_membership(self, msg: Inputs) -> None:
        for rid in msg.dead:
            robot = self.robots.get(rid)
            if robot is not None:
                robot.alive = False
        self.adopt(msg.new)

    # -- lockstep --------------------------------------------------------------
    async def step(self, msg: Inputs) -> list[RobotOut]:
        """One lockstep tick: membership, then every live robot's hooks; the rows to send to the world."""
        self.tick = msg.tick
        self._take_membership(msg)
        tick, now, objects = msg.tick, msg.now, msg.objects
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
            robot.ctx._set_inputs(tick, now, poses[i], objects, None if known is None else known[i],
                                  None if rays is None else rays[i])
            a, b = iptr[i], iptr[i + 1]
            if rab is not None and rab[i] is not None:  # each receiver's own range and bearing (frame.rab)
                rb = rab[i]
                inbox = [frames.frame(k) for k in refs[a:b]]
                inbox = [f if f is None else with_rab(f, (rb[2 * j], rb[2 * j + 1])) for j, f in enumerate(inbox)]
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
            _, late = await asyncio.wait(pending, timeout=self.run.watchdog_s)
            for task in late:
                task.cancel()
                pending[task].fail(f"watchdog: step of tick {tick} exceeded {self.run.watchdog_s} s")
            if late:
                await asyncio.wait(late, timeout=1.0)  # the tasks this step started end with the step
        return [robot.outputs() for robot in stepped]

    # -- realtime ----------------------------------------------------------------
    def start_realtime(self, emit: Callable[[list[RobotOut]], None], timer: DueTimer,
                       slice_size: int | None = None) -> None:
        """Realtime, once, in the running loop: rows go to ``emit``, copies not yet due to ``timer``.

        ``slice_size``: robots stepped or handed frames per loop callback (default RT_SLICE, RT_SLICE_LARGE
        on hosts of more than RT_SMALL_HOST robots).
        """
        self._loop = asyncio.get_running_loop()
        self._emit, self._timer = emit, timer
        # a hook's own errors crash its robot (run_calls); what reaches the set is the watchdog's timeout
        self._tasks = TaskSet(f"host {self.name}", on_error=_unless_timeout)
        self._slice = slice_size or (RT_SLICE if len(self.robots) <= RT_SMALL_HOST else RT_SLICE_LARGE)
        for robot in self.robots.values():
            self._realtime_timers(robot)

    def stop(self) -> None:
        """Realtime: hand nothing more to the robots (no inputs, deliveries or timers)."""
        self.stopped = True

    async def close(self) -> None:
        """Realtime: cancel the hooks still running and wait until they have ended."""
        if self._tasks is not None:
            await self._tasks.close()

    def now(self) -> float:
        """Realtime: seconds since the world's start (``epoch``), on this machine's wall clock."""
        return time.time() - (self.epoch or time.time())

    def take_inputs(self, msg: Inputs) -> None:
        """Realtime: a tick's inputs: membership, then each robot's ``on_tick``, a slice at a time.

        Between two slices the event loop runs whatever else is due (deliveries handed over by the timer, other
        hosts' frames), so a frame does not wait for a whole tick of other robots' hooks, and the frames of a
        slice leave as soon as the slice is done. Every robot is stepped once per tick's inputs, in order: the
        next tick's inputs first finish this one.
        """
        if self._next is not None:  # the previous tick's robots not stepped yet go first, all at once
            self._step_slice(*self._next, to_end=True)
        if msg.epoch is not None:
            self.epoch = msg.epoch
        self.tick = msg.tick
        self._take_membership(msg)
        self._step_slice(msg, 0)

    def _step_slice(self, msg: Inputs, start: int, to_end: bool = False) -> None:
        self._next = None
        if self.stopped:
            return
        touched: list[Robot] = []
        end = len(msg.robots) if to_end else min(start + self._slice, len(msg.robots))
        for row in msg.robots[start:end]:
            robot = self.robots.get(row.id)
            if robot is None or not robot.alive:
                if robot is not None and robot.error and not robot.error_sent:
                    touched.append(robot)
                continue
            robot.ctx._set_inputs(self.tick, self.now(), row.pose, msg.objects, row.objects, row.rays)
            ids, flat = row.sensed
            self._run(robot, robot.calls([], SensedView(ids, flat, len(row.pose) - 1, robot.local)))
            touched.append(robot)
        self._flush(touched)
        if end < len(msg.robots):
            self._next = (msg, end)
            self._loop.call_soon(self._resume, msg)

    def _resume(self, msg: Inputs) -> None:
        if self._next is not None and self._next[0] is msg:
            self._step_slice(*self._next)

    def take_deliveries(self, msg: Deliveries) -> None:
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
            self.deliver(at_once, now)

    def deliver(self, groups: list[DueCopies], woke: float = 0.0) -> None:
        """Realtime: hand copies whose due time has come to their robots (one batch per robot), the timer's call.

        ``woke``: when the timer fired for them (or they arrived already due); for the benchmarks' stamps only.
        """
        if self.stopped:
            return
        if RT_STAMPS is not None:
            RT_BATCH[:] = (woke, time.time(), self.epoch or 0.0)
        # Each robot's frames are decoded just before its hooks run, not all up front: the first robot's
        # on_frame does not wait for the whole batch's decoding. ``ctx.now`` is read per robot. Every copy's
        # body is decoded for its robot alone, so no robot sees another's changes.
        robots = self.robots
        # each robot's copies in order: a FrameIn, or (FrameIn, its range and bearing) under rab
        by_robot: dict[int, list[Any]] = {}
        for msg, dst, refs, idx in groups:
            table, rab = msg.frames, msg.rab
            for i in idx:
                copy = table[refs[i]] if rab is None or rab[i] is None else (table[refs[i]], rab[i])
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
            frames = [decode_body(c) if type(c) is not tuple else decode_body(*c) for c in copies]
            if None in frames:
                robot.bad_bodies += frames.count(None)
                frames = [f for f in frames if f is not None]
            if not frames:
                continue
            robot.ctx._set_time(self.tick, self.now())
            self._run(robot, robot.frame_calls(frames))
            touched.append(robot)
            if len(touched) == self._slice:  # sent now, not after all
                self._flush(touched)
                touched = []
        self._flush(touched)

    def _realtime_timers(self, robot: Robot) -> None:
        """Realtime: a behaviour's timer fires at its due time, on the event loop."""

        def schedule(delay: float, fn) -> None:
            def fire() -> None:
                if robot.alive and not self.stopped:
                    robot.ctx._set_time(self.tick, self.now())
                    self._run(robot, robot.timer_calls(fn))
                    self._flush_soon(robot)

            self._loop.call_later(max(0.0, delay), fire)

        robot.ctx._schedule_with(schedule)

    def _run(self, robot: Robot, calls: Iterator[Any]) -> None:
        rest = run_calls(robot, calls)
        if rest is None:
            return
        task = self._tasks.spawn(asyncio.wait_for(rest, self.run.watchdog_s))

        def done(t: asyncio.Task) -> None:
            if not t.cancelled() and isinstance(t.exception(), TimeoutError):
                robot.fail(f"watchdog: a hook exceeded {self.run.watchdog_s} s")
            self._flush_soon(robot)

        task.add_done_callback(done)

    def _flush_soon(self, robot: Robot) -> None:
        """Flush ``robot``'s outputs once the loop has run the other callbacks ready now.

        Timers that fall due together fire in one pass of the event loop; their robots' frames then leave in
        one uplink instead of one each (a put per robot per timer overloads the world at N = 1000).
        """
        if not self._later:
            self._loop.call_soon(self._flush_later)
        self._later.append(robot)

    def _flush_later(self) -> None:
        robots, self._later = self._later, []
        self._flush(robots)

    def _flush(self, robots: list[Robot]) -> None:
        # a robot with nothing queued, no velocity, no status and no error to report is skipped at once
        rows = [r.outputs() for r in dict.fromkeys(robots) if r.has_outputs()]
        rows = [row for row in rows if row.velocity is not None or row.frames or row.status or row.error]
        if rows:
            self._emit(rows)


def _unless_timeout(exc: BaseException) -> None:
    if not isinstance(exc, TimeoutError):
        log.error("robot task failed: %r", exc, exc_info=exc)
