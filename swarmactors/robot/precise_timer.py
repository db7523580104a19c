"""Sub-millisecond timers for realtime deliveries.

asyncio's timers wake through ``epoll_wait``, whose timeout is whole milliseconds: a delivery due at t fires up
to a millisecond later. Two ways past that, both with one rule: an item is never handed over before its due time
(wall clock, ``time.time()``), and every item due when the timer fires goes to ``on_due`` in one batch.

* ``precise_loop`` + ``LoopTimer`` (what a realtime host uses): the loop's selector is wrapped so that it waits
  on the epoll descriptor with ``select(2)`` (a microsecond timeout) and then collects the events without
  waiting; the items are ordinary loop timers. One wake-up per due time, no thread. With K = 0 (robots in the
  world's process) the loop is the world's too, whose own timers then also wake on time.
* ``PreciseTimer``: a thread that waits with ``threading.Condition.wait`` (a futex with a microsecond timeout)
  and hands the due items to the loop with ``call_soon_threadsafe``. Used where the loop cannot be wrapped, or
  with ``SWARMACTORS_RT_TIMER=thread``; it costs a second wake-up and a GIL hand-off per batch.
"""

from __future__ import annotations

import asyncio
import heapq
import itertools
import select
import sys
import threading
import time
from collections.abc import Callable
from typing import Any


class PreciseTimer:
    """Calls ``on_due(items)`` on ``loop`` once each item's wall-clock due time has passed."""

    def __init__(self, loop: asyncio.AbstractEventLoop, on_due: Callable[..., None], name: str = "timer",
                 stamped: bool = False):
        """``stamped``: call ``on_due(items, woke)`` with the wall time at which the thread took them."""
        self._stamped = stamped
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
                    if self._stamped:
                        self._loop.call_soon_threadsafe(self._on_due, batch, now)
                    else:
                        self._loop.call_soon_threadsafe(self._on_due, batch)
                except RuntimeError:  # the loop closed under us: the host is gone
                    return


# -- the event loop's own timers, made precise --------------------------------------------------------------------
_FD_SETSIZE = 1024  # select(2) takes descriptors below this


class _PreciseSelector:
    """Wraps an asyncio loop's selector so that its wait has microsecond resolution.

    ``EpollSelector.select`` rounds its timeout up to whole milliseconds (``epoll_wait``). This one first waits
    on the epoll descriptor itself with ``select(2)``, whose timeout is in microseconds, then collects the
    events without waiting. Everything else goes to the wrapped selector.
    """

    def __init__(self, inner: Any):
        self._inner = inner
        self._fd = inner.fileno()
        self.users = 1  # precise_loop calls not yet undone (several hosts may share one loop)

    def select(self, timeout: float | None = None):
        if timeout is not None and timeout > 0:
            select.select([self._fd], [], [], timeout)
            timeout = 0
        return self._inner.select(timeout)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._inner, name)


def precise_loop(loop: asyncio.AbstractEventLoop) -> bool:
    """Give ``loop``'s timers microsecond resolution (True), or leave it alone when it cannot be done (False).

    Works on asyncio's selector event loop with an epoll (or other pollable) selector; a loop of another kind
    (uvloop, the Windows proactor) keeps its own timers. The calling thread's timer slack is also lowered to
    1 µs where Linux allows it (``prctl``), so its sleeps are not rounded up by the default 50 µs.
    """
    sel = getattr(loop, "_selector", None)
    if isinstance(sel, _PreciseSelector):
        sel.users += 1
        return True
    if sel is None or not hasattr(sel, "fileno") or not hasattr(sel, "select"):
        return False
    try:
        fd = sel.fileno()
    except Exception:
        return False
    if not isinstance(fd, int) or fd < 0 or fd >= _FD_SETSIZE:
        return False
    loop._selector = _PreciseSelector(sel)
    _low_timer_slack()
    return True


def plain_loop(loop: asyncio.AbstractEventLoop) -> None:
    """Undo one ``precise_loop`` call (the loop is plain again once every caller has undone its own)."""
    sel = getattr(loop, "_selector", None)
    if isinstance(sel, _PreciseSelector):
        sel.users -= 1
        if sel.users <= 0:
            loop._selector = sel._inner


def _low_timer_slack() -> None:
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(29, 1000, 0, 0, 0)  # PR_SET_TIMERSLACK, in nanoseconds
    except Exception:  # no libc symbol, a sandbox: the default slack only costs tens of microseconds
        pass


class LoopTimer:
    """``PreciseTimer``'s contract on the event loop's own timers (``precise_loop``): no thread, no GIL hand-off.

    Items with the same due time share one loop timer. When one fires, every item already due goes to
    ``on_due`` in one batch, in due order (a loop that was busy when several fell due hands them over
    together, as the thread does). A timer that fires before its wall-clock due time (the loop runs on the
    monotonic clock; the two may drift apart by microseconds) is set again for the rest: never early.
    """

    def __init__(self, loop: asyncio.AbstractEventLoop, on_due: Callable[..., None], stamped: bool = False):
        self._loop = loop
        self._on_due = on_due
        self._stamped = stamped
        self._pending: dict[float, list[Any]] = {}
        self._handles: dict[float, asyncio.TimerHandle] = {}
        self._dues: list[float] = []  # heap of the pending due times
        self._closed = False

    def add(self, due: float, item: Any) -> None:
        """Hand ``item`` to ``on_due`` at wall time ``due`` (on the loop, soon, if it has passed)."""
        if self._closed:
            return
        items = self._pending.get(due)
        if items is not None:
            items.append(item)
            return
        self._pending[due] = [item]
        heapq.heappush(self._dues, due)
        self._arm(due)

    def _arm(self, due: float) -> None:
        loop = self._loop
        self._handles[due] = loop.call_at(loop.time() + (due - time.time()), self._fire, due)

    def _fire(self, due: float) -> None:
        now = time.time()
        if now < due:  # the clocks drifted: never early
            self._arm(due)
            return
        dues, pending, handles = self._dues, self._pending, self._handles
        batch: list[Any] = []
        while dues and dues[0] <= now:
            d = heapq.heappop(dues)
            batch += pending.pop(d)
            h = handles.pop(d)
            if d != due:
                h.cancel()
        if batch:
            if self._stamped:
                self._on_due(batch, now)
            else:
                self._on_due(batch)

    def close(self) -> None:
        """Pending items are dropped."""
        self._closed = True
        for h in self._handles.values():
            h.cancel()
        self._handles.clear()
        self._pending.clear()
        self._dues.clear()
