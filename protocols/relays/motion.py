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
* Eq. 8, collision avoidance by sampling RVO (van den Berg et al. 2008): u = argmin over admissible
  candidates u' of sum_{j in N_close} alpha / tvo_j(u') + |u_pref - u'|, alpha = 1; tvo_j is the time to
  collision of bodies of combined radius r_col under the reciprocal relative velocity 2u' - u_i - u_j (j takes
  half the avoidance). Candidates: a fixed polar grid, u_pref, 0, 16 drawn with the robot's ctx.rng (they
  break mirror symmetries), and u_pref projected into the admissible set. N_close (our choice; the paper's
  d_ij < r_col would hold only robots already touching): the sensed robots within r_col + 4 v_max tau (those
  some candidate could meet within tau), tau = 1 s; a collision later than tau costs nothing (RVO's time
  horizon). Neighbour velocities are estimated by the caller from its own consecutive sensings (0 if unknown).
* Safety guard (ours, part of the admissible set): for every sensed robot j, the closing component of u is at
  most (d_ij - r_col - margin)/(2 dt): two robots that both apply it end every step at least r_col + margin
  apart, so bodies of radius r_col/2 never touch whatever the RVO cost prefers.

Zero satisfies every bound, so the admissible set is never empty.
"""

from __future__ import annotations

import functools
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


def _hard_bounds(x: np.ndarray, links: list[tuple[np.ndarray, float]], others: list[np.ndarray], rcol: float,
                 dt: float, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """The admissible set's half-planes as (unit vectors E, bounds b): u is admissible when E u <= b.

    Eq. 8 (our reading) for each chain link (y, limit): the separating component along (x - y)/d is at most
    max(0, (limit - d)/(2 dt)). The safety guard for each sensed robot y: the closing component along
    (y - x)/d is at most max(0, (d - r_col - margin)/(2 dt)), so two robots that both apply it end a step at
    least r_col + margin apart (bodies of radius r_col/2 never touch). Zero satisfies every bound.
    """
    dim = len(x)
    ly = np.array([y for y, _ in links], dtype=float).reshape(-1, dim)
    lim = np.array([limit for _, limit in links], dtype=float)
    oy = np.array(others, dtype=float).reshape(-1, dim)
    v = np.concatenate([x - ly, oy - x])  # away from a chain neighbour; towards any sensed robot
    d = np.linalg.norm(v, axis=1)
    b = np.maximum(0.0, np.concatenate([(lim - d[:len(ly)]), (d[len(ly):] - rcol - margin)]) / (2 * dt))
    keep = d > 1e-9
    return v[keep] / d[keep, None], b[keep]


def _project(u: np.ndarray, E: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Three sweeps over the bounds in order, each violated one capped in turn; zero if one still fails."""
    u = np.array(u, dtype=float)
    for _ in range(3):
        k = 0
        while k < len(b):
            over = np.flatnonzero(E[k:] @ u - b[k:] > 0)
            if not len(over):
                break
            k += int(over[0])
            u = u - (float(E[k] @ u) - b[k]) * E[k]
            k += 1
    if len(b) and np.any(E @ u > b + 1e-9):
        return np.zeros_like(u)
    return u


def bound(u: np.ndarray, x: np.ndarray, links: list[tuple[np.ndarray, float]], others: list[np.ndarray],
          rcol: float, dt: float, margin: float = 0.02) -> np.ndarray:
    """The projection of u into the admissible set (three sweeps of capping each bound), or zero.

    The velocity nearest to u that keeps every link and every body within its bound: the candidate of
    ``constrain`` that follows u_pref as closely as the links allow, and the fix of a step cut by a wall.
    """
    return _project(u, *_hard_bounds(x, links, others, rcol, dt, margin))


