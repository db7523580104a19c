"""Drawing the world's space with matplotlib: obstacles, grid maps, bodies to scale, flying robots.

Used by ``swarm.png`` (swarmactors/tools/plots.py) and replay frames. Obstacles are grey, darker the higher they
reach (a full-height wall is darkest; a box that starts above the ground is hatched: robots fly under it);
grid maps are drawn as one image; water is blue. Bodies are drawn to scale as circles; flying robots as
triangles with their altitude written beside them when the swarm is small enough to read it.
"""

from __future__ import annotations

import numpy as np
from matplotlib.collections import PatchCollection
from matplotlib.patches import Circle, Polygon


def space_extent(world: dict) -> list[tuple[float, float]]:
    """Corner points of every obstacle and map, so that the axes' limits include them."""
    pts: list[tuple[float, float]] = []
    for ob in world.get("obstacles") or []:
        pts += [tuple(p) for p in ob["xy"]]
    m = world.get("map")
    if m:
        h, w = len(m["layers"][0]["rows"]), len(m["layers"][0]["rows"][0])
        x0, y0 = m["origin"]
        pts += [(x0, y0), (x0 + w * m["cell"], y0 + h * m["cell"])]
    return pts


def draw_space(ax, world: dict) -> None:
    """Draw the obstacles and the grid map of a resolved ``[world]`` section on ``ax`` (under the robots)."""
    patches, shades, hatched = [], [], []
    for ob in world.get("obstacles") or []:
        z = ob.get("z")
        lifted = z is not None and z[0] is not None and z[0] > 0
        patch = Polygon(ob["xy"], closed=True)
        (hatched if lifted else patches).append(patch)
        shades.append(0.35 if z is None or z[1] is None else 0.55)
    if patches:
        ax.add_collection(PatchCollection(patches, facecolors=[str(s) for s in shades[: len(patches)]],
                                          edgecolors="0.2", linewidths=0.5, zorder=0.5))
    if hatched:
        ax.add_collection(PatchCollection(hatched, facecolors="none", edgecolors="0.35", hatch="///",
                                          linewidths=0.5, zorder=0.5))
    m = world.get("map")
    if m:
        layers = m["layers"]
        h, w = len(layers[0]["rows"]), len(layers[0]["rows"][0])
        blocked = np.zeros((h, w))
        for layer in layers:
            z = layer.get("z")
            full = z is None or (z[0] is None or z[0] <= 0)
            b = np.array([[ch == "@" for ch in row] for row in layer["rows"]], dtype=bool)
            blocked = np.maximum(blocked, b * (0.8 if full else 0.4))
        rgba = np.zeros((h, w, 4))
        rgba[..., :3] = 0.25
        rgba[..., 3] = blocked
        if m.get("water"):
            wet = np.array([[ch == "W" for ch in row] for row in m["water"]], dtype=bool)
            rgba[wet] = (0.3, 0.5, 0.9, 0.5)
        x0, y0 = m["origin"]
        ax.imshow(rgba, extent=(x0, x0 + w * m["cell"], y0, y0 + h * m["cell"]), origin="upper",
                  interpolation="nearest", zorder=0.4)


def draw_bodies(ax, pos: dict[int, tuple], radius: dict[int, float]) -> None:
    """Bodies to scale: a circle of each robot's ``body_radius`` (robots without a body are skipped)."""
    circles = [Circle(pos[r][:2], radius[r]) for r in pos if radius.get(r, 0) > 0]
    if circles:
        ax.add_collection(PatchCollection(circles, facecolors="none", edgecolors="0.3", linewidths=0.6, zorder=2))


def draw_flying(ax, pos: dict[int, tuple], flying: set[int], size: float, labels: bool) -> None:
    """Flying robots as triangles over their discs, with the altitude (z) beside them when ``labels``."""
    ids = [r for r in pos if r in flying]
    if not ids:
        return
    xy = np.array([pos[r][:2] for r in ids], dtype=float)
    ax.scatter(xy[:, 0], xy[:, 1], marker="^", s=size * 0.5, c="none", edgecolors="tab:blue", linewidths=0.9,
               zorder=4)
    if labels:
        for r in ids:
            if len(pos[r]) > 2:
                ax.annotate(f"z={pos[r][2]:.1f}", pos[r][:2], xytext=(4, 4), textcoords="offset points",
                            fontsize=5, color="tab:blue", zorder=5)
