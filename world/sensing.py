"""Neighbourhoods from positions: radio reach and sensing, via a k-d tree.

``in_range[i]`` lists the alive robots within robot i's *radio* range
(directed when ranges differ); ``sensed[i]`` lists (id, position) of the alive
robots within its *sensing* range, with optional Gaussian noise on the
positions drawn from the counter-based generator keyed on
(seed, tick, observer, observed).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from world import rng


def within(pos: np.ndarray, alive_ids: np.ndarray, radii: np.ndarray) -> dict[int, np.ndarray]:
    """For each alive robot i, the sorted alive ids j != i with |x_j - x_i| <= radii[i]."""
    if alive_ids.size == 0:
        return {}
    pts = pos[alive_ids]
    tree = cKDTree(pts)
    hits = tree.query_ball_point(pts, r=radii[alive_ids], return_sorted=True)
    out: dict[int, np.ndarray] = {}
    for k, i in enumerate(alive_ids.tolist()):
        ids = alive_ids[hits[k]]
        out[i] = ids[ids != i]
    return out


def sense(
    pos: np.ndarray,
    neighbours: dict[int, np.ndarray],
    noise: np.ndarray,
    seed: int,
    tick: int,
    digits: int = 6,
) -> dict[int, list[list]]:
    """``{i: [[j, x, y(, z)], ...]}`` for every alive robot, noisy where ``noise[i] > 0``."""
    out: dict[int, list[list]] = {}
    for i, ids in neighbours.items():
        p = pos[ids]
        if noise[i] > 0.0 and ids.size:
            u1 = rng.uniform(seed, rng.NOISE, tick, i, ids * 2)
            u2 = rng.uniform(seed, rng.NOISE, tick, i, ids * 2 + 1)
            # Box-Muller: one Gaussian per coordinate pair from two uniforms.
            r = np.sqrt(-2.0 * np.log(np.maximum(u1, 1e-300))) * noise[i]
            p = p.copy()
            p[:, 0] += r * np.cos(2 * np.pi * u2)
            p[:, 1] += r * np.sin(2 * np.pi * u2)
        out[i] = [[j, *row] for j, row in zip(ids.tolist(), np.round(p, digits).tolist())]
    return out
