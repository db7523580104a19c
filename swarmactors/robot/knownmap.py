"""``ctx.map``: the run's static obstacles, given to a robot as prior knowledge (its group's ``knows_map``).

Swarm Relays' robots plan on a known map; this is that map and nothing else (never other robots). Each
robot gets its own copy, built from the same resolved shapes the world uses (``transport.space``), so a
robot's idea of a wall is exactly the world's.
"""

from __future__ import annotations

import copy
from functools import lru_cache

import numpy as np

from transport import pack
from transport.space import Space, space_from_spec


class KnownMap:
    """Read-only queries on the static map (points and segments in world coordinates)."""

    def __init__(self, space: Space, spec: dict):
        self._space = space
        self._spec = spec

    @classmethod
    def from_spec(cls, spec: dict) -> KnownMap:
        """A robot's own copy of the map described by ``spec`` (``{"dims", "obstacles", "map"}``)."""
        return cls(copy.deepcopy(_parsed(pack(spec))), copy.deepcopy(spec))

    @property
    def dims(self) -> int:
        return 2 if self._space.flat else 3

    @property
    def obstacles(self) -> list[dict]:
        """The convex obstacles: ``{"xy": [[x, y], ...], "z": [lo, hi] | None}`` (a copy)."""
        return copy.deepcopy(self._spec.get("obstacles") or [])

    @property
    def grid(self) -> dict | None:
        """The grid map in its resolved form (cell, origin, layers of rows, water, markers), or None (a copy)."""
        return copy.deepcopy(self._spec.get("map"))

    def inside(self, point, ground: bool = True) -> bool:
        """Whether ``point`` lies inside an obstacle (water counts for ``ground``)."""
        return bool(self._space.inside(_pts([point]), ground)[0])

    def inside_all(self, points, ground: bool = True) -> np.ndarray:
        """``inside`` for many points at once (an n x 2 or n x 3 array -> n booleans)."""
        return self._space.inside(_pts(points), ground) if len(points) else np.zeros(0, dtype=bool)

    def clear(self, a, b, ground: bool = True) -> bool:
        """Whether the straight segment from ``a`` to ``b`` crosses no obstacle."""
        return not bool(self._space.blocked(_pts([a]), _pts([b]), ground)[0])

    def first_hit(self, a, b, ground: bool = True) -> float:
        """Fraction of the segment a -> b travelled before it enters an obstacle (``inf``: it never does)."""
        return float(self._space.first_hit(_pts([a]), _pts([b]), ground)[0])


@lru_cache(maxsize=4)
def _parsed(packed: bytes) -> Space:
    from transport import unpack

    return space_from_spec(unpack(packed))


def _pts(points) -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.shape[1] == 2:
        p = np.column_stack([p, np.zeros(len(p))])
    return p[:, :3]
