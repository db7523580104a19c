"""Path finding on the known map (002 Sec. IV, mobility module). Pure, deterministic, robot side.

The map is cut into square cells of side R (``resolution``); a cell is blocked when its centre is inside an
obstacle or closer than ``clearance`` to a blocked centre (the obstacles grown by the body and a margin).
Reachability is a flood fill of the free cells from the start (the paper's DFS over G_PE); the path is A*
(8-neighbour moves, no corner cutting, Euclidean heuristic, ties broken by insertion order) with a budget
of node expansions, never wall time. The cell path is then shortened by keeping a waypoint only where the
straight line from the previous kept one stops being free (line of sight over the grid).
"""

from __future__ import annotations

import heapq
import math
from collections import deque
from collections.abc import Callable

import numpy as np


class Grid:
    """Occupancy of the area [x0, x1] x [y0, y1] at resolution ``res`` (blocked cells in a set)."""

    dims = 2

    def __init__(self, area: list[list[float]], res: float, blocked_at: Callable[[float, float], bool],
                 clearance: float = 0.0):
        (self.x0, self.y0), (x1, y1) = [float(v) for v in area[0][:2]], [float(v) for v in area[1][:2]]
        self.res = float(res)
        self.cols = max(1, int(math.ceil((x1 - self.x0) / res)))
        self.rows = max(1, int(math.ceil((y1 - self.y0) / res)))
        hard = {(c, r) for c in range(self.cols) for r in range(self.rows) if blocked_at(*self.centre((c, r)))}
        grow = int(math.ceil(clearance / res))
        self.blocked = set(hard)
        if grow:
            offs = [(dc, dr) for dc in range(-grow, grow + 1) for dr in range(-grow, grow + 1)
                    if math.hypot(dc, dr) * res <= clearance + 1e-9]
            for c, r in hard:
                self.blocked.update((c + dc, r + dr) for dc, dr in offs)
        self.hard = hard

    def centre(self, cell: tuple[int, int]) -> tuple[float, float]:
        return (self.x0 + (cell[0] + 0.5) * self.res, self.y0 + (cell[1] + 0.5) * self.res)

    def cell(self, x: float, y: float) -> tuple[int, int] | None:
        c, r = int(math.floor((x - self.x0) / self.res)), int(math.floor((y - self.y0) / self.res))
        return (c, r) if 0 <= c < self.cols and 0 <= r < self.rows else None

    def free(self, cell: tuple[int, int]) -> bool:
        return 0 <= cell[0] < self.cols and 0 <= cell[1] < self.rows and cell not in self.blocked

    def neighbours(self, cell: tuple[int, int]):
        c, r = cell
        for dc, dr in ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)):
            n = (c + dc, r + dr)
            if not self.free(n):
                continue
            if dc and dr and not (self.free((c + dc, r)) and self.free((c, r + dr))):
                continue  # no corner cutting
            yield n, math.hypot(dc, dr)

    def nearest_free(self, cell: tuple[int, int], radius: int = 4) -> tuple[int, int] | None:
        """The start or goal cell itself, or the nearest free cell within ``radius`` cells (ring order)."""
        if self.free(cell):
            return cell
        best = None
        for dc in range(-radius, radius + 1):
            for dr in range(-radius, radius + 1):
                n = (cell[0] + dc, cell[1] + dr)
                if self.free(n) and (best is None or (dc * dc + dr * dr, n) < best[0]):
                    best = ((dc * dc + dr * dr, n), n)
        return best[1] if best else None

    def line_free(self, a: tuple[int, int], b: tuple[int, int]) -> bool:
        """Whether every cell the segment between two cell centres passes through (sampled at R/4) is free."""
        (ax, ay), (bx, by) = self.centre(a), self.centre(b)
        steps = max(1, int(math.ceil(4 * math.hypot(bx - ax, by - ay) / self.res)))
        for i in range(steps + 1):
            t = i / steps
            c = self.cell(ax + t * (bx - ax), ay + t * (by - ay))
            if c is None or c in self.blocked:
                return False
        return True


