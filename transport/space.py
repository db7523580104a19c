"""The world's static space: obstacles as convex prisms and occupancy grids, and their geometry.

One definition shared by the world (motion, radio occlusion, collisions, obstacle sensing) and by robots that
are given the map as prior knowledge (``ctx.map``): numpy only, no scipy, so a robot host may import it.

Shapes (docs/scenarios.md, "Obstacles and maps"):

* a **prism** is a convex polygon (counter-clockwise or clockwise vertices, at least 3) extruded over a
  vertical extent ``z = [z_min, z_max]`` (default: every height). A non-convex obstacle is a union of convex
  prisms; a wall with a window is two boxes, one under and one over the window.
* a **grid** is an occupancy grid of square cells (``cell`` length units, lower-left corner ``origin``)
  with one or more **layers**, each a vertical extent ``[z_lo, z_hi)`` and a boolean plane of blocked
  cells; row 0 of a plane is the map's *top* row (as the file is written), so a map looks the same on the
  screen as in the file. ``ground_only`` marks cells (water) that stop ground robots and nothing else.

Rules:

* In a **2-D** world (``flat``) heights do not exist: every obstacle blocks ground robots and the radio at
  every height, a flying robot crosses every obstacle, and water stops ground robots only.
* In a **3-D** world a ground robot stays at z = 0; a point is inside a prism when its (x, y) is inside
  the polygon and z_min <= z <= z_max, inside a grid cell when the layer holding its z blocks the cell.
* A segment is **blocked** when it overlaps an obstacle over a positive length (a segment that only grazes
  a corner or an edge is clear; its measure is zero for robots placed at random).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

INF = float("inf")


@dataclass(frozen=True)
class Prism:
    """A convex polygon ``xy`` (k x 2) extruded over ``z`` = (z_min, z_max)."""

    xy: np.ndarray
    z: tuple[float, float] = (-INF, INF)
    loss_db: float | None = None  # what a radio link crossing it loses (radio.channel.walls = "crossing")

    def half_spaces(self) -> tuple[np.ndarray, np.ndarray]:
        """Outward normals ``n`` (k+2 x 3) and offsets ``h``: inside is n . p <= h for every row."""
        xy = self.xy
        if _signed_area(xy) < 0:  # make the vertices counter-clockwise: outward normal = (dy, -dx)
            xy = xy[::-1]
        d = np.roll(xy, -1, axis=0) - xy
        n = np.column_stack([d[:, 1], -d[:, 0], np.zeros(len(xy))])
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        h = np.einsum("ij,ij->i", n[:, :2], xy)
        z_lo, z_hi = self.z
        n = np.vstack([n, [[0.0, 0.0, -1.0], [0.0, 0.0, 1.0]]])
        h = np.concatenate([h, [-z_lo if np.isfinite(z_lo) else INF, z_hi if np.isfinite(z_hi) else INF]])
        return n, h


@dataclass(frozen=True)
class Grid:
    """An occupancy grid: ``blocked[layer, row, col]``, layer ``k`` spanning ``z_edges[k]..z_edges[k+1]``."""

    origin: tuple[float, float]
    cell: float
    blocked: np.ndarray  # bool (L, H, W)
    z_edges: np.ndarray  # (L+1,), from -inf to +inf
    ground_only: np.ndarray  # bool (H, W): water

    @property
    def shape(self) -> tuple[int, int]:
        return self.blocked.shape[1], self.blocked.shape[2]

    def extent(self) -> tuple[float, float, float, float]:
        """(x_min, x_max, y_min, y_max) of the grid in world coordinates."""
        h, w = self.shape
        x0, y0 = self.origin
        return x0, x0 + w * self.cell, y0, y0 + h * self.cell

    def cells_at(self, pts: np.ndarray, flat: bool, ground: np.ndarray | bool) -> np.ndarray:
        """Whether each point (n x 3) lies in a cell that stops it (outside the grid: free)."""
        h, w = self.shape
        col = np.floor((pts[:, 0] - self.origin[0]) / self.cell).astype(np.int64)
        row_from_bottom = np.floor((pts[:, 1] - self.origin[1]) / self.cell).astype(np.int64)
        row = h - 1 - row_from_bottom
        ok = (col >= 0) & (col < w) & (row >= 0) & (row < h)
        out = np.zeros(len(pts), dtype=bool)
        if not ok.any():
            return out
        r, c = row[ok], col[ok]
        if flat:
            hit = self.blocked[:, r, c].any(axis=0)
        else:
            layer = np.clip(np.searchsorted(self.z_edges, pts[ok, 2], side="right") - 1, 0, len(self.z_edges) - 2)
            hit = self.blocked[layer, r, c]
        hit = hit | (self.ground_only[r, c] & np.broadcast_to(ground, (len(pts),))[ok])
        out[ok] = hit
        return out


@dataclass
class Space:
    """Every static obstacle of a run, with the geometric queries the world and robots ask of them."""

    prisms: list[Prism] = field(default_factory=list)
    grid: Grid | None = None
    flat: bool = True  # a 2-D world: no heights (module docstring)

    def __post_init__(self):
        k = max((len(p.xy) for p in self.prisms), default=0) + 2
        self._n = np.zeros((len(self.prisms), k, 3))
        self._h = np.full((len(self.prisms), k), INF)  # padding rows: 0 . p <= inf, always inside
        for i, p in enumerate(self.prisms):
            n, h = p.half_spaces()
            if self.flat:
                n, h = n[:-2], h[:-2]
            self._n[i, : len(n)] = n
            self._h[i, : len(h)] = h

    @property
    def empty(self) -> bool:
        return not self.prisms and self.grid is None

    # ------------------------------------------------------------ queries
    def first_hit(self, a: np.ndarray, b: np.ndarray, ground: np.ndarray | bool = True,
                  closed: bool = False) -> np.ndarray:
        """For segments a -> b (n x 3 each), the fraction t in [0, 1] where each first enters an obstacle.

        ``inf`` where the segment is clear. ``ground`` (per segment or one value) says whether water stops it.
        ``closed``: a segment that only touches an obstacle's boundary hits it too (motion: a robot never
        ends a step on a wall's face); otherwise only an overlap of positive length counts (occlusion).
        """
        a = np.asarray(a, dtype=float)
        b = np.asarray(b, dtype=float)
        t = np.full(len(a), INF)
        if len(a) == 0:
            return t
        if self.prisms:
            t = np.minimum(t, self._prisms_hit(a, b, closed))
        if self.grid is not None:
            t = np.minimum(t, self._grid_hit(a, b, ground))
            if closed:  # a step that ends on a blocked cell's boundary
                t = np.where(np.isinf(t) & self.grid.cells_at(b, self.flat, ground), 1.0, t)
        return t

    def blocked(self, a: np.ndarray, b: np.ndarray, ground: np.ndarray | bool = False) -> np.ndarray:
        """Whether each segment a -> b overlaps an obstacle over a positive length."""
        return np.isfinite(self.first_hit(a, b, ground))

    def wall_loss(self, a: np.ndarray, b: np.ndarray, default_db: float) -> np.ndarray:
        """The dB each segment a -> b loses through the walls it crosses.

        Each prism it overlaps over a positive length adds its ``loss_db`` (``default_db`` when it has none);
        each run of consecutive blocked grid cells along it adds ``default_db`` (a thick wall is one wall).
        """
        a = np.asarray(a, dtype=float)
        b = np.asarray(b, dtype=float)
        out = np.zeros(len(a))
        if len(a) == 0:
            return out
        if self.prisms:
            t_in, t_out, parallel_out = self._prisms_clip(a, b)
            crossed = (t_in < t_out) & ~parallel_out  # (n, m)
            loss = np.array([default_db if p.loss_db is None else p.loss_db for p in self.prisms], dtype=float)
            out += crossed.astype(float) @ loss
        if self.grid is not None:
            _t0, stop, valid = self._grid_cells(a, b, False)
            for i in range(len(a)):
                s = stop[i][valid[i]]
                if len(s):
                    out[i] += default_db * (int(s[0]) + int(np.count_nonzero(s[1:] & ~s[:-1])))
        return out

    def inside(self, pts: np.ndarray, ground: np.ndarray | bool = True) -> np.ndarray:
        """Whether each point (n x 3) is inside an obstacle (water counts for ground points)."""
        pts = np.asarray(pts, dtype=float)
        out = np.zeros(len(pts), dtype=bool)
        if len(pts) == 0:
            return out
        if self.prisms:
            p = pts if not self.flat else np.column_stack([pts[:, :2], np.zeros(len(pts))])
            val = np.einsum("mkd,nd->nmk", self._n, p) - self._h[None]
            out |= (val <= 0).all(axis=2).any(axis=1)
        if self.grid is not None:
            out |= self.grid.cells_at(pts, self.flat, ground)
        return out

    def clearance_overlap(self, pts: np.ndarray, radius: np.ndarray, ground: np.ndarray | bool = True) -> np.ndarray:
        """Index of an obstacle each body (centre ``pts``, ``radius``) overlaps, or -1 (grid cells: -2).

        A body overlaps a prism when the horizontal distance from its centre to the polygon is below its
        radius and (3-D) its centre is within ``radius`` of the prism's vertical extent; it overlaps a grid
        when a stopping cell lies closer than its radius.
        """
        pts = np.asarray(pts, dtype=float)
        radius = np.asarray(radius, dtype=float)
        out = np.full(len(pts), -1, dtype=np.int64)
        for i, p in enumerate(self.prisms):
            d = _distance_to_polygon(pts[:, :2], p.xy)
            hit = d < radius
            if not self.flat:
                hit &= (pts[:, 2] > p.z[0] - radius) & (pts[:, 2] < p.z[1] + radius)
            out = np.where((out == -1) & hit, i, out)
        if self.grid is not None:
            near = self._grid_near(pts, radius, ground)
            out = np.where((out == -1) & near, -2, out)
        return out

    # ------------------------------------------------------------ prisms: Cyrus-Beck clipping
    def _prisms_hit(self, a: np.ndarray, b: np.ndarray, closed: bool = False) -> np.ndarray:
        t_in, t_out, parallel_out = self._prisms_clip(a, b)
        hit = ((t_in <= t_out) if closed else (t_in < t_out)) & ~parallel_out
        return np.where(hit, t_in, INF).min(axis=1)

    def _prisms_clip(self, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per segment and prism (n x m): where it enters and leaves the prism (clipped to [0, 1]); parallel.

        The third array marks a segment parallel to a face and outside it: it misses the prism.
        """
        if self.flat:
            a = np.column_stack([a[:, :2], np.zeros(len(a))])
            b = np.column_stack([b[:, :2], np.zeros(len(b))])
        d = b - a
        na = np.einsum("mkd,nd->nmk", self._n, a)  # (n, m, k)
        nd = np.einsum("mkd,nd->nmk", self._n, d)
        num = self._h[None] - na
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = num / nd
        entering = nd < 0
        leaving = nd > 0
        parallel_out = (nd == 0) & (num < 0)
        t_in = np.where(entering, ratio, -INF).max(axis=2)
        t_out = np.where(leaving, ratio, INF).min(axis=2)
        t_in = np.maximum(t_in, 0.0)
        t_out = np.minimum(t_out, 1.0)
        return t_in, t_out, parallel_out.any(axis=2)

    # ------------------------------------------------------------ grids: every cell a segment crosses
    def _grid_hit(self, a: np.ndarray, b: np.ndarray, ground) -> np.ndarray:
        t0, stop, _valid = self._grid_cells(a, b, ground)
        return np.where(stop, t0, INF).min(axis=1)

    def _grid_cells(self, a: np.ndarray, b: np.ndarray, ground) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The pieces of each segment between cell borders, in order (n x pieces each).

        Where each piece starts (t), whether its cell stops the segment, whether it has a positive length.
        """
        g = self.grid
        d = b - a
        parts = [np.zeros((len(a), 1)), np.ones((len(a), 1))]
        axes = [(0, g.origin[0], g.cell), (1, g.origin[1], g.cell)]
        for axis, origin, cell in axes:
            lo = np.minimum(a[:, axis], b[:, axis])
            hi = np.maximum(a[:, axis], b[:, axis])
            k0 = np.ceil((lo - origin) / cell)
            k1 = np.floor((hi - origin) / cell)
            count = np.clip(k1 - k0 + 1, 0, None)
            m = int(count.max(initial=0))
            if m == 0:
                continue
            k = k0[:, None] + np.arange(m)[None]
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (origin + k * cell - a[:, axis, None]) / d[:, axis, None]
            t[(np.arange(m)[None] >= count[:, None]) | ~np.isfinite(t)] = np.nan
            parts.append(t)
        if not self.flat and len(g.z_edges) > 2:
            edges = g.z_edges[1:-1]
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (edges[None] - a[:, 2, None]) / d[:, 2, None]
            t[~((t > 0) & (t < 1))] = np.nan
            parts.append(t)
        ts = np.sort(np.clip(np.concatenate(parts, axis=1), 0.0, 1.0), axis=1)  # nan sorts last
        t0, t1 = ts[:, :-1], ts[:, 1:]
        valid = np.isfinite(t0) & np.isfinite(t1) & (t1 > t0)
        mid = np.where(valid, (t0 + t1) / 2, 0.0)
        pts = a[:, None, :] + mid[..., None] * d[:, None, :]
        gr = np.broadcast_to(np.asarray(ground), (len(a),))
        stop = g.cells_at(pts.reshape(-1, 3), self.flat, np.repeat(gr, mid.shape[1])).reshape(mid.shape) & valid
        return t0, stop, valid

    def _grid_near(self, pts: np.ndarray, radius: np.ndarray, ground) -> np.ndarray:
        g = self.grid
        out = np.zeros(len(pts), dtype=bool)
        idx = np.flatnonzero(radius > 0)
        if idx.size == 0:
            return out
        span = int(np.ceil(float(radius[idx].max()) / g.cell)) + 1
        offs = np.arange(-span, span + 1) * g.cell
        ox, oy = (a.ravel() for a in np.meshgrid(offs, offs))
        p = pts[idx]
        # centres of the cells around each body (k bodies x m cells)
        cx = g.origin[0] + (np.floor((p[:, 0, None] + ox[None] - g.origin[0]) / g.cell) + 0.5) * g.cell
        cy = g.origin[1] + (np.floor((p[:, 1, None] + oy[None] - g.origin[1]) / g.cell) + 0.5) * g.cell
        cz = np.broadcast_to(p[:, 2, None], cx.shape)
        gr = np.broadcast_to(np.asarray(ground), (len(pts),))[idx]
        stop = g.cells_at(np.column_stack([cx.ravel(), cy.ravel(), cz.ravel()]), self.flat,
                          np.repeat(gr, cx.shape[1])).reshape(cx.shape)
        dx = np.maximum(np.abs(cx - p[:, 0, None]) - g.cell / 2, 0.0)
        dy = np.maximum(np.abs(cy - p[:, 1, None]) - g.cell / 2, 0.0)
        out[idx] = (stop & (np.hypot(dx, dy) < radius[idx, None])).any(axis=1)
        return out


def _signed_area(xy: np.ndarray) -> float:
    x, y = xy[:, 0], xy[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _distance_to_polygon(p: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Distance from each point (n x 2) to a convex polygon (0 inside)."""
    a = xy
    b = np.roll(xy, -1, axis=0)
    ab = b - a
    ap = p[:, None, :] - a[None]
    t = np.clip(np.einsum("nkd,kd->nk", ap, ab) / np.einsum("kd,kd->k", ab, ab), 0.0, 1.0)
    closest = a[None] + t[..., None] * ab[None]
    dist = np.linalg.norm(p[:, None, :] - closest, axis=2).min(axis=1)
    cross = ab[None, :, 0] * ap[..., 1] - ab[None, :, 1] * ap[..., 0]
    inside = (cross >= 0).all(axis=1) | (cross <= 0).all(axis=1)
    return np.where(inside, 0.0, dist)


