"""The realtime delivery timer (issue 22): never early, sub-millisecond late on an idle loop, in due order."""

from __future__ import annotations

import asyncio
import time

import numpy as np

from swarmactors.precise_timer import PreciseTimer


async def _collect(dues: list[float]) -> list[tuple[float, float]]:
    """(due, handed-over wall time) for items added with the given due times."""
    loop = asyncio.get_running_loop()
    got: list[tuple[float, float]] = []
    done = asyncio.Event()

    def on_due(items):
        now = time.time()
        got.extend((due, now) for due in items)
        if len(got) == len(dues):
            done.set()

    timer = PreciseTimer(loop, on_due, "test")
    try:
        for due in dues:
            timer.add(due, due)
        await asyncio.wait_for(done.wait(), 10)
    finally:
        timer.close()
    return got


async def test_items_are_never_handed_over_before_their_due_time():
    start = time.time() + 0.02
    rng = np.random.default_rng(1)
    dues = (start + rng.uniform(0, 0.2, 300)).tolist()
    got = await _collect(dues)
    assert sorted(d for d, _ in got) == sorted(dues)  # each once
    late = np.array([now - due for due, now in got])
    assert (late >= 0).all(), late.min()
    # an idle loop: typically tens of microseconds late (asyncio's own timers: up to a millisecond); the bound is
    # loose because this is a correctness test, not a benchmark: at load 10 on 2 cores the median reached 2 ms
    assert np.median(late) < 0.02, np.median(late)


async def test_items_are_handed_over_in_due_order_and_past_ones_at_once():
    now = time.time()
    dues = [now + 0.03, now - 1.0, now + 0.01, now + 0.02]
    got = await _collect(dues)
    handed = [d for d, _ in sorted(got, key=lambda x: (x[1], x[0]))]
    assert handed == sorted(dues)


async def test_close_drops_pending_items_and_stops_the_thread():
    loop = asyncio.get_running_loop()
    got = []
    timer = PreciseTimer(loop, got.extend, "test")
    timer.add(time.time() + 0.05, "late")
    timer.close()
    await asyncio.sleep(0.1)
    assert got == [] and not timer._thread.is_alive()
