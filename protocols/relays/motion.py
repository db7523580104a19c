"""Swarm Relays' motion law (002 Eqs. 1, 3, 4, 6-8) as pure vector functions. Robot side.

* u_path(pi, F|B): the velocity towards a point ``lookahead`` ahead (F) or behind (B) of the robot's arc
  position on the path pi, at most v_max; the arc position is tracked locally (projection within a window
  around the previous one, so a path that folds back is not short-cut).
* Eq. 6-7: u_pref = f_c(d_C) u_path(pi, F) when d_P <= d_s, else u_path(pi, B); f_c = 1 when d_C <= d_s (or
  there is no child), 0 otherwise.
* Eq. 8 as we read it (the literal ||u|| < min (d_s - d_ij)/(2 dt) is empty once a link reaches d_s, so a
  chain could never extend): for each chain neighbour j (parent, child) only the component of u that
  separates the pair is bounded, by (d_s - d_ij)/(2 dt) while d_ij <= d_s (Eq. 3: each robot takes half the
  margin, so the pair ends within d_s) and by 0 beyond d_s (Eq. 4: a pair in the critical or break-away
  zone may only close up). Motion across or towards the neighbour is free.
* Collision avoidance (instead of RVO, stated): for every sensed robot j, the closing component of u is
  bounded by (d_ij - r_col - margin)/(2 dt), the same half-margin rule, so two bodies of radius r_col/2 never
  touch when both apply it; the part of u so removed is turned to the robot's right (both robots of a
  pair keep right, so they pass instead of blocking each other).

The bounds are applied by projection, three sweeps; if any is still violated the robot stands still (zero
satisfies every bound).
"""

from __future__ import annotations

import math

import numpy as np


def arc_points(path: list[list[float]]) -> tuple[np.ndarray, np.ndarray]:
    """(points, cumulative arc length at each point) of a polyline."""
    p = np.asarray(path, dtype=float)
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1) if len(p) > 1 else np.zeros(0)
    return p, np.concatenate([[0.0], np.cumsum(seg)])


def point_at(p: np.ndarray, cum: np.ndarray, s: float) -> np.ndarray:
    """The point at arc length s (clamped to the path)."""
    s = min(max(s, 0.0), float(cum[-1]))
    k = int(np.searchsorted(cum, s, side="right") - 1)
    k = min(max(k, 0), len(p) - 2) if len(p) > 1 else 0
    if len(p) == 1:
        return p[0].copy()
    seg = cum[k + 1] - cum[k]
    t = 0.0 if seg <= 0 else (s - cum[k]) / seg
    return p[k] + t * (p[k + 1] - p[k])


def project(p: np.ndarray, cum: np.ndarray, x: np.ndarray, lo: float = -math.inf, hi: float = math.inf) -> float:
    """The arc length of the point of the path nearest to x, among arc lengths in [lo, hi]."""
    best, best_s = math.inf, 0.0
    for k in range(max(len(p) - 1, 1)):
        a, b = p[k], p[min(k + 1, len(p) - 1)]
        s0, s1 = cum[k], cum[min(k + 1, len(p) - 1)]
        if s1 < lo or s0 > hi:
            continue
        ab = b - a
        L2 = float(ab @ ab)
        t = 0.0 if L2 == 0 else float(np.clip((x - a) @ ab / L2, 0.0, 1.0))
        s = s0 + t * (s1 - s0)
        s = min(max(s, lo), hi)
        q = point_at(p, cum, s)
        d = float(np.linalg.norm(x - q))
        if d < best - 1e-12:
            best, best_s = d, s
    return best_s


def u_path(p: np.ndarray, cum: np.ndarray, s: float, x: np.ndarray, forward: bool, vmax: float, dt: float,
           lookahead: float) -> np.ndarray:
    """Velocity towards the point ``lookahead`` ahead of (forward) or behind arc s, at most vmax (one step)."""
    goal = point_at(p, cum, s + lookahead if forward else s - lookahead)
    v = goal - x
    d = float(np.linalg.norm(v))
    if d < 1e-9:
        return np.zeros_like(x)
    return v / d * min(vmax, d / dt)


def preferred(u_f: np.ndarray, u_b: np.ndarray, d_parent: float, d_child: float | None, ds: float,
              to_child: np.ndarray | None = None) -> np.ndarray:
    """Eq. 6-7: forward scaled by f_c(d_C) when the parent is within d_s, else backward.

    f_c = 1 when there is no child, the child is within d_s, or (our addition) moving forward closes on the
    child (``to_child``: the vector to it): a new recruit next to the root must catch up with its child.
    """
    if d_parent <= ds:
        closes = to_child is not None and float(u_f @ to_child) > 0
        fc = 1.0 if d_child is None or d_child <= ds or closes else 0.0
        return fc * u_f
    return u_b


def _cap(u: np.ndarray, e: np.ndarray, bound: float) -> np.ndarray:
    """Bound the component of u along unit e by ``bound``."""
    s = float(u @ e)
    return u - (s - bound) * e if s > bound else u


def constrain(u: np.ndarray, x: np.ndarray, links: list[tuple[np.ndarray, float]], others: list[np.ndarray],
              rcol: float, dt: float, margin: float = 0.02) -> np.ndarray:
    """Eq. 8 (our reading) and the collision rule: u within every bound, or zero.

    ``links``: (neighbour position, limit) for parent and child; the limit is d_s, or d_c for the child of
    a robot moving back along pi (a retracting robot may pull its child into the critical zone, so that the
    child retracts too by Eq. 6; Sec. III-B's critical tolerance).
    """
    bounds = []
    for y, limit in links:  # separation from a chain neighbour
        v = x - y
        d = float(np.linalg.norm(v))
        if d > 1e-9:
            bounds.append((v / d, max(0.0, (limit - d) / (2 * dt))))
    swerve = np.zeros_like(u)
    for y in others:  # closing on any sensed robot
        v = y - x
        d = float(np.linalg.norm(v))
        if d > 1e-9 and d < rcol + margin + 4 * float(np.linalg.norm(u)) * dt + 0.2:
            e, b = v / d, max(0.0, (d - rcol - margin) / (2 * dt))
            bounds.append((e, b))
            closing = float(u @ e)
            near = max(0.0, 1.0 - (d - rcol) / 0.4)  # turns right earlier the nearer j is
            if closing > 0:  # keep right: the blocked part turns to the robot's right (in the horizontal plane)
                swerve += max(closing - b, closing * near) * np.array([e[1], -e[0], 0.0][:len(u)])
    u = u + swerve
    for _ in range(3):
        for e, b in bounds:
            u = _cap(u, e, b)
    if any(float(u @ e) > b + 1e-9 for e, b in bounds):
        return np.zeros_like(u)
    return u
