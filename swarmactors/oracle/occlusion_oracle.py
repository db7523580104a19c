"""An independent oracle for radio occlusion: which links cross an obstacle, computed with shapely.

The world decides occlusion with its own vectorised clipping (``transport.space``); checks must not trust
that code, so this module recomputes the rule from the scenario's resolved shapes with a different method:
shapely intersects each link's ground track with each obstacle's footprint, and the link is blocked when a
piece of positive length of it lies, at its interpolated heights, within the obstacle's vertical extent.
A grid layer's footprint is the union of its blocked cells. Used by ``Result.graph_at`` (tests and
checks only; robot hosts never import it).
"""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import LineString, Point, Polygon, box
from shapely.ops import unary_union
from shapely.prepared import prep

EPS = 1e-9


class Occluders:
    """Footprints (shapely) with vertical extents, from a resolved ``[world]`` section."""

    def __init__(self, world: dict):
        self.flat = world["dims"] == 2
        self.shapes: list[tuple] = []  # (footprint, prepared footprint, z_lo, z_hi)
        for ob in world.get("obstacles") or []:
            self._add(Polygon(ob["xy"]), ob.get("z"))
        m = world.get("map")
        if m:
            cell = float(m["cell"])
            x0, y0 = m["origin"]
            for layer in m["layers"]:
                rows = layer["rows"]
                h = len(rows)
                cells = [box(x0 + c * cell, y0 + (h - 1 - r) * cell, x0 + (c + 1) * cell, y0 + (h - r) * cell)
                         for r, row in enumerate(rows) for c, ch in enumerate(row) if ch == "@"]
                if cells:
                    self._add(unary_union(cells), layer.get("z"))

    def _add(self, footprint, z) -> None:
        lo, hi = (-math.inf, math.inf) if z is None else (
            -math.inf if z[0] is None else z[0], math.inf if z[1] is None else z[1])
        self.shapes.append((footprint, prep(footprint), lo, hi))

    def blocks(self, a, b) -> bool:
        """Whether the link between points ``a`` and ``b`` (2 or 3 coordinates) crosses an obstacle."""
        a = np.asarray(a, dtype=float)
        b = np.asarray(b, dtype=float)
        za = a[2] if len(a) > 2 else 0.0
        zb = b[2] if len(b) > 2 else 0.0
        length = float(np.hypot(*(b[:2] - a[:2])))
        for footprint, prepared, lo, hi in self.shapes:
            if length < EPS:  # a vertical link
                if footprint.contains(Point(a[:2])) and (self.flat or (min(za, zb) <= hi and max(za, zb) >= lo)):
                    return True
                continue
            track = LineString([a[:2], b[:2]])
            if not prepared.intersects(track):
                continue
            inside = track.intersection(footprint)
            for piece in getattr(inside, "geoms", [inside]):
                if piece.is_empty or piece.length <= EPS:
                    continue
                if self.flat:
                    return True
                # heights at the piece's ends, interpolated along the link
                ts = [float(np.hypot(*(np.asarray(p) - a[:2]))) / length for p in piece.coords]
                zs = [za + t * (zb - za) for t in ts]
                if min(zs) <= hi + EPS and max(zs) >= lo - EPS:
                    return True
        return False