class Grid3:
    """Occupancy of the box [x0, x1] x [y0, y1] x [z0, z1] in cubic voxels of side ``res`` (3-D planning).

    Same rules as ``Grid`` one dimension up: a voxel is blocked when its centre is inside an obstacle
    (``blocked_all``: an n x 3 array of points -> n booleans, e.g. the known map's prisms with their z-extent)
    or within ``clearance`` of a blocked centre (a ball). Moves are 26-connected (faces, edges and corners of
    the cube, cost their length) with no corner cutting: a diagonal move needs every voxel of the unit cube it
    crosses to be free, so a path never slips between two blocked voxels that touch along an edge.
    """

    dims = 3
    MOVES = [(dx, dy, dz) for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1) if dx or dy or dz]

    def __init__(self, box: list[list[float]], res: float, blocked_all: Callable[[np.ndarray], np.ndarray],
                 clearance: float = 0.0):
        lo, hi = np.asarray(box[0][:3], dtype=float), np.asarray(box[1][:3], dtype=float)
        self.res = float(res)
        self.x0, self.y0, self.z0 = (float(v) for v in lo)
        self.shape = tuple(max(1, int(math.ceil((hi[k] - lo[k]) / res))) for k in range(3))
        idx = np.indices(self.shape).reshape(3, -1).T
        hard = np.asarray(blocked_all(lo + (idx + 0.5) * res), dtype=bool)
        self.hard = {tuple(int(v) for v in c) for c in idx[hard]}
        grow = int(math.ceil(clearance / res))
        offs = [(a, b, c) for a in range(-grow, grow + 1) for b in range(-grow, grow + 1)
                for c in range(-grow, grow + 1) if math.sqrt(a * a + b * b + c * c) * res <= clearance + 1e-9]
        self.blocked = {(i + a, j + b, k + c) for i, j, k in self.hard for a, b, c in offs} | self.hard
        self._free = np.zeros([n + 2 for n in self.shape], dtype=bool)  # padded by one blocked voxel
        self._free[1:-1, 1:-1, 1:-1] = True
        for c in self.blocked:
            if all(-1 <= c[k] <= self.shape[k] for k in range(3)):
                self._free[c[0] + 1, c[1] + 1, c[2] + 1] = False
        self._parts: dict[tuple[int, int, int], np.ndarray] = {}  # flood-filled component of a seed voxel

    def centre(self, cell: tuple[int, int, int]) -> tuple[float, float, float]:
        return (self.x0 + (cell[0] + 0.5) * self.res, self.y0 + (cell[1] + 0.5) * self.res,
                self.z0 + (cell[2] + 0.5) * self.res)

    def cell(self, x: float, y: float, z: float) -> tuple[int, int, int] | None:
        c = tuple(int(math.floor((v - o) / self.res)) for v, o in zip((x, y, z), (self.x0, self.y0, self.z0),
                                                                      strict=True))
        return c if all(0 <= c[k] < self.shape[k] for k in range(3)) else None

    def free(self, cell: tuple[int, int, int]) -> bool:
        if not all(-1 <= cell[k] <= self.shape[k] for k in range(3)):
            return False
        return bool(self._free[cell[0] + 1, cell[1] + 1, cell[2] + 1])

    def connected(self, a: tuple[int, int, int], b: tuple[int, int, int]) -> bool:
        """Whether two free voxels are in one component (the PE flag).

        With no corner cutting a diagonal move needs its whole cube free, so it can be replaced by face
        moves: the components of the 26-connected moves are those of 6-connectivity, flood-filled from ``a`` with
        numpy (robot hosts do not import scipy: tests/test_host_imports.py).
        """
        if a not in self._parts:
            self._parts[a] = self._component((a[0] + 1, a[1] + 1, a[2] + 1))
        return bool(self._parts[a][b[0] + 1, b[1] + 1, b[2] + 1])

    def _component(self, seed: tuple[int, int, int]) -> np.ndarray:
        """The free voxels 6-connected to ``seed`` (indices into the padded grid), by repeated face dilation."""
        free = self._free
        reached = np.zeros_like(free, dtype=bool)
        reached[seed] = bool(free[seed])
        while True:
            grown = reached.copy()
            for axis in range(3):
                lo = [slice(None)] * 3
                hi = [slice(None)] * 3
                lo[axis], hi[axis] = slice(1, None), slice(None, -1)
                grown[tuple(lo)] |= reached[tuple(hi)]
                grown[tuple(hi)] |= reached[tuple(lo)]
            grown &= free
            if np.array_equal(grown, reached):
                return reached
            reached = grown

    def neighbours(self, cell: tuple[int, int, int]):
        c = cell
        for d in self.MOVES:
            n = (c[0] + d[0], c[1] + d[1], c[2] + d[2])
            if not self.free(n):
                continue
            if sum(map(abs, d)) > 1 and not all(  # no corner cutting: the cube's other voxels are free too
                    self.free((c[0] + a * d[0], c[1] + b * d[1], c[2] + e * d[2]))
                    for a in (0, 1) for b in (0, 1) for e in (0, 1)):
                continue
            yield n, math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])

    def nearest_free(self, cell: tuple[int, int, int], radius: int = 4) -> tuple[int, int, int] | None:
        """The cell itself, or the nearest free voxel within ``radius`` voxels (ties: lowest index)."""
        if self.free(cell):
            return cell
        rng = range(-radius, radius + 1)
        near = [(a * a + b * b + c * c, (cell[0] + a, cell[1] + b, cell[2] + c))
                for a in rng for b in rng for c in rng]
        near = [q for q in near if self.free(q[1])]
        return min(near)[1] if near else None

    def line_free(self, a: tuple[int, int, int], b: tuple[int, int, int]) -> bool:
        """Whether every voxel the segment between two voxel centres passes through (sampled at R/4) is free."""
        pa, pb = np.array(self.centre(a)), np.array(self.centre(b))
        steps = max(1, int(math.ceil(4 * float(np.linalg.norm(pb - pa)) / self.res)))
        for i in range(steps + 1):
            c = self.cell(*(pa + i / steps * (pb - pa)))
            if c is None or c in self.blocked:
                return False
        return True


