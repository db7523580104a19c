"""Neighbourhoods from positions: radio reach and sensing, from one k-d tree query per tick.

Robot j is within robot i's radius r_i when i != j, both are alive and the squared distance, summed
coordinate by coordinate in order, is at most r_i * r_i (a directed relation when radii differ). ``reach``
gives it for every robot at once as a CSR table (``Reach``): row i lists i's neighbours, sorted. Candidate
pairs come from a k-d tree queried with a margin, so the tree's own rounding at the edge loses no pair; the
rule above then decides on exact floats. ``within`` is the same table as ``{i: neighbours}``.

``sensed[i]`` lists (id, position) of the alive robots within its *sensing* range, with optional Gaussian
noise on the positions drawn from the counter-based generator keyed on (seed, tick, observer, observed).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from world import rng

MARGIN = 1e-9  # relative margin of the k-d tree's candidate query


@dataclass
class Reach:
    """Neighbours of every robot as CSR: ``nbrs[indptr[i]:indptr[i + 1]]`` are robot i's, sorted."""

    indptr: np.ndarray  # (n + 1,) int64
    nbrs: np.ndarray  # int64

    @property
    def n(self) -> int:
        return len(self.indptr) - 1

    def row(self, i: int) -> np.ndarray:
        return self.nbrs[self.indptr[i]: self.indptr[i + 1]]

    def owners(self) -> np.ndarray:
        """The robot whose row each entry of ``nbrs`` is in."""
        return np.repeat(np.arange(self.n, dtype=np.int64), np.diff(self.indptr))

    def find(self, src: np.ndarray, dst: np.ndarray) -> np.ndarray:
        """For each pair, the index in ``nbrs`` of ``dst`` in ``src``'s row, or -1 when it is not there."""
        src = np.asarray(src, dtype=np.int64)
        dst = np.asarray(dst, dtype=np.int64)
        stride = self.n + 1
        keys = self.owners() * stride + self.nbrs  # ascending: rows in order, each row sorted
        ok = (src >= 0) & (src < self.n) & (dst >= 0) & (dst < self.n)
        q = np.where(ok, src * stride + dst, -1)
        j = np.minimum(np.searchsorted(keys, q), max(len(keys) - 1, 0))
        found = ok & (len(keys) > 0)
        found[found] = keys[j[found]] == q[found]
        return np.where(found, j, -1)

    def as_dict(self, alive_ids: np.ndarray) -> dict[int, np.ndarray]:
        """``{i: neighbours}`` for the alive robots."""
        return {i: self.nbrs[self.indptr[i]: self.indptr[i + 1]] for i in alive_ids.tolist()}

    @classmethod
    def from_dict(cls, n: int, rows: dict[int, np.ndarray]) -> Reach:
        counts = np.zeros(n, dtype=np.int64)
        for i, ids in rows.items():
            counts[i] = len(ids)
        indptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(counts, out=indptr[1:])
        parts = [np.asarray(rows[i], dtype=np.int64) for i in sorted(rows) if len(rows[i])]
        return cls(indptr, np.concatenate(parts) if parts else np.zeros(0, dtype=np.int64))


SMALL_N = 20  # up to this many alive robots, ``reach`` tests all pairs in Python (numpy's calls cost more)


def reach(pos: np.ndarray, alive_ids: np.ndarray, radii: np.ndarray) -> Reach:
    """Every alive robot's neighbours within its own radius (the rule in the module's docstring)."""
    n = len(pos)
    alive_ids = np.asarray(alive_ids, dtype=np.int64)
    if alive_ids.size < 2:
        return Reach(np.zeros(n + 1, dtype=np.int64), np.zeros(0, dtype=np.int64))
    if alive_ids.size <= SMALL_N:
        small = reach_small(pos, alive_ids, radii)
        if small is not None:
            return small
    return reach_tree(pos, alive_ids, radii)


