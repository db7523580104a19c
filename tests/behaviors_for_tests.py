"""Small behaviours that only the tests use, referred to as ``behaviors_for_tests:Class``.

Under pytest ``tests/`` is on ``sys.path`` (rootdir conftest), and host processes
started with the ``spawn`` method inherit the parent's ``sys.path``; a test that
runs the CLI in a subprocess must put ``tests/`` on ``PYTHONPATH`` itself.
"""

from __future__ import annotations

import asyncio

from swarmactors import Behavior, Context, Frame


class Raiser(Behavior):
    """Robot ``who`` raises ``ValueError(f"{message} at tick {t}")`` in hook ``hook`` at tick ``at``.

    ``hook`` is one of ``on_start``, ``on_tick``, ``async_on_tick`` (raises after
    an ``await``) and ``on_frame`` (the first frame received at or after ``at``).
    Every other robot, and robot ``who`` before ``at``, does nothing.
    """

    name = "raiser"

    def __init__(self, who: int = 0, at: int = 3, hook: str = "on_tick", message: str = "boom"):
        self.who, self.at, self.hook, self.message = who, at, hook, message
        self.ticks_seen = 0

    def _boom(self, ctx: Context) -> None:
        raise ValueError(f"{self.message} at tick {ctx.tick}")

    def on_start(self, ctx: Context):
        if self.hook == "on_start" and ctx.id == self.who:
            self._boom(ctx)

    def on_tick(self, ctx: Context, sensed):
        self.ticks_seen += 1
        if ctx.id != self.who or ctx.tick != self.at:
            return None
        if self.hook == "on_tick":
            self._boom(ctx)
        if self.hook == "async_on_tick":
            return self._later(ctx)
        return None

    async def _later(self, ctx: Context) -> None:
        await asyncio.sleep(0)
        self._boom(ctx)

    def on_frame(self, ctx: Context, frame: Frame):
        if self.hook == "on_frame" and ctx.id == self.who and ctx.tick >= self.at:
            self._boom(ctx)

    def report(self) -> dict:
        return {"ticks_seen": self.ticks_seen}


class Hang(Behavior):
    """Robot ``who``'s ``on_tick`` at tick ``at`` awaits forever (a step that never ends)."""

    name = "hang"

    def __init__(self, who: int = 0, at: int = 3):
        self.who, self.at = who, at
        self.hung = False

    def on_tick(self, ctx: Context, sensed):
        if ctx.id == self.who and ctx.tick == self.at:
            self.hung = True
            return self._forever()
        return None

    async def _forever(self) -> None:
        await asyncio.get_running_loop().create_future()

    def report(self) -> dict:
        return {"hung": self.hung}


class RaiseInInit(Behavior):
    """A behaviour whose constructor raises: the robot cannot even be built."""

    name = "raise_in_init"

    def __init__(self, message: str = "cannot build this behaviour"):
        raise RuntimeError(message)
