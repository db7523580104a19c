"""Test-only behaviours (importable by spawned host processes: tests/ is put on their sys.path)."""

from __future__ import annotations

from swarmactors import Behavior


class RandomWalk(Behavior):
    """Move in a direction drawn from the robot's own seeded generator, changed every few ticks."""

    name = "random_walk"

    def on_tick(self, ctx, sensed) -> None:
        if ctx.tick % 3 == 0:
            ctx.move(ctx.rng.normal(size=2))
        ctx.set_status(moved=ctx.tick)
