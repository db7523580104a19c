"""The only code that advances time: a lockstep and a realtime driver behind one stepping interface.

Both drivers own the tick counter and ``now``, and run the same three steps of a tick on the world
(``TickSteps``): ``begin`` (events, reach, sensing, inputs out), ``exchange`` (the robots step), ``end``
(record, integrate motion). They differ only in what ends a tick:

* ``LockstepClock``: virtual time in ticks; a tick ends when every live host has stepped (the world's
  barrier), however long that takes. ``now`` is the tick number. It can be paused, stepped and run to a
  tick (the ``control`` queryable).
* ``RealtimeClock``: wall-clock time; tick k ends at ``start + (k + 1)·dt``. ``now`` is seconds since the
  start. It also schedules realtime deliveries (``after``): frames are delivered when their latency has
  elapsed, never earlier, with timers batched into buckets of ``BUCKET_S``.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import time
from collections.abc import Callable
from typing import Protocol

BUCKET_S = 0.0005  # realtime deliveries due within the same half millisecond share one timer


class TickSteps(Protocol):
    """What a clock drives: the three steps of one tick (world/world.py)."""

    def begin(self) -> None: ...

    async def exchange(self) -> None: ...

    def end(self) -> None: ...


class Clock:
    """Common state: the tick counter, the stop request, the wall-clock epoch."""

    name = ""

    def __init__(self, ticks: int, dt: float):
        self.ticks = ticks
        self.dt = dt
        self._tick = 0
        self.epoch = 0.0  # wall time (time.time()) of the run's start
        self.ticks_done = 0
        self.stopping = asyncio.Event()

    @property
    def tick(self) -> int:
        """The current tick (0-based)."""
        return self._tick

    def now(self) -> float:
        """The clock's time: ticks in lockstep, seconds since the start in realtime."""
        raise NotImplementedError

    def stop(self) -> None:
        """End the run after the current tick."""
        self.stopping.set()

    async def run(self, steps: TickSteps) -> None:
        """Drive ``steps`` through every tick until the end or a stop."""
        raise NotImplementedError

    def _start(self) -> None:
        self.epoch = time.time()


class LockstepClock(Clock):
    """Virtual time: a tick lasts as long as the slowest host's step."""

    name = "lockstep"

    def __init__(self, ticks: int, dt: float):
        super().__init__(ticks, dt)
        self._resume = asyncio.Event()
        self._resume.set()
        self._pause_at: int | None = None

    def now(self) -> float:
        return float(self._tick)

    @property
    def paused(self) -> bool:
        return not self._resume.is_set()

    def pause(self) -> None:
        self._resume.clear()

    def resume(self) -> None:
        self._pause_at = None
        self._resume.set()

    def run_to(self, tick: int) -> None:
        """Run until ``tick`` starts, then pause."""
        self._pause_at = tick
        self._resume.set()

    def stop(self) -> None:
        super().stop()
        self._resume.set()

    async def run(self, steps: TickSteps) -> None:
        self._start()
        for k in range(self.ticks):
            if self.stopping.is_set():
                break
            if self._pause_at is not None and k >= self._pause_at:
                self._resume.clear()
                self._pause_at = None
            await self._resume.wait()
            if self.stopping.is_set():
                break
            self._tick = k
            steps.begin()
            await steps.exchange()
            steps.end()
            self.ticks_done = k + 1


class RealtimeClock(Clock):
    """Wall-clock time: tick k spans [start + k·dt, start + (k+1)·dt); deliveries run on timers."""

    name = "realtime"

    def __init__(self, ticks: int, dt: float):
        super().__init__(ticks, dt)
        self._buckets: dict[int, list] = {}
        self.on_due: Callable[[object], None] = lambda item: None  # set by the world: deliver one item

    def now(self) -> float:
        return time.time() - self.epoch if self.epoch else 0.0

    async def run(self, steps: TickSteps) -> None:
        self._start()
        loop = asyncio.get_running_loop()
        start = loop.time()
        for k in range(self.ticks):
            if self.stopping.is_set():
                break
            self._tick = k
            steps.begin()
            await steps.exchange()
            delay = start + (k + 1) * self.dt - loop.time()
            if delay > 0:
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(self.stopping.wait(), delay)
            steps.end()
            self.ticks_done = k + 1

    def after(self, delays_s: list[float], items: list) -> None:
        """Call ``on_due(item)`` once each item's delay has elapsed (never earlier; timers share buckets)."""
        loop = asyncio.get_running_loop()
        now = loop.time()
        for delay, item in zip(delays_s, items, strict=True):
            # A bucket fires at its end, so never before the delay.
            bucket = math.ceil((now + delay) / BUCKET_S)
            due = self._buckets.get(bucket)
            if due is None:
                due = self._buckets[bucket] = []
                loop.call_at(bucket * BUCKET_S, self._fire, bucket)
            due.append(item)

    def _fire(self, bucket: int) -> None:
        for item in self._buckets.pop(bucket, ()):
            self.on_due(item)


def make_clock(name: str, ticks: int, dt: float) -> Clock:
    """The clock a scenario's ``run.clock`` names."""
    return {"lockstep": LockstepClock, "realtime": RealtimeClock}[name](ticks, dt)