def reachable(grid: Grid, start: tuple[int, int], goal: tuple[int, int]) -> bool:
    """Flood fill of the free cells from ``start``: is ``goal`` among them (the PE flag)."""
    seen, todo = {start}, deque([start])
    while todo:
        cell = todo.popleft()
        if cell == goal:
            return True
        for n, _ in grid.neighbours(cell):
            if n not in seen:
                seen.add(n)
                todo.append(n)
    return False


def astar(grid: Grid, start: tuple[int, int], goal: tuple[int, int], budget: int) -> list[tuple[int, int]] | None:
    """A* over the free cells; None when the goal is not reached within ``budget`` expansions."""
    goal_c = grid.centre(goal)

    def h(c):
        return math.dist(goal_c, grid.centre(c)) / grid.res

    g = {start: 0.0}
    came: dict = {}
    seq = 0
    heap = [(h(start), seq, start)]
    closed = set()
    while heap and budget > 0:
        _, _, cell = heapq.heappop(heap)
        if cell in closed:
            continue
        if cell == goal:
            out = [cell]
            while out[-1] in came:
                out.append(came[out[-1]])
            return out[::-1]
        closed.add(cell)
        budget -= 1
        for n, cost in grid.neighbours(cell):
            ng = g[cell] + cost
            if ng < g.get(n, math.inf):
                g[n], came[n] = ng, cell
                seq += 1
                heapq.heappush(heap, (ng + h(n), seq, n))
    return None


