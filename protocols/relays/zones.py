"""Swarm Relays' communication zones and link quality (002 Sec. III-A). Pure functions, robot side."""

from __future__ import annotations

import math

SAFE, CRITICAL, BREAKAWAY, OUT = "safe", "critical", "breakaway", "out"


def link_quality(d: float, z: float, delta: float) -> float:
    """e_ij from a robot's own distance measurement: 1 below delta, exp(-delta*d/Z) up to Z, 0 beyond (Sec. III-A)."""
    if d > z:
        return 0.0
    if d < delta:
        return 1.0
    return math.exp(-delta * d / z)


def zone(d: float, ds: float, dc: float, db: float) -> str:
    """The zone of a neighbour at distance d: safe (d <= ds), critical (<= dc), break-away (<= db), else out."""
    if d <= ds:
        return SAFE
    if d <= dc:
        return CRITICAL
    if d <= db:
        return BREAKAWAY
    return OUT


def robots_needed(path_length: float, ds: float) -> int:
    """Return n = ceil(d_path / d_s), the robots a chain along a path of that length needs (Sec. IV)."""
    return max(1, math.ceil(path_length / ds - 1e-9))
