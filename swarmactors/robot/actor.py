"""One robot actor: its behaviours, its context, the order of its hooks, and what it will send.

A hook that raises crashes its robot (the error goes to the world and into result.json); the robot's later
hooks of that step are not called, and the other robots carry on.
"""

from __future__ import annotations

import asyncio
import inspect
import logging
import traceback
from collections.abc import Collection, Iterator
from typing import Any

import numpy as np

from swarmactors.robot.behavior import Behavior, Context, Frame, params_problem
from swarmactors.robot.knownmap import KnownMap
from swarmactors.robot.plugins import RefusedBehavior, resolve_behavior
from swarmactors.robot.robot_clock import robot_clock
from transport.messages import RobotDescr, RobotOut, RunInfo

log = logging.getLogger(__name__)


class Robot:
    """One robot actor: its behaviours, its context, and what it will send."""

    def __init__(self, descr: RobotDescr, run: RunInfo, allow: Collection[str] = ()):
        """Build the robot the world described; a behaviour refused or failing to build crashes it (``error``)."""
        self.id = descr.id
        self.ctx = Context(self.id, np.random.default_rng([run.seed, self.id]), run.clock, dt=run.dt,
                           radio_range=descr.range, sensing_range=descr.sensing, kind=descr.kind,
                           pose=descr.pose, sensing_frame=descr.sensing_frame,
                           known_map=KnownMap.from_spec(run.map) if descr.knows_map and run.map is not None else None,
                           own_clock=robot_clock(descr.clock_offset, descr.clock_drift, run.clock, run.dt))
        self.local = descr.sensing_frame == "local"
        self.behaviors: list[Behavior] = []
        self.report_names: list[str] = []  # the name each behaviour's report goes under
        self.started = False
        self.error: str | None = None
        self.traceback: str | None = None  # the full traceback of the exception that crashed it (result.json)
        self.error_sent = False
        self.alive = True
        self.sent_status: dict[str, Any] = {}
        self.bad_bodies = 0  # frames received whose body did not decode
        self.frames_sent = 0
        try:
            for spec in descr.behaviors:
                # only allowed Behavior subclasses are imported or called (plugins.resolve_behavior)
                cls = resolve_behavior(spec.get("use"), allow)
                if descr.sensing_frame not in cls.frames:
                    raise ValueError(f"behaviour {spec.get('use')!r} does not support sensing_frame = "
                                     f"{descr.sensing_frame!r} (it supports {', '.join(cls.frames)})")
                params = {k: v for k, v in spec.items() if k not in ("use", "as")}
                problem = params_problem(cls, params)  # the scenario's checks again: a spec may come from the wire
                if problem:
                    raise RefusedBehavior(f"refused behaviour {spec.get('use')!r}: {problem}")
                b = cls(**params)
                self.behaviors.append(b)
                self.report_names.append(spec.get("as") or type(b).name or spec["use"])
        except RefusedBehavior as exc:  # the world counts it under its own cause (world.uplink)
            self.fail(str(exc))
        except Exception as exc:  # a behaviour that cannot be built crashes its robot, not the host
            self.fail(exc)
        self._catch_all = [b.on_frame for b in self.behaviors if not b.kinds]
        self._by_kind: dict[str, list] = {}
        # on_batch only where a behaviour overrides it (the default does nothing)
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
            for fn in ctx._due_timers():
                r = fn()
                if r is not None and inspect.isawaitable(r):
                    yield r
        for h in self._tick_hooks:
            r = h(ctx, sensed)
            if r is not None and inspect.isawaitable(r):
                yield r

    def frame_calls(self, frames: list[Frame]) -> Iterator[Any]:
        """Realtime: the hooks for one delivery batch: each frame, then ``on_batch`` (``on_start`` first)."""
        if not self.started:
            yield from self.start_calls()
        ctx = self.ctx
        by_kind = self._by_kind
        for frame in frames:
            hs = by_kind.get(frame.kind)
            if hs is None:
                hs = self.handlers(frame.kind)
            for h in hs:
                r = h(ctx, frame)
                if r is not None and inspect.isawaitable(r):
                    yield r
        if self._batch_hooks:
            yield from self.batch_calls()

    def timer_calls(self, fn) -> Iterator[Any]:
        """Realtime: one due timer."""
        r = fn()
        if r is not None and inspect.isawaitable(r):
            yield r

    def batch_calls(self) -> Iterator[Any]:
        """``on_batch`` of the behaviours that override it."""
        ctx = self.ctx
        for h in self._batch_hooks:
            r = h(ctx)
            if r is not None and inspect.isawaitable(r):
                yield r

    def has_outputs(self) -> bool:
        """Whether ``outputs`` would carry anything: frames, a velocity, status fields or an error not yet sent."""
        return self.ctx._has_outputs() or (bool(self.error) and not self.error_sent)

    def outputs(self) -> RobotOut:
        """This robot's outputs since the last call (velocity, frames, status changes, error); resets the outbox."""
        frames, vel, status = self.ctx._take_outputs()
        self.frames_sent += len(frames)
        changed = None
        if status:
            sent = self.sent_status
            changed = {k: v for k, v in status.items() if k not in sent or sent[k] != v} or None
            if changed:
                sent.update(changed)
        if self.error:
            self.error_sent = True
        return RobotOut(self.id, vel, frames, changed, self.error)

    def fail(self, exc: BaseException | str) -> None:
        """Crash the robot: it runs no more hooks, and its next outputs carry ``error`` once."""
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
        """Its behaviours' reports by name, with its error, its last log lines and its undecodable frames."""
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
