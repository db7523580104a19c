"""The world's rules of space: motion against obstacles, altitude, radio occlusion, bodies and collisions.

The shapes and their geometry are ``transport.space`` (shared with robots that know the map); this module
holds what the world does with them each tick:

* **motion** (after kinematics): a ground robot *stops at the wall* - it advances along its step up to just
  before the first obstacle the step would enter, and does not slide along it; a flying robot is stopped the
  same way in 3-D (in a 2-D world it crosses every obstacle). In a 3-D world ground robots stay at z = 0
  and flying robots stay within their group's ``altitude`` limits, climbing at most ``climb_rate`` per second.
* **occlusion** (``radio.occlusion``): a link whose segment overlaps an obstacle is blocked; the radio
  counts frames over it as dropped with cause ``occluded``.
* **bodies**: each robot has a ``body_radius`` (0: a point). A collision starts when two bodies, or a body
  and an obstacle, begin to overlap and ends when they part: one episode, recorded once with its start
  and end tick (``collisions`` in the trace events and result.json). With ``world.blocking`` a step that
  would make two bodies overlap is not taken (both robots of the new overlap keep their previous position),
  so no robot-robot collision can happen.
* **obstacle rays**: ``obstacle_rays = k`` gives a robot k horizontal range rays, evenly spaced from its
  heading, each the distance to the first obstacle within its sensing range (``inf``: none).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from transport.space import Space

STOP_MARGIN = 1e-6  # a robot stopped by a wall halts this fraction of its step before it


class SpaceRules:
    """Per-run state of the space rules: the obstacles and the open collision episodes."""

    def __init__(self, space: Space, dims: int, occlusion: bool, blocking: bool):
        self.space = space
        self.dims = dims
        self.occlusion = occlusion and not space.empty
        self.blocking = blocking
        self.open: dict[tuple, int] = {}  # (a, b) or (a, "obstacle", k) -> start tick
        self.episodes: list[dict] = []  # ended episodes, in order of ending
        self.counts = {"robot": 0, "obstacle": 0}

    # ------------------------------------------------------------ points in 3-D
    def points(self, pos: np.ndarray) -> np.ndarray:
        """Positions as 3-D points (a 2-D world is the plane z = 0)."""
        if pos.shape[1] == 3:
            return pos
        return np.column_stack([pos, np.zeros(len(pos))])

    # ------------------------------------------------------------ motion
    def constrain(self, before: np.ndarray, pos: np.ndarray, robots, dt: float) -> None:
        """Apply altitude limits and obstacles to this tick's steps ``before -> pos`` (in place)."""
        ground = robots.ground
        if self.dims == 3:
            pos[ground, 2] = 0.0
            fly = ~ground
            if fly.any():
                climb = np.clip(pos[fly, 2] - before[fly, 2], -robots.climb[fly] * dt,
                                robots.climb[fly] * dt)
                pos[fly, 2] = np.clip(before[fly, 2] + climb, robots.alt_lo[fly], robots.alt_hi[fly])
        if self.space.empty:
            return
        moved = robots.alive & np.any(pos != before, axis=1)
        if self.dims == 2:
            moved &= ground  # flying robots cross every obstacle in a 2-D world
        idx = np.flatnonzero(moved)
        if idx.size == 0:
            return
        a, b = self.points(before[idx]), self.points(pos[idx])
        t = self.space.first_hit(a, b, ground[idx], closed=True)
        hit = np.isfinite(t)
        if hit.any():
            k = idx[hit]
            frac = np.maximum(t[hit] - STOP_MARGIN, 0.0)
            pos[k] = before[k] + frac[:, None] * (pos[k] - before[k])

    def unblock_bodies(self, before: np.ndarray, pos: np.ndarray, robots) -> None:
        """``world.blocking``: steps that make two bodies newly overlap are not taken."""
        if not self.blocking:
            return
        radius = robots.body
        if not (radius > 0).any():
            return
        was = set(self._overlapping(before, robots.alive, radius))
        for _ in range(len(pos)):
            new = [p for p in self._overlapping(pos, robots.alive, radius) if p not in was]
            if not new:
                return
            for a, b in new:
                pos[a] = before[a]
                pos[b] = before[b]

    # ------------------------------------------------------------ radio
    def hidden_pairs(self, pos: np.ndarray, table) -> np.ndarray | None:
        """Which links of a ``world.sensing.Reach`` table an obstacle blocks, aligned with ``table.nbrs``.

        None when none is (or occlusion is off).
        """
        if not self.occlusion or not table.nbrs.size:
            return None
        hidden = self.occluded(pos, table.owners(), table.nbrs)
        return hidden if hidden.any() else None

    def hidden_by_sender(self, pos: np.ndarray, reach: dict[int, np.ndarray]) -> dict[int, tuple]:
        """Per sender whose reach (``reach[src]``, sorted) an obstacle cuts: ``(heard, hidden)`` robot ids."""
        if not self.occlusion or not reach:
            return {}
        senders = np.fromiter(reach, dtype=np.int64, count=len(reach))
        counts = np.array([len(v) for v in reach.values()], dtype=np.int64)
        src = np.repeat(senders, counts)
        dst = np.concatenate([np.zeros(0, dtype=np.int64), *reach.values()]).astype(np.int64)
        hidden = self.occluded(pos, src, dst)
        if not hidden.any():
            return {}
        out: dict[int, tuple] = {}
        cuts = np.cumsum(counts)[:-1]
        for k, part, mask in zip(senders.tolist(), np.split(dst, cuts), np.split(hidden, cuts), strict=True):
            if mask.any():
                out[k] = (part[~mask], part[mask])
        return out

    def occluded(self, pos: np.ndarray, src: np.ndarray, dst: np.ndarray) -> np.ndarray:
        """Whether the link src -> dst (arrays of robot ids) crosses an obstacle."""
        if not self.occlusion or len(src) == 0:
            return np.zeros(len(src), dtype=bool)
        p = self.points(pos)
        return self.space.blocked(p[src], p[dst], ground=False)

    # ------------------------------------------------------------ sensing
    def rays(self, pos: np.ndarray, heading: np.ndarray, reach: np.ndarray, count: np.ndarray,
             ids: np.ndarray) -> dict[int, list[float]]:
        """Per robot in ``ids`` with ``count > 0``: distances along its rays to the first obstacle (inf: none)."""
        out: dict[int, list[float]] = {}
        ids = ids[count[ids] > 0]
        if ids.size == 0 or self.space.empty:
            return {int(i): [float("inf")] * int(count[i]) for i in ids}
        starts, ends, owners = [], [], []
        p = self.points(pos)
        for i in ids.tolist():
            k = int(count[i])
            ang = heading[i] + 2 * np.pi * np.arange(k) / k
            d = np.column_stack([np.cos(ang), np.sin(ang), np.zeros(k)]) * reach[i]
            starts.append(np.repeat(p[i][None], k, axis=0))
            ends.append(p[i] + d)
            owners.append(np.full(k, i))
        a, b, who = np.vstack(starts), np.vstack(ends), np.concatenate(owners)
        t = self.space.first_hit(a, b, ground=False)
        dist = np.where(np.isfinite(t), t * reach[who], np.inf)
        start = 0
        for i in ids.tolist():
            k = int(count[i])
            out[i] = [round(float(x), 6) for x in dist[start: start + k]]
            start += k
        return out

    # ------------------------------------------------------------ collisions
    def _overlapping(self, pos: np.ndarray, alive: np.ndarray, radius: np.ndarray) -> list[tuple[int, int]]:
        ids = np.flatnonzero(alive & (radius > 0))
        if ids.size < 2:
            return []
        tree = cKDTree(pos[ids])
        pairs = tree.query_pairs(r=2 * float(radius[ids].max()), output_type="ndarray")
        if len(pairs) == 0:
            return []
        a, b = ids[pairs[:, 0]], ids[pairs[:, 1]]
        d = np.linalg.norm(pos[a] - pos[b], axis=1)
        hit = d < radius[a] + radius[b]
        return sorted(zip(np.minimum(a, b)[hit].tolist(), np.maximum(a, b)[hit].tolist(), strict=True))

    def collisions(self, tick: int, pos: np.ndarray, robots) -> list[dict]:
        """Start and end collision episodes from this tick's positions; return the ended ones to record.

        An episode is recorded once, when it ends (or when the run ends), with its start and end tick.
        """
        radius = robots.body
        touching: set[tuple] = set(self._overlapping(pos, robots.alive, radius))
        if not self.space.empty:
            bodies = robots.alive & (radius > 0)
            if self.dims == 2:
                bodies &= robots.ground  # in a 2-D world flying robots pass over every obstacle
            ids = np.flatnonzero(bodies)
            if ids.size:
                which = self.space.clearance_overlap(self.points(pos[ids]), radius[ids], robots.ground[ids])
                touching |= {(int(i), "obstacle", int(k)) for i, k in zip(ids, which, strict=True) if k != -1}
        events = []
        for key in sorted(self.open.keys() - touching, key=str):
            events.append(self._end(key, tick))
        for key in sorted(touching - self.open.keys(), key=str):
            self.open[key] = tick
            self.counts["robot" if len(key) == 2 else "obstacle"] += 1
        return events

    def close(self, tick: int) -> list[dict]:
        """End every open episode at the run's end."""
        return [self._end(key, tick) for key in sorted(self.open, key=str)]

    def _end(self, key: tuple, tick: int) -> dict:
        start = self.open.pop(key)
        episode = {"collision": _who(key), "start": start, "end": tick}
        self.episodes.append(episode)
        return episode

    def summary(self) -> dict:
        return {"robot_robot": self.counts["robot"], "robot_obstacle": self.counts["obstacle"],
                "episodes": self.episodes[:1000]}


def _who(key: tuple) -> list:
    """An episode's parties: two robot ids, or a robot id, ``"obstacle"`` and the obstacle's index (-2: grid)."""
    return list(key)
