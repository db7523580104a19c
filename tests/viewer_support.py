"""A behaviour for the viewer's tests (importable by the CLI's processes: tests/ is put on their PYTHONPATH)."""

from __future__ import annotations

from swarmactors import Behavior


class Chain(Behavior):
    """Report a chain: every robot's ``parent`` is the robot with the id before its own."""

    name = "chain"

    def on_start(self, ctx) -> None:
        ctx.set_status(parent=ctx.id - 1 if ctx.id > 0 else None)
