"""Situated sensing: what a robot knows in its own frame, and the per-robot draws that go with it.

A robot group's keys (docs/scenarios.md) choose, per robot:

* ``sensing_frame = "local"`` (ARGoS's range-and-bearing sensor; e-puck and Kilobot IR boards): the robot
  senses each neighbour as (id, range, bearing) in its own body frame (bearing 0 straight ahead, positive to
  the left; in 3-D the bearing is the azimuth and an elevation follows), with Gaussian noise of standard
  deviation ``range_noise`` (length units) and ``bearing_noise`` (radians); its pose is its odometry: its
  position relative to its own start, in a frame turned by a per-robot heading offset delta drawn from the
  run's seed, and its heading plus delta. Its velocity commands are in that same frame.
* ``sensing_to = "surface"`` with ``body_radius`` > 0 (Sano et al., Eqs. 4-5): the sensed vector points to
  the closest point of the other robot's body, at distance max(d - R_j, 0), and a robot is sensed when that
  point is within sensing range.
* frame range and bearing (``frame.rab``), under local sensing or ``radio.rab = true``: every delivered frame
  carries the range and bearing at which its receiver heard it, from the positions at the send tick, in the
  receiver's body frame, with the receiver's noise.
* ``clock_offset`` (seconds) and ``clock_drift`` (ppm): drawn here, applied by the robot's host
  (swarmactors/robot/robot_clock.py).

A value given as ``[lo, hi]`` is drawn uniformly per robot, keyed on (seed, SITUATED, robot id, what), so a
robot's draws depend neither on the process layout nor on other robots. Noise is keyed on (seed, tick,
observer, observed) and, for frames, (seed, tick, receiver, sender, seq).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from transport.scenario import RobotSpec
from world import rng
from world.sensing import within

HEADING, OFFSET, DRIFT = 0, 1, 2  # what a per-robot draw is for


def draw(value, seed: int, rid: int, what: int) -> float:
    """A per-robot value: a number as is, or ``[lo, hi]`` drawn uniformly from the run's seed."""
    if isinstance(value, (list, tuple)):
        lo, hi = float(value[0]), float(value[1])
        return lo + float(rng.uniform(seed, rng.SITUATED, rid, what)) * (hi - lo)
    return float(value)


def _wrap(a: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * a))


def _gauss(seed: int, stream: int, *key) -> tuple[np.ndarray, np.ndarray]:
    """Two independent standard normals per key (Box-Muller); the last key field is doubled."""
    *head, last = key
    last = np.asarray(last, dtype=np.int64)
    u1 = rng.uniform(seed, stream, *head, last * 2)
    u2 = rng.uniform(seed, stream, *head, last * 2 + 1)
    r = np.sqrt(-2.0 * np.log(np.maximum(u1, 1e-300)))
    return r * np.cos(2 * np.pi * u2), r * np.sin(2 * np.pi * u2)