@functools.lru_cache(maxsize=32)
def _grid(vmax: float, dim: int, vertical: bool, rings: int, azimuths: int) -> np.ndarray:
    speeds = vmax * np.arange(1, rings + 1) / rings
    az = 2 * math.pi * np.arange(azimuths) / azimuths
    if dim == 2 or not vertical:
        dirs = np.stack([np.cos(az), np.sin(az)] + ([np.zeros(azimuths)] if dim == 3 else []), axis=1)
    else:
        rows = [np.stack([np.cos(az) * math.cos(el), np.sin(az) * math.cos(el), np.full(azimuths, math.sin(el))],
                         axis=1) for el in np.radians([0.0, 30.0, -30.0, 60.0, -60.0])]
        dirs = np.concatenate(rows + [np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])])
    grid = (speeds[:, None, None] * dirs[None, :, :]).reshape(-1, dim)
    grid.flags.writeable = False
    return grid


def candidates(u_pref: np.ndarray, vmax: float, vertical: bool = False, rings: int = 4,
               azimuths: int = 24) -> np.ndarray:
    """The sampled velocities of the RVO: a fixed polar grid, u_pref itself and zero (deterministic).

    2-D (or a ground robot in 3-D): ``rings`` speeds vmax k/rings times ``azimuths`` directions in the horizontal
    plane. A flying robot in 3-D (``vertical``): the same azimuths at elevations 0, +-30 and +-60 degrees, plus
    straight up and down.
    """
    dim = len(u_pref)
    grid = _grid(float(vmax), dim, bool(vertical and dim == 3), rings, azimuths)
    return np.concatenate([np.asarray(u_pref, dtype=float)[None, :], np.zeros((1, dim)), grid])


def random_candidates(rng: np.random.Generator, n: int, vmax: float, dim: int, vertical: bool = False) -> np.ndarray:
    """``n`` velocities drawn uniformly in the disc of radius vmax (the ball, for a flying robot in 3-D).

    Drawn with the robot's own ``ctx.rng``, so lockstep runs stay deterministic. They break the exact mirror
    symmetries a fixed grid keeps: two robots crossing in mirror image score mirrored grids identically and
    make mirrored choices (the reciprocal dance, ending with both pressed against the safety guard).
    """
    if n <= 0:
        return np.zeros((0, dim))
    k = 3 if dim == 3 and vertical else 2
    d = rng.normal(size=(n, k))
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    u = d * (vmax * rng.random(n) ** (1.0 / k))[:, None]
    return u if k == dim else np.concatenate([u, np.zeros((n, dim - k))], axis=1)


def tvo(p: np.ndarray, w: np.ndarray, r: float) -> np.ndarray:
    """Time to collision: the least t >= 0 with |p - w t| <= r, inf when there is none.

    ``p`` (..., D): the other robot's position relative to this one; ``w`` (..., D): this robot's velocity
    relative to the other (broadcast together). Two discs of combined radius r at relative position p meet
    when the relative motion brings p within r. Already overlapping: 0 while closing (p.w > 0), else inf.
    """
    p, w = np.broadcast_arrays(np.asarray(p, dtype=float), np.asarray(w, dtype=float))
    a = np.einsum("...i,...i", w, w)
    pw = np.einsum("...i,...i", p, w)
    c = np.einsum("...i,...i", p, p) - r * r
    disc = pw * pw - a * c
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (pw - np.sqrt(np.maximum(disc, 0.0))) / a
    out = np.where((disc >= 0) & (a > 1e-18) & (pw > 0) & (t >= 0), t, np.inf)
    return np.where(c <= 0, np.where(pw > 0, 0.0, np.inf), out)


def close_set(x: np.ndarray, others: list[np.ndarray], rcol: float, vmax: float, horizon: float) -> list[int]:
    """N_close (our choice): the indices of the sensed robots within r_col + 4 v_max horizon.

    The reciprocal test velocity 2u' - u_i - u_j is at most 4 v_max, so these are exactly the robots that some
    candidate could meet within ``horizon`` seconds; a robot farther away has tvo > horizon for every u'.
    """
    if not len(others):
        return []
    d = np.linalg.norm(np.array(others, dtype=float).reshape(len(others), -1) - x, axis=1)
    return np.flatnonzero(d < rcol + 4 * vmax * horizon).tolist()