def shorten(grid: Grid, cells: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """Keep a cell only where the line of sight from the last kept one ends (greedy string pulling)."""
    if len(cells) <= 2:
        return list(cells)
    out, i = [cells[0]], 0
    while i < len(cells) - 1:
        j = len(cells) - 1
        while j > i + 1 and not grid.line_free(cells[i], cells[j]):
            j -= 1
        out.append(cells[j])
        i = j
    return out


def plan(grid: Grid, start: list[float], goal: list[float], budget: int) -> tuple[str, list[list[float]]]:
    """("ok", waypoints from start to goal), or ("unreachable" | "budget" | "outside", [])."""
    s, t = grid.cell(*start[:grid.dims]), grid.cell(*goal[:grid.dims])
    if s is None or t is None:
        return "outside", []
    s, t = grid.nearest_free(s), grid.nearest_free(t)
    if s is None or t is None or not (grid.connected(s, t) if grid.dims == 3 else reachable(grid, s, t)):
        return "unreachable", []
    cells = astar(grid, s, t, budget)
    if cells is None:
        return "budget", []
    pts = [list(grid.centre(c)) for c in shorten(grid, cells)]
    pts[0], pts[-1] = [float(v) for v in start[:grid.dims]], [float(v) for v in goal[:grid.dims]]
    return "ok", pts


def length(path: list[list[float]]) -> float:
    """The length of a polyline."""
    return sum(math.dist(a, b) for a, b in zip(path, path[1:], strict=False))


def arc_3d(path: list[list[float]], s: float) -> float:
    """The arc length along the 3-D polyline ``path`` of the point at arc length ``s`` along its projection."""
    done, out = 0.0, 0.0
    for a, b in zip(path, path[1:], strict=False):
        flat, full = math.dist(a[:2], b[:2]), math.dist(a, b)
        if done + flat >= s and flat > 0:
            return out + (s - done) / flat * full
        done, out = done + flat, out + full
    return out

def ground_reach(path: list[list[float]], blocked_at, clearance: float, step: float = 0.05,
                 body: float | None = None) -> float:
    """Return the arc length a ground robot can follow along ``path``.

    That is, up to ``clearance`` before the first point where a body of radius ``body`` centred on the path
    touches a ground obstacle (the end of pi_g's ground part), sampled every ``step``. ``body`` defaults to
    ``clearance``; the behaviour passes the robot's body radius r_col / 2: a path planned at resolution R keeps
    its clearance only at cell centres, so between them (at a corner of a maze) it may pass closer than the
    clearance to a wall a ground robot still passes, which must not end the ground part there.
    """
    r = clearance if body is None else body
    ring = [(r * math.cos(a), r * math.sin(a)) for a in (k * math.pi / 4 for k in range(8))]
    s = 0.0
    for a, b in zip(path, path[1:], strict=False):
        seg = math.dist(a, b)
        for i in range(max(1, int(math.ceil(seg / step)))):
            t = i * step / seg if seg else 0.0
            x, y = a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])
            if blocked_at(x, y) or any(blocked_at(x + dx, y + dy) for dx, dy in ring):
                return max(0.0, s + t * seg - clearance)
        s += seg
    return s


def offset(path: list[list[float]], o: float, miter: float = 2.0) -> list[list[float]]:
    """The path shifted sideways by ``o`` (to its left when o > 0): one of C_n side-by-side chains (Sec. III-C).

    Each waypoint moves along the bisector of its two segments' left normals by o / cos(half the turn), so
    every segment stays parallel to the original at distance |o|; the factor is capped at ``miter`` (a sharp
    turn). Repeated points are dropped first.
    """
    p = np.asarray(path, dtype=float)
    if len(p):
        p = p[np.r_[True, np.linalg.norm(np.diff(p[:, :2], axis=0), axis=1) > 1e-12]]
    if o == 0 or len(p) < 2:
        return [[round(float(v), 4) for v in q] for q in p]
    seg = np.diff(p[:, :2], axis=0)
    unit = seg / np.linalg.norm(seg, axis=1)[:, None]
    normal = np.column_stack([-unit[:, 1], unit[:, 0]])
    out = p.copy()
    for i in range(len(p)):
        n = [normal[j] for j in (i - 1, i) if 0 <= j < len(normal)]
        b = np.sum(n, axis=0)
        nb = float(np.linalg.norm(b))
        b = n[0] if nb < 1e-9 else b / nb  # a U-turn: the two normals cancel; keep the incoming one
        out[i, :2] = p[i, :2] + o * min(miter, 1.0 / max(float(np.dot(b, n[0])), 1e-9)) * b
    return [[round(float(v), 4) for v in q] for q in out]