def reach_tree(pos: np.ndarray, alive_ids: np.ndarray, radii: np.ndarray) -> Reach:
    """``reach`` for two or more alive robots, from a k-d tree's candidate pairs (numpy throughout)."""
    n = len(pos)
    pts = pos[alive_ids]
    r = radii[alive_ids]
    # an unbalanced, uncompacted tree builds faster and gives the same candidates (the rule decides below)
    tree = cKDTree(pts, balanced_tree=False, compact_nodes=False)
    pairs = tree.query_pairs(max(float(r.max()), 0.0) * (1 + MARGIN) + 1e-12, output_type="ndarray")
    a, b = pairs[:, 0].astype(np.int64), pairs[:, 1].astype(np.int64)
    diff = pts[b] - pts[a]  # the other direction's differences are these negated: the same squares
    d2 = diff[:, 0] * diff[:, 0]
    for k in range(1, diff.shape[1]):
        d2 = d2 + diff[:, k] * diff[:, k]
    ab, ba = d2 <= r[a] * r[a], d2 <= r[b] * r[b]
    src = alive_ids[np.concatenate([a[ab], b[ba]])]
    dst = alive_ids[np.concatenate([b[ab], a[ba]])]
    key = np.sort(src * n + dst)  # rows in id order, each row sorted
    src = key // n
    counts = np.bincount(src, minlength=n)
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(counts, out=indptr[1:])
    return Reach(indptr, key - src * n)


def reach_small(pos: np.ndarray, alive_ids: np.ndarray, radii: np.ndarray) -> Reach | None:
    """``reach_tree``'s table by testing every pair in Python floats, bit for bit; None for a radius below 0.

    The squares are summed in the same order on the same doubles as in ``reach_tree`` (b's coordinates minus
    a's, for a before b in ``alive_ids``), so each pair is decided alike. A pair within a radius r >= 0 is
    always among the tree's candidates; with a negative (or NaN) radius it may not be, so those go to the tree.
    """
    n = len(pos)
    ids = alive_ids.tolist()
    pts = pos[alive_ids].tolist()
    rs = radii[alive_ids].tolist()
    if not all(r >= 0.0 for r in rs):
        return None
    r2 = [r * r for r in rs]
    rows: list[list[int]] = [[] for _ in range(n)]
    m = len(ids)
    planar = len(pts[0]) == 2
    for a in range(m):
        pa, ra2, row_a = pts[a], r2[a], rows[ids[a]]
        if planar:
            xa, ya = pa
        for b in range(a + 1, m):
            pb = pts[b]
            if planar:
                dx, dy = pb[0] - xa, pb[1] - ya
                d2 = dx * dx + dy * dy
            else:
                d2 = 0.0
                for k, x in enumerate(pa):
                    d = pb[k] - x
                    d2 = d * d if k == 0 else d2 + d * d
            if d2 <= ra2:
                row_a.append(ids[b])
            if d2 <= r2[b]:
                rows[ids[b]].append(ids[a])
    indptr = [0] * (n + 1)
    total = 0
    for i, row in enumerate(rows):
        if len(row) > 1:
            row.sort()
        total += len(row)
        indptr[i + 1] = total
    return Reach(np.array(indptr, dtype=np.int64),
                 np.array([j for row in rows for j in row], dtype=np.int64))


def within(pos: np.ndarray, alive_ids: np.ndarray, radii: np.ndarray) -> dict[int, np.ndarray]:
    """For each alive robot i, the sorted alive ids j != i within radii[i] (``reach`` as a dict)."""
    alive_ids = np.asarray(alive_ids, dtype=np.int64)
    if alive_ids.size == 0:
        return {}
    return reach(pos, alive_ids, radii).as_dict(alive_ids)


