"""Biconnectivity: pure geometry and graphs on the robot side (proximity, placement, removal)."""

from __future__ import annotations

import math
from itertools import combinations

import numpy as np

TOL = 1e-9


# ================================================================ pure geometry and graphs (robot side)
def prox(points: np.ndarray, pos: np.ndarray, s: float) -> np.ndarray:
    """Move each point ``s`` towards ``pos``, stopping at ``pos`` (the proximal map of s·|x - pos|)."""
    points = np.asarray(points, dtype=float)
    v = points - pos
    dist = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        k = np.where(dist > 0, np.maximum(0.0, 1.0 - s / np.where(dist > 0, dist, 1.0)), 0.0)
    return pos + v * k


def adjacency(points: np.ndarray, reach: float) -> list[set[int]]:
    """Index adjacency of points closer than ``reach`` (inclusive, with a relative tolerance)."""
    p = np.asarray(points, dtype=float)
    n = len(p)
    if n == 0:
        return []
    d = np.linalg.norm(p[:, None, :] - p[None, :, :], axis=-1)
    lim = reach * (1 + TOL)
    return [{j for j in range(n) if j != i and d[i, j] <= lim} for i in range(n)]


def _connected(adj: list[set[int]], skip: int = -1) -> bool:
    nodes = [i for i in range(len(adj)) if i != skip]
    if not nodes:
        return True
    seen = {nodes[0]}
    stack = [nodes[0]]
    while stack:
        u = stack.pop()
        for v in adj[u]:
            if v != skip and v not in seen:
                seen.add(v)
                stack.append(v)
    return len(seen) == len(nodes)


def biconnected(adj: list[set[int]]) -> bool:
    """The paper's biconnectivity (Definition 2 with Lemma 1): at least 3 robots, connected, no cut robot."""
    n = len(adj)
    return n >= 3 and _connected(adj) and all(_connected(adj, skip=v) for v in range(n))


def structure_ok(adj: list[set[int]]) -> bool:
    """What the removal leader wants of r's ex-neighbours (Theorem 4): biconnected; two robots adjacent."""
    n = len(adj)
    if n <= 1:
        return True
    if n == 2:
        return 1 in adj[0]
    return biconnected(adj)


def removal_distance(points: np.ndarray, pos: np.ndarray, reach: float, step: float) -> float:
    """Smallest d in {0, step, 2·step, ...} after which the moved ex-neighbours satisfy ``structure_ok``."""
    points = np.asarray(points, dtype=float)
    if len(points) <= 1:
        return 0.0
    dmax = float(np.max(np.linalg.norm(points - pos, axis=1)))
    k = 0
    while True:
        d = k * step
        if structure_ok(adjacency(prox(points, pos, d), reach)) or d >= dmax:
            return float(d)
        k += 1