def rvo_cost(cand: np.ndarray, u_pref: np.ndarray, x: np.ndarray, others: list[np.ndarray], rcol: float, vmax: float,
             u_self: np.ndarray | None = None, v_others: list[np.ndarray | None] | None = None, alpha: float = 1.0,
             horizon: float = 1.0) -> np.ndarray:
    """Eq. 8's cost of each candidate u' (rows of ``cand``): sum_{j in N_close} alpha / tvo_j(u') + |u_pref - u'|.

    tvo_j tests the reciprocal relative velocity 2u' - u_self - u_j (van den Berg et al. 2008: j is assumed to
    take half the avoidance) against bodies of combined radius r_col; a collision later than ``horizon`` seconds
    counts as none (RVO's time horizon). ``v_others``: the sensed robots' estimated velocities (None: unknown,
    taken as 0); ``u_self``: this robot's own current velocity (None: 0).
    """
    u_pref = np.asarray(u_pref, dtype=float)
    cost = np.linalg.norm(cand - u_pref, axis=1)
    near = close_set(x, others, rcol, vmax, horizon)
    if not near:
        return cost
    dim = len(x)
    ui = np.zeros(dim) if u_self is None else np.asarray(u_self, dtype=float)
    P = np.array([others[k] - x for k in near])
    V = np.array([np.zeros(dim) if v_others is None or v_others[k] is None else np.asarray(v_others[k], dtype=float)
                  for k in near])
    w = 2 * cand[:, None, :] - ui[None, None, :] - V[None, :, :]
    t = tvo(P[None, :, :], w, rcol)
    t = np.where(t > horizon, np.inf, t)  # a collision beyond the horizon is not a threat yet
    return cost + alpha * np.sum(1.0 / np.maximum(t, 1e-9), axis=1)


def constrain(u_pref: np.ndarray, x: np.ndarray, links: list[tuple[np.ndarray, float]], others: list[np.ndarray],
              rcol: float, dt: float, vmax: float, u_self: np.ndarray | None = None,
              v_others: list[np.ndarray | None] | None = None, alpha: float = 1.0, horizon: float = 1.0,
              margin: float = 0.02, vertical: bool = False, rng: np.random.Generator | None = None,
              samples: int = 16) -> np.ndarray:
    """Eq. 8 by sampling RVO: u = argmin over admissible u' of sum_{j in N_close} alpha / tvo_j(u') + |u_pref - u'|.

    ``links``: (neighbour position, limit) for parent and child; the limit is d_s, or d_c for the child of a
    robot moving back along pi (a retracting robot may pull its child into the critical zone, so that the
    child retracts too by Eq. 6; Sec. III-B's critical tolerance). ``others``: every sensed robot's position;
    ``v_others``, ``u_self``, ``alpha``, ``horizon``: as in ``rvo_cost``.

    Candidates: the fixed grid (``candidates``), ``samples`` drawn with ``rng`` (``random_candidates``; none
    without it) and u_pref's projection into the admissible set (``bound``); the admissible
    ones are Eq. 8's set (our reading, ``_hard_bounds``) cut by the safety guard. Zero is always admissible.
    Exact ties (a mirror-symmetric encounter) go to the candidate most to the right of u_pref, by a cost of
    1e-9 per m/s to its left: both robots of a symmetric head-on pair then turn the same way relative to
    themselves and pass.
    """
    u_pref = np.asarray(u_pref, dtype=float)
    dim = len(x)
    drawn = random_candidates(rng, samples, vmax, dim, vertical) if rng is not None else np.zeros((0, dim))
    E, b = _hard_bounds(x, links, others, rcol, dt, margin)
    cand = np.concatenate([candidates(u_pref, vmax, vertical and dim == 3), drawn, _project(u_pref, E, b)[None, :]])
    if len(b):
        cand = cand[np.all(cand @ E.T <= b + 1e-9, axis=1)]
    cost = rvo_cost(cand, u_pref, x, others, rcol, vmax, u_self, v_others, alpha, horizon)
    n = float(np.linalg.norm(u_pref[:2]))
    if n > 1e-12:  # tie-break to the right of u_pref
        left = np.zeros(dim)
        left[0], left[1] = -u_pref[1] / n, u_pref[0] / n
        cost = cost + 1e-9 * (cand @ left)
    return cand[int(np.argmin(cost))].copy()