def convex(xy: np.ndarray) -> bool:
    """Whether the polygon's vertices (k x 2, k >= 3, in order) form a convex polygon with non-zero area."""
    d = np.roll(xy, -1, axis=0) - xy
    cross = d[:, 0] * np.roll(d[:, 1], -1) - d[:, 1] * np.roll(d[:, 0], -1)
    return abs(_signed_area(xy)) > 0 and ((cross >= -1e-12).all() or (cross <= 1e-12).all())


def space_from_spec(world: dict) -> Space:
    """The ``Space`` of a resolved ``[world]`` section (``obstacles`` and ``map``; see swarmactors.runs.maps)."""
    flat = world["dims"] == 2
    prisms = [Prism(np.asarray(o["xy"], dtype=float), _extent(o.get("z")), o.get("loss_db"))
              for o in world.get("obstacles") or []]
    grid = None
    m = world.get("map")
    if m:
        layers = m["layers"]
        blocked = np.array([[[ch == "@" for ch in row] for row in layer["rows"]] for layer in layers], dtype=bool)
        edges = [_extent(layers[0].get("z"))[0]] + [_extent(layer.get("z"))[1] for layer in layers]
        water = m.get("water")
        ground_only = (np.array([[ch == "W" for ch in row] for row in water], dtype=bool) if water
                       else np.zeros(blocked.shape[1:], dtype=bool))
        grid = Grid(tuple(map(float, m.get("origin", (0.0, 0.0)))), float(m.get("cell", 1.0)), blocked,
                    np.asarray(edges, dtype=float), ground_only)
    return Space(prisms, grid, flat)


def _extent(z) -> tuple[float, float]:
    """A vertical extent from its resolved form ([lo, hi], None meaning unbounded)."""
    if z is None:
        return (-INF, INF)
    lo, hi = z
    return (-INF if lo is None else float(lo), INF if hi is None else float(hi))
