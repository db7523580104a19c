"""Owned tasks: every task the host and the viewer start has an owner that awaits it.

asyncio keeps only weak references to tasks, and an exception in a task nobody awaits is lost. A
``TaskSet`` holds its tasks, logs the error of any task that fails, and on ``close()`` cancels the
rest and waits until they have ended.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable, Coroutine
from typing import Any

log = logging.getLogger(__name__)


class TaskSet:
    """Tasks started by one owner; ``close()`` cancels and awaits them."""

    def __init__(self, name: str, on_error: Callable[[BaseException], None] | None = None):
        self.name = name
        self.on_error = on_error
        self._tasks: set[asyncio.Task] = set()

    def __len__(self) -> int:
        return len(self._tasks)

    def spawn(self, coro: Coroutine[Any, Any, Any]) -> asyncio.Task:
        """Start ``coro`` as a task owned by this set."""
        task = asyncio.get_running_loop().create_task(coro)
        self._tasks.add(task)
        task.add_done_callback(self._done)
        return task

    def _done(self, task: asyncio.Task) -> None:
        self._tasks.discard(task)
        if task.cancelled():
            return
        exc = task.exception()
        if exc is not None:
            if self.on_error is not None:
                self.on_error(exc)
            else:
                log.error("%s: task %s failed: %r", self.name, task.get_name(), exc, exc_info=exc)

    async def close(self, timeout: float = 5.0) -> None:  # noqa: ASYNC109 — bounds how long cancelled tasks may take
        """Cancel every task still running and wait (at most ``timeout`` s) until they have ended."""
        tasks = list(self._tasks)
        for task in tasks:
            task.cancel()
        if tasks:
            _, late = await asyncio.wait(tasks, timeout=timeout)
            for task in late:
                log.error("%s: task %s did not end %.1f s after it was cancelled", self.name, task.get_name(),
                          timeout)
