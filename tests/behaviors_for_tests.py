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


class Mutator(Behavior):
    """Robot 0 broadcasts a nested body at tick 1; robot ``mutator`` changes what it received.

    Every robot reports the body as it saw it at the end, and what it holds in ``ctx.objects``;
    robot ``mutator`` also scribbles on its own ``ctx.objects``.
    """

    name = "mutator"
    kinds = ("NEST",)

    def __init__(self, mutator: int = 1):
        self.mutator = mutator
        self.body = None
        self.objects = None

    def on_tick(self, ctx, sensed):
        if ctx.id == 0 and ctx.tick == 1:
            ctx.broadcast("NEST", {"list": [0, [1]], "map": {"a": {"b": 1}}, "n": 7})
        if ctx.id == self.mutator and ctx.objects:
            name = next(iter(ctx.objects))
            ctx.objects[name].append(99.0)
            ctx.objects["mine"] = [0.0, 0.0]
        self.objects = {k: list(v) for k, v in ctx.objects.items()}

    def on_frame(self, ctx, frame):
        self.body = frame.body
        if ctx.id == self.mutator:
            frame.body["list"].append(ctx.id)
            frame.body["list"][1].append(ctx.id)
            frame.body["map"]["a"]["b"] = ctx.id
            frame.body["map"]["new"] = True

    def report(self):
        return {"body": self.body, "objects": self.objects}


class BatchAndTimers(Behavior):
    """Records the order of hooks (lockstep) and when realtime timers fire against their due time.

    Robot 0 broadcasts PING at every tick; every robot logs hooks as ``[tick, hook]``. Each robot arms a timer of
    ``delay`` clock units at its first tick and records ``[due, fired_at]``.
    """

    name = "batch_timers"
    kinds = ("PING",)

    def __init__(self, delay: float = 0.05):
        self.delay = delay
        self.order: list = []
        self.timer: list | None = None
        self.batches = 0

    def on_start(self, ctx):
        due = ctx.now + self.delay

        def fire():
            self.timer = [due, ctx.now]
            self.order.append([ctx.tick, "timer"])

        ctx.after(self.delay, fire)

    def on_frame(self, ctx, frame):
        self.order.append([ctx.tick, "frame"])

    def on_batch(self, ctx):
        self.batches += 1
        self.order.append([ctx.tick, "batch"])

    def on_tick(self, ctx, sensed):
        self.order.append([ctx.tick, "tick"])
        if ctx.id == 0:
            ctx.broadcast("PING", ctx.tick)

    def report(self):
        return {"order": self.order[:40], "timer": self.timer, "batches": self.batches}


class ReadsContext(Behavior):
    """Reports the scenario values the context gives, and whether time can be assigned."""

    name = "reads_context"

    def __init__(self):
        self.seen = None

    def on_start(self, ctx):
        errors = []
        for attr in ("now", "tick", "dt", "range", "sensing", "clock"):
            try:
                setattr(ctx, attr, 5)
            except AttributeError:
                errors.append(attr)
        self.seen = {"dt": ctx.dt, "range": ctx.range, "sensing": ctx.sensing, "clock": ctx.clock,
                     "read_only": errors}

    def report(self):
        return {"seen": self.seen}


class HostImports(Behavior):
    """Reports, at the end of the run, which oracle-side modules its host process has imported, and its pid."""

    name = "host_imports"

    def report(self) -> dict:
        import os
        import sys

        oracle = sorted(m for m in sys.modules
                        if m.split(".")[0] in {"networkx", "scipy"} or m.startswith("swarmactors.runs.conformance"))
        return {"modules": oracle, "pid": os.getpid()}


class SeesSpace(Behavior):
    """Reports what ``ctx.map`` and ``ctx.rays`` tell it at its first tick (issue 14)."""

    name = "sees_space"

    def __init__(self):
        self.seen = None

    def on_tick(self, ctx, sensed):
        if self.seen is None:
            m = ctx.map
            self.seen = {"knows": m is not None, "rays": None if ctx.rays is None else list(ctx.rays),
                         "inside": None if m is None else m.inside([4.5, 5.0]),
                         "clear": None if m is None else m.clear(ctx.position[:2], [8.0, 5.0]),
                         "obstacles": None if m is None else len(m.obstacles)}

    def report(self):
        return {"seen": self.seen}
