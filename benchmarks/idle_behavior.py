"""A benchmark behaviour that does nothing: the floor of what a robot-tick costs.

Robots running it send nothing and receive nothing; what a lockstep tick of them costs is the product's own
work (the world's tick, the host's step, the messages between them), none of it a behaviour's. Used by
``benchmarks/bench.py`` as ``use = "idle_behavior:Idle"`` with ``benchmarks/`` on ``sys.path``.
"""

from __future__ import annotations

from swarmactors import Behavior


class Idle(Behavior):
    """No hook does anything."""

    name = "idle"