def body_frame(rel: np.ndarray, heading) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Range, bearing and elevation of world vectors ``rel`` (n, dims) seen from bodies with ``heading`` (one or n)."""
    c, s = np.cos(heading), np.sin(heading)
    bx = c * rel[:, 0] + s * rel[:, 1]
    by = -s * rel[:, 0] + c * rel[:, 1]
    bz = rel[:, 2] if rel.shape[1] > 2 else np.zeros(len(rel))
    return np.sqrt(bx**2 + by**2 + bz**2), np.arctan2(by, bx), np.arctan2(bz, np.hypot(bx, by))


def closest_point(rel: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """The vectors ``rel`` shortened by the bodies' ``radius``: to the closest point of each body (Sano Eq. 4-5).

    A body that covers the observer's centre gives the zero vector.
    """
    d = np.linalg.norm(rel, axis=1)
    scale = np.where(d > 0, np.maximum(d - radius, 0.0) / np.where(d > 0, d, 1.0), 0.0)
    return rel * scale[:, None]


class Situated:
    """Per-robot situated parameters (filled from the robots' specs as robots appear) and their rules."""

    def __init__(self, seed: int, rab_all: bool = False):
        self.seed = seed
        self.rab_all = rab_all
        self.n = 0
        self.local = np.zeros(0, dtype=bool)
        self.surface = np.zeros(0, dtype=bool)
        self.radius = np.zeros(0)
        self.sigma_r = np.zeros(0)
        self.sigma_b = np.zeros(0)
        self.offset = np.zeros(0)  # heading offset delta (local sensing)
        self.start: list[np.ndarray] = []
        self.clock: list[tuple[float, float]] = []  # (offset s, drift ppm)
        self._rab: dict[tuple[int, int, int], tuple[float, float]] = {}
        self.any_local = False  # some robot senses in its own frame
        self.active = False  # some robot's sensing differs from the global default (local or surface)
        self.rab = rab_all  # some robot's frames carry range and bearing

    # ------------------------------------------------------------ robots
    def sync(self, specs: Sequence[RobotSpec]) -> None:
        """Take the parameters of robots added since the last call (``specs[i]`` is robot i's resolved spec)."""
        new = specs[self.n :]
        if not new:
            return
        ids = range(self.n, len(specs))
        local = [s.sensing_frame == "local" for s in new]
        self.local = np.concatenate([self.local, local])
        self.surface = np.concatenate([self.surface, [s.sensing_to == "surface" for s in new]])
        self.radius = np.concatenate([self.radius, [float(s.body_radius) for s in new]])
        self.sigma_r = np.concatenate([self.sigma_r, [float(s.range_noise) for s in new]])
        self.sigma_b = np.concatenate([self.sigma_b, [float(s.bearing_noise) for s in new]])
        self.offset = np.concatenate([self.offset, [
            draw(s.frame_offset, self.seed, rid, HEADING) if loc else 0.0
            for rid, s, loc in zip(ids, new, local, strict=True)]])
        self.start += [np.array(s.pos, dtype=float) for s in new]
        self.clock += [(draw(s.clock_offset, self.seed, rid, OFFSET), draw(s.clock_drift, self.seed, rid, DRIFT))
                       for rid, s in zip(ids, new, strict=True)]
        self.n = len(specs)
        self.any_local = bool(self.local.any())
        self.active = self.any_local or bool(self.surface.any())
        self.rab = self.rab_all or self.any_local

    def wants_rab(self, rid: int) -> bool:
        """Whether frames delivered to ``rid`` carry their range and bearing."""
        return self.rab_all or bool(self.local[rid])

    def descr(self, rid: int) -> dict:
        """What the robot's host must know (RobotDescr fields; defaults left out)."""
        out: dict = {}
        if self.local[rid]:
            out["sensing_frame"] = "local"
        offset, drift = self.clock[rid]
        if offset:
            out["clock_offset"] = offset
        if drift:
            out["clock_drift"] = drift
        return out

    # ------------------------------------------------------------ the robot's own frame
    def pose(self, rid: int, pos: np.ndarray, heading: float) -> list[float]:
        """Robot ``rid``'s odometry: position from its start turned by its offset delta, heading + delta."""
        d = float(self.offset[rid])
        p = np.asarray(pos, dtype=float) - self.start[rid][: len(pos)]
        c, s = math.cos(d), math.sin(d)
        x, y = c * float(p[0]) - s * float(p[1]), s * float(p[0]) + c * float(p[1])
        return [x, y, *p[2:].tolist(), float(_wrap(np.array(heading + d)))]

    def own_poses(self, poses: list[list[float]], pos: np.ndarray, heading: np.ndarray, digits: int) -> None:
        """Replace, in ``poses`` (one row per robot), the rows of local-sensing robots by their odometry."""
        ids = np.flatnonzero(self.local)
        if not ids.size:
            return
        d = self.offset[ids]
        c, s = np.cos(d), np.sin(d)
        p = pos[ids] - np.array([self.start[i][: pos.shape[1]] for i in ids.tolist()])
        rows = p.copy()
        rows[:, 0], rows[:, 1] = c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1]
        rows = np.round(np.column_stack([rows, _wrap(heading[ids] + d)]), digits).tolist()
        for rid, row in zip(ids.tolist(), rows, strict=True):
            poses[rid] = row

    def velocity(self, rid: int, v: np.ndarray) -> np.ndarray:
        """A local-sensing robot's command, given in its own frame, as a world velocity (turned by -delta)."""
        if not self.any_local or not self.local[rid]:
            return v
        d = float(self.offset[rid])
        c, s = math.cos(d), math.sin(d)
        w = np.array(v, dtype=float)
        w[0], w[1] = c * v[0] + s * v[1], -s * v[0] + c * v[1]
        return w

    # ------------------------------------------------------------ sensing
    def sense(self, pos: np.ndarray, heading: np.ndarray, alive_ids: np.ndarray, sensing: np.ndarray,
              noise: np.ndarray, neighbours: dict[int, np.ndarray], sensed: dict[int, list], tick: int,
              digits: int) -> dict[int, list]:
        """``sensed`` (world/sensing.py's, global) with the rows of local or surface-sensing robots replaced.

        A local robot's row holds, per neighbour, range and bearing (and elevation in 3-D) instead of a
        position; a surface-sensing robot in the global frame gets the closest points of the others' bodies.
        Computed for every (observer, observed) pair at once.
        """
        obs = [i for i in np.flatnonzero(self.local | self.surface).tolist() if i in sensed]
        if not obs:
            return sensed
        empty = np.zeros(0, dtype=np.int64)
        if self.surface.any():  # sensed if the closest point of the body is in range
            wide = within(pos, alive_ids, sensing + float(self.radius.max()))
            lists = [wide.get(i, empty) if self.surface[i] else neighbours.get(i, empty) for i in obs]
        else:
            lists = [neighbours.get(i, empty) for i in obs]
        obs_arr = np.array(obs, dtype=np.int64)
        i_of = np.repeat(obs_arr, [len(x) for x in lists])
        j_of = np.concatenate(lists) if lists else empty
        rel = pos[j_of] - pos[i_of]
        surf = self.surface[i_of]
        if surf.any():
            keep = ~surf | (np.linalg.norm(rel, axis=1) - self.radius[j_of] <= sensing[i_of])
            rel[surf] = closest_point(rel[surf], self.radius[j_of[surf]])
            i_of, j_of, rel = i_of[keep], j_of[keep], rel[keep]
        values = pos[i_of] + rel  # global rows: the (closest) point, in world coordinates
        g = ~self.local[i_of] & (noise[i_of] > 0)
        if g.any():  # the position noise of world/sensing.py, same draws
            n1, n2 = _gauss(self.seed, rng.NOISE, tick, i_of[g], j_of[g])
            values[g, 0] += noise[i_of[g]] * n1
            values[g, 1] += noise[i_of[g]] * n2
        loc = self.local[i_of]
        if loc.any():
            li, lj = i_of[loc], j_of[loc]
            r, b, e = body_frame(rel[loc], heading[li])
            noisy = (self.sigma_r[li] > 0) | (self.sigma_b[li] > 0)
            if noisy.any():
                n1, n2 = _gauss(self.seed, rng.BEARING, tick, li[noisy], lj[noisy])
                r[noisy] = np.maximum(r[noisy] + self.sigma_r[li[noisy]] * n1, 0.0)
                b[noisy] = _wrap(b[noisy] + self.sigma_b[li[noisy]] * n2)
            values[loc] = np.column_stack([r, b, e][: pos.shape[1]])
        values = np.round(values, digits)
        cuts = np.searchsorted(i_of, obs_arr[1:])
        for i, ids, rows in zip(obs, np.split(j_of, cuts), np.split(values, cuts), strict=True):
            sensed[i] = [ids.tolist(), rows.ravel().tolist()]
        return sensed

    # ------------------------------------------------------------ range and bearing of frames
    def note_rab(self, tick: int, deliveries: list[tuple], pos: np.ndarray, heading: np.ndarray) -> None:
        """Remember (range, bearing) of each delivery ``(dst, src, seq, frame, tick)`` whose receiver wants it."""
        if not deliveries:
            return
        dst, src, seq = (np.array(col, dtype=np.int64) for col in list(zip(*deliveries, strict=True))[:3])
        self.note_rab_arrays(tick, dst, src, seq, pos, heading)

    def note_rab_arrays(self, tick: int, dst: np.ndarray, src: np.ndarray, seq: np.ndarray, pos: np.ndarray,
                        heading: np.ndarray) -> None:
        """``note_rab`` for deliveries given as arrays of receivers, senders and sequence numbers."""
        if not self.rab_all:
            want = self.local[dst]
            dst, src, seq = dst[want], src[want], seq[want]
        if not len(dst):
            return
        r, b, _ = body_frame(pos[src] - pos[dst], heading[dst])
        noisy = (self.sigma_r[dst] > 0) | (self.sigma_b[dst] > 0)
        if noisy.any():
            n1, n2 = _gauss(self.seed, rng.RAB, tick, dst[noisy], src[noisy], seq[noisy])
            r[noisy] = np.maximum(r[noisy] + self.sigma_r[dst[noisy]] * n1, 0.0)
            b[noisy] = _wrap(b[noisy] + self.sigma_b[dst[noisy]] * n2)
        rb = np.round(np.column_stack([r, b]), 6).tolist()
        self._rab.update(zip(zip(src.tolist(), seq.tolist(), dst.tolist(), strict=True), map(tuple, rb), strict=True))

    def take_rab(self, src: int, seq: int, dst: int) -> tuple[float, float]:
        """The (range, bearing) noted for a delivery, forgotten once taken (NaNs if none was noted)."""
        return self._rab.pop((src, seq, dst), (math.nan, math.nan))
