"""The clocks (world/clock.py): the only code that advances time, driving begin/exchange/end in order."""

from __future__ import annotations

import asyncio
import time

import pytest

from world.clock import BUCKET_S, LockstepClock, RealtimeClock, make_clock


class Steps:
    """Records the order of the steps the clock drives, and the clock's tick and now at each."""

    def __init__(self, clock, on_begin=None):
        self.clock, self.log, self.on_begin = clock, [], on_begin

    def begin(self):
        self.log.append(("begin", self.clock.tick, self.clock.now()))
        if self.on_begin:
            self.on_begin(self.clock)

    async def exchange(self):
        self.log.append(("exchange", self.clock.tick))
        await asyncio.sleep(0)

    def end(self):
        self.log.append(("end", self.clock.tick))


def test_lockstep_runs_every_tick_in_order_and_now_is_the_tick():
    clock = LockstepClock(ticks=3, dt=0.5)
    steps = Steps(clock)
    asyncio.run(clock.run(steps))
    assert steps.log == [("begin", 0, 0.0), ("exchange", 0), ("end", 0), ("begin", 1, 1.0), ("exchange", 1),
                         ("end", 1), ("begin", 2, 2.0), ("exchange", 2), ("end", 2)]
    assert clock.ticks_done == 3


def test_tick_is_read_only():
    clock = LockstepClock(ticks=3, dt=1.0)
    with pytest.raises(AttributeError):
        clock.tick = 2


def test_lockstep_stop_ends_after_the_current_tick():
    clock = LockstepClock(ticks=10, dt=1.0)
    steps = Steps(clock, on_begin=lambda c: c.stop() if c.tick == 4 else None)
    asyncio.run(clock.run(steps))
    assert clock.ticks_done == 5 and steps.log[-1] == ("end", 4)


def test_lockstep_run_to_pauses_until_resumed():
    async def go():
        clock = LockstepClock(ticks=6, dt=1.0)
        steps = Steps(clock)
        clock.run_to(2)
        task = asyncio.create_task(clock.run(steps))
        for _ in range(50):
            await asyncio.sleep(0)
        assert clock.paused and clock.ticks_done == 2  # ticks 0 and 1 ran, tick 2 waits
        clock.resume()
        await task
        return clock

    assert asyncio.run(go()).ticks_done == 6


def test_realtime_ticks_follow_the_wall_clock():
    dt = 0.02
    clock = RealtimeClock(ticks=5, dt=dt)
    steps = Steps(clock)
    t0 = time.perf_counter()
    asyncio.run(clock.run(steps))
    wall = time.perf_counter() - t0
    assert clock.ticks_done == 5
    assert wall >= 5 * dt - 1e-3  # a tick never ends early
    begins = [now for name, _, *rest in steps.log if name == "begin" for now in rest]
    assert all(b2 > b1 for b1, b2 in zip(begins, begins[1:], strict=False))


def test_realtime_deliveries_are_never_early():
    async def go():
        clock = RealtimeClock(ticks=1, dt=1.0)
        fired = []
        loop = asyncio.get_running_loop()
        clock.on_due = lambda item: fired.append((item, loop.time()))
        start = loop.time()
        delays = [0.004, 0.001, 0.0102, 0.0101]
        clock.after(delays, list(range(4)))
        await asyncio.sleep(0.05)
        return start, delays, fired

    start, delays, fired = asyncio.run(go())
    assert sorted(i for i, _ in fired) == [0, 1, 2, 3]
    for item, at in fired:
        assert at - start >= delays[item] - 1e-6
        assert at - start <= delays[item] + BUCKET_S + 0.02  # one bucket plus the loop's own lateness


def test_make_clock_by_name():
    assert isinstance(make_clock("lockstep", 1, 1.0), LockstepClock)
    assert isinstance(make_clock("realtime", 1, 1.0), RealtimeClock)


def test_the_air_keeps_each_copy_once_and_never_lets_it_out_before_it_is_due():
    """The world's realtime bookkeeping (world/air.py): copies by slot of due times, each slot out at its end."""
    import numpy as np

    from world.air import Air, Copies
    from world.sim import BOOKKEEPING_S

    rng = np.random.default_rng(3)
    now = 1234.56789
    due = now + np.r_[rng.uniform(0.008, 0.012, 500), np.full(20, 0.01), [0.0]]
    n = len(due)
    air = Air(BOOKKEEPING_S)
    slots = air.put(Copies(np.arange(n), np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64),
                           np.arange(n), np.zeros(n, dtype=np.int64), due, np.zeros(n, dtype=bool), []))
    assert slots == sorted(set(slots)) and len(air) == n  # one timer a slot
    seen = []
    for slot in slots:
        end = slot * BOOKKEEPING_S
        out = air.pop(end)
        assert (out.due <= end + 1e-12).all()  # never before a copy's due time
        assert (end - out.due <= BOOKKEEPING_S + 1e-12).all()  # nor a slot after it
        seen += out.seq.tolist()
    assert sorted(seen) == list(range(n)) and len(air) == 0  # every copy once