def two_closest_sum(points: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """The paper's heuristic value: sum of the distances to the two closest region centres."""
    points = np.atleast_2d(points)
    d = np.linalg.norm(points[:, None, :] - centres[None, :, :], axis=-1)
    if d.shape[1] == 1:
        return d[:, 0]
    return np.partition(d, 1, axis=1)[:, :2].sum(axis=1)


def lens_area(d: np.ndarray, rho: float) -> np.ndarray:
    """Intersection area of two disks of radius ``rho`` whose centres are ``d`` apart."""
    d = np.asarray(d, dtype=float)
    if rho <= 0:
        return np.zeros_like(d)
    x = np.clip(d / (2 * rho), 0.0, 1.0)
    lens = 2 * rho * rho * np.arccos(x) - d / 2 * np.sqrt(np.maximum(0.0, 4 * rho * rho - d * d))
    return np.where(d < 2 * rho, lens, 0.0)


def overlap(points: np.ndarray, centres: np.ndarray, rho: float) -> np.ndarray:
    """Total intersection area of a region at each point with the regions at ``centres``."""
    points = np.atleast_2d(points)
    d = np.linalg.norm(points[:, None, :] - centres[None, :, :], axis=-1)
    return lens_area(d, rho).sum(axis=1)


def feasible(points: np.ndarray, centres: np.ndarray, reach: float, need: int, must=()) -> np.ndarray:
    """Points within ``reach`` of at least ``need`` centres, and of every centre index in ``must``."""
    points = np.atleast_2d(points)
    d = np.linalg.norm(points[:, None, :] - centres[None, :, :], axis=-1)
    lim = reach * (1 + TOL)
    ok = (d <= lim).sum(axis=1) >= need
    for i in must:
        ok &= d[:, i] <= lim
    return ok


def _candidates(centres: np.ndarray, reach: float, grid: int = 60, ring: int = 720) -> np.ndarray:
    """Candidate positions: circles of radius ``reach`` around the centres, their intersections, a grid."""
    pts = []
    ang = np.linspace(0.0, 2 * math.pi, ring, endpoint=False)
    circle = np.stack([np.cos(ang), np.sin(ang)], axis=1) * reach
    for c in centres:
        pts.append(c + circle)
    for i, j in combinations(range(len(centres)), 2):
        a, b = centres[i], centres[j]
        dv = b - a
        d = float(np.linalg.norm(dv))
        if 0 < d <= 2 * reach:
            mid = a + dv / 2
            h = math.sqrt(max(0.0, reach * reach - d * d / 4))
            perp = np.array([-dv[1], dv[0]]) / d
            pts.append(np.stack([mid + perp * h, mid - perp * h]))
    lo = centres.min(axis=0) - reach
    hi = centres.max(axis=0) + reach
    span = float(np.max(hi - lo))
    k = max(2, int(grid * span / max(reach, 1e-12)))
    k = min(k, 400)
    xs = np.linspace(lo[0], hi[0], k)
    ys = np.linspace(lo[1], hi[1], k)
    gx, gy = np.meshgrid(xs, ys)
    pts.append(np.stack([gx.ravel(), gy.ravel()], axis=1))
    return np.vstack(pts)


def _refine(p: np.ndarray, score, ok, reach: float) -> np.ndarray:
    """Pattern search: move while the score improves and the point stays feasible."""
    best = p.copy()
    best_v = float(score(best[None])[0])
    step = reach / 40
    dirs = np.array([[math.cos(a), math.sin(a)] for a in np.linspace(0, 2 * math.pi, 16, endpoint=False)])
    while step > reach * 1e-7:
        trial = best + dirs * step
        good = ok(trial)
        if good.any():
            vals = np.where(good, score(trial), -np.inf)
            k = int(np.argmax(vals))
            if vals[k] > best_v + 1e-12:
                best, best_v = trial[k], float(vals[k])
                continue
        step /= 2
    return best


def join_position(centres: np.ndarray, reach: float, must=(), method: str = "heuristic", rho: float = 0.0,
                  rng: np.random.Generator | None = None) -> tuple[np.ndarray, float, list[int]] | None:
    """Best position of a new region (Theorem 3 and the paper's heuristic).

    Feasible: within ``reach`` of at least min(2, k) centres, and of each index in ``must``.
    ``heuristic``: maximise the sum of the distances to the two closest centres.
    ``min_intersection``: minimise the total intersection with the other regions (ties: at random).
    Returns (position, heuristic value, indices of the two closest centres), or None.
    """
    centres = np.asarray(centres, dtype=float).reshape(-1, 2)
    k = len(centres)
    if k == 0:
        return None
    need = min(2, k)
    cand = _candidates(centres, reach)
    ok_mask = feasible(cand, centres, reach, need, must)
    cand = cand[ok_mask]
    if len(cand) == 0:
        return None

    def ok(pts):
        return feasible(pts, centres, reach, need, must)

    if method == "heuristic":
        vals = two_closest_sum(cand, centres)
        top = np.argsort(-vals)[:8]
        refined = [_refine(cand[i], lambda q: two_closest_sum(q, centres), ok, reach) for i in top]
        refined_vals = two_closest_sum(np.array(refined), centres)
        best = refined[int(np.argmax(refined_vals))]
    elif method == "min_intersection":
        ov = overlap(cand, centres, rho)
        low = np.flatnonzero(ov <= ov.min() + 1e-9 * max(rho * rho, 1e-12))
        pick = low[int((rng or np.random.default_rng(0)).integers(len(low)))]
        best = cand[pick]
    else:
        raise ValueError(f"unknown placement method {method!r}")
    d = np.linalg.norm(centres - best, axis=1)
    closest = [int(i) for i in np.argsort(d)[:2]]
    return best, float(two_closest_sum(best[None], centres)[0]), closest


def _region_problem(radio_range: float, region: float) -> str | None:
    """Why regions of radius ``region`` cannot work with this radio range (two must fit in it), or None."""
    if radio_range - 2 * region <= 0:
        return (f"region = {region!r} too large for the radio range {radio_range!r}: two regions must fit in "
                "range (range - 2·region > 0)")
    return None