@dataclass
class Sensed:
    """What every robot senses, as CSR: robot i senses ``ids[indptr[i]:indptr[i + 1]]`` at the same rows of ``at``.

    ``at`` is (m, dims): a position per sensed robot (or, under situated sensing, its range and bearing).
    """

    indptr: np.ndarray  # (n + 1,) int64
    ids: np.ndarray  # (m,) int64
    at: np.ndarray  # (m, dims) float64

    def as_dict(self, alive_ids: np.ndarray) -> dict[int, list]:
        """``{i: [[j, ...], [x_j, y_j(, z_j), ...]]}`` (ids, flat coordinates) per alive robot."""
        ids, flat, ptr, dims = self.ids.tolist(), self.at.ravel().tolist(), self.indptr.tolist(), self.at.shape[1]
        return {i: [ids[ptr[i]: ptr[i + 1]], flat[ptr[i] * dims: ptr[i + 1] * dims]] for i in alive_ids.tolist()}

    @classmethod
    def from_dict(cls, n: int, dims: int, rows: dict[int, list]) -> Sensed:
        """The table of ``as_dict``'s form (robots missing from ``rows`` sense nothing)."""
        counts = np.zeros(n, dtype=np.int64)
        for i, (ids, _) in rows.items():
            counts[i] = len(ids)
        indptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(counts, out=indptr[1:])
        order = sorted(rows)
        ids = np.array([j for i in order for j in rows[i][0]], dtype=np.int64)
        at = np.array([v for i in order for v in rows[i][1]], dtype=float).reshape(len(ids), dims)
        return cls(indptr, ids, at)

    def rows(self, which: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For robots ``which``, in that order: offsets (len + 1) into, and the indices of, their entries."""
        return gather(self.indptr[which], self.indptr[which + 1])


def gather(starts: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ranges ``[starts[i], ends[i])`` of one array, concatenated: their offsets (len + 1) and the indices."""
    counts = ends - starts
    ptr = np.zeros(len(starts) + 1, dtype=np.int64)
    np.cumsum(counts, out=ptr[1:])
    return ptr, np.repeat(starts - ptr[:-1], counts) + np.arange(ptr[-1], dtype=np.int64)


def sense_arrays(pos: np.ndarray, table: Reach, noise: np.ndarray, seed: int, tick: int, digits: int = 6) -> Sensed:
    """What each robot of ``table`` senses: its row's robots and their positions, rounded to ``digits``.

    Positions are noisy where ``noise[i] > 0`` (x and y only; Box-Muller from two uniforms keyed on
    (seed, NOISE, tick, i, 2j) and (…, 2j + 1)); everything is computed for all pairs at once.
    """
    nbrs = table.nbrs
    values = np.round(pos, digits)[nbrs]
    noisy = noise > 0.0
    if noisy.any():
        obs = table.owners()
        noisy = noisy[obs]
    if noisy.any():
        i, j = obs[noisy], nbrs[noisy]
        p = pos[j].copy()
        u1 = rng.uniform(seed, rng.NOISE, tick, i, j * 2)
        u2 = rng.uniform(seed, rng.NOISE, tick, i, j * 2 + 1)
        r = np.sqrt(-2.0 * np.log(np.maximum(u1, 1e-300))) * noise[i]
        p[:, 0] += r * np.cos(2 * np.pi * u2)
        p[:, 1] += r * np.sin(2 * np.pi * u2)
        values[noisy] = np.round(p, digits)
    return Sensed(table.indptr, nbrs, values)


def sense_table(pos: np.ndarray, table: Reach, alive_ids: np.ndarray, noise: np.ndarray, seed: int, tick: int,
                digits: int = 6) -> dict[int, list]:
    """``sense_arrays`` as ``{i: [[j, ...], [x_j, y_j(, z_j), ...]]}`` (ids, flat coordinates) per alive robot."""
    return sense_arrays(pos, table, noise, seed, tick, digits).as_dict(alive_ids)


def sense(
    pos: np.ndarray,
    neighbours: dict[int, np.ndarray],
    noise: np.ndarray,
    seed: int,
    tick: int,
    digits: int = 6,
) -> dict[int, list]:
    """``sense_table`` for neighbours given as ``{i: ids}`` (rows in any order; ids as given)."""
    table = Reach.from_dict(len(pos), neighbours)
    return sense_table(pos, table, np.array(sorted(neighbours), dtype=np.int64), noise, seed, tick, digits)
