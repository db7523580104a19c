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
) -> dict[int, list]:
    """``{i: [[j, ...], [x_j, y_j(, z_j), ...]]}`` (ids, flat coordinates) per alive robot.

    Positions are noisy where ``noise[i] > 0``; the flat layout keeps the
    per-tick cost in numpy rather than in Python loops over neighbours.
    """
    out: dict[int, list] = {}
    rounded = np.round(pos, digits)
    for i, ids in neighbours.items():
        if noise[i] > 0.0 and ids.size:
            p = pos[ids].copy()
            u1 = rng.uniform(seed, rng.NOISE, tick, i, ids * 2)
            u2 = rng.uniform(seed, rng.NOISE, tick, i, ids * 2 + 1)
            # Box-Muller: one Gaussian per coordinate pair from two uniforms.
            r = np.sqrt(-2.0 * np.log(np.maximum(u1, 1e-300))) * noise[i]
            p[:, 0] += r * np.cos(2 * np.pi * u2)
            p[:, 1] += r * np.sin(2 * np.pi * u2)
            flat = np.round(p, digits).ravel().tolist()
        else:
            flat = rounded[ids].ravel().tolist()
        out[i] = [ids.tolist(), flat]
    return out
