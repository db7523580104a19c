"""Sub-millisecond timers for realtime deliveries.

asyncio's timers wake through ``epoll_wait``, whose timeout is whole milliseconds: a delivery due at t fires up
to a millisecond later. This timer waits on its own thread with ``threading.Condition.wait`` (a futex with a
microsecond timeout), then hands the due items to the event loop with ``call_soon_threadsafe``, which wakes the
loop at once. Rule: an item is never handed over before its due time (wall clock, ``time.time()``); every item
due when the thread wakes goes to the loop in one batch.
"""

from __future__ import annotations

import asyncio
import heapq
import itertools
import threading
import time
from collections.abc import Callable
from typing import Any


class PreciseTimer:
    """Calls ``on_due(items)`` on ``loop`` once each item's wall-clock due time has passed."""

    def __init__(self, loop: asyncio.AbstractEventLoop, on_due: Callable[[list[Any]], None], name: str = "timer"):
        self._loop = loop
        self._on_due = on_due
        self._heap: list[tuple[float, int, Any]] = []
        self._order = itertools.count()
        self._cond = threading.Condition()
        self._closed = False
        self._thread = threading.Thread(target=self._run, name=f"precise-{name}", daemon=True)
        self._thread.start()

    def add(self, due: float, item: Any) -> None:
        """Hand ``item`` to ``on_due`` at wall time ``due`` (at once if it has passed)."""
        with self._cond:
            heapq.heappush(self._heap, (due, next(self._order), item))
            if self._heap[0][2] is item:
                self._cond.notify()

    def close(self) -> None:
        """Stop the thread; pending items are dropped."""
        with self._cond:
            self._closed = True
            self._heap.clear()
            self._cond.notify()
        self._thread.join(timeout=1.0)

    def _run(self) -> None:
        heap = self._heap
        while True:
            with self._cond:
                while not self._closed:
                    if not heap:
                        self._cond.wait()
                        continue
                    wait = heap[0][0] - time.time()
                    if wait <= 0:
                        break
                    self._cond.wait(wait)
                if self._closed:
                    return
                batch = []
                now = time.time()
                while heap and heap[0][0] <= now:
                    batch.append(heapq.heappop(heap)[2])
            if batch:
                try:
                    self._loop.call_soon_threadsafe(self._on_due, batch)
                except RuntimeError:  # the loop closed under us: the host is gone
                    return
