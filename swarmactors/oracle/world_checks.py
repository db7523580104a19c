"""Checks of the world's own rules (not of a protocol): ``world.no_collisions``."""

from __future__ import annotations

from swarmactors.oracle.checks import Outcome
from swarmactors.oracle.result import Result


def no_collisions(result: Result) -> list[Outcome]:
    """No two bodies, and no body and obstacle, overlapped during the run (world/space.py's episodes)."""
    col = result["world"].get("collisions") or {"robot_robot": 0, "robot_obstacle": 0, "episodes": []}
    total = col["robot_robot"] + col["robot_obstacle"]
    first = min((e["start"] for e in col["episodes"]), default=None)
    detail = (f"{col['robot_robot']} robot-robot and {col['robot_obstacle']} robot-obstacle collision episodes"
              + (f"; first: {col['episodes'][0]['collision']} from tick {first}" if col["episodes"] else ""))
    return [Outcome("world.no_collisions", total == 0, total, 0, detail, first, op="=")]
