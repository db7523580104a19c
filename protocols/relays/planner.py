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
    gx, gy = grid.centre(goal)

    def h(c):
        x, y = grid.centre(c)
        return math.hypot(gx - x, gy - y) / grid.res

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
    s, t = grid.cell(*start[:2]), grid.cell(*goal[:2])
    if s is None or t is None:
        return "outside", []
    s, t = grid.nearest_free(s), grid.nearest_free(t)
    if s is None or t is None or not reachable(grid, s, t):
        return "unreachable", []
    cells = astar(grid, s, t, budget)
    if cells is None:
        return "budget", []
    pts = [list(grid.centre(c)) for c in shorten(grid, cells)]
    pts[0], pts[-1] = [float(v) for v in start[:2]], [float(v) for v in goal[:2]]
    return "ok", pts


def length(path: list[list[float]]) -> float:
    """The length of a polyline."""
    return sum(math.dist(a, b) for a, b in zip(path, path[1:], strict=False))


def ground_reach(path: list[list[float]], blocked_at, clearance: float, step: float = 0.05) -> float:
    """Return the arc length a ground robot can follow along ``path``.

    That is, up to where the path comes within ``clearance`` of a ground obstacle (the end of pi_g's ground
    part), sampled every ``step``.
    """
    ring = [(clearance * math.cos(a), clearance * math.sin(a)) for a in (k * math.pi / 4 for k in range(8))]
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
