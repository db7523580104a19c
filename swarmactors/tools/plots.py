"""The run plot: robot positions, radio links, and a status field as colour.

Drawn to scale with the swarm: all links are one ``LineCollection`` and all robots one scatter per group
(with / without the field, failed), so 10,000 robots take about as long as 50 (docs/benchmarks.md). Ids are
written only when they can be read (N <= ``LABEL_MAX`` or ``labels=True``). A status field whose values are
strings or booleans gets a categorical legend; a numeric one a colour bar.

What the robots work on is drawn too: the world's objects (SECS's tasks) as diamonds, and the points a
behaviour names in its parameters (``Behavior.plot_marks``: CBAA's ``tasks``, Swarm Relays' ``targets``) as
numbered stars. When the status field holds an index into those points (CBAA's ``task``), robots and points
share a colour per point and each robot is joined to its point by a dashed line.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib import patheffects  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

from swarmactors.oracle.result import Result  # noqa: E402

LABEL_MAX = 60  # ids are drawn only up to this many robots (unless asked for)
CATEGORY_MAX = 20  # more distinct categorical values than this fall back to "other"


def is_categorical(values: list) -> bool:
    """True when a status field's values are labels (strings, booleans, or mixed types), not quantities."""
    kinds = {type(v) for v in values if v is not None}
    if not kinds:
        return False
    return not kinds <= {int, float} or bool in kinds


def marker_size(n: int) -> float:
    """Scatter marker area (points^2) that keeps a swarm of ``n`` robots readable."""
    return float(np.clip(9000.0 / max(n, 1), 2.0, 90.0))


def categories(values: list) -> list[str]:
    """The legend's categories of a field's values (as strings, numbers by value), "other" past CATEGORY_MAX."""
    cats = sorted({str(v) for v in values if v is not None}, key=_natural)
    return cats[:CATEGORY_MAX - 1] + ["other"] if len(cats) > CATEGORY_MAX else cats


def category_cmap(cats: list[str]):
    """The qualitative colour map for ``cats`` (tab10, or tab20 past ten categories)."""
    return plt.get_cmap("tab10" if len(cats) <= 10 else "tab20")


def category_codes(cats: list[str], values: list) -> np.ndarray:
    """Each value's index in ``cats`` (values not among them: the last one, "other")."""
    index = {c: i for i, c in enumerate(cats)}
    return np.array([index.get(str(v), len(cats) - 1) for v in values], dtype=int)


def write_ids(ax, pos: dict[int, tuple], fontsize: float = 6) -> None:
    """Write each robot's id on its disc, black with a white halo (readable on dark discs too)."""
    halo = [patheffects.withStroke(linewidth=1.6, foreground="white")]
    for rid, p in pos.items():
        ax.text(p[0], p[1], str(rid), fontsize=fontsize, ha="center", va="center", zorder=5, color="black",
                path_effects=halo)


def swarm_links(result: Result, tick: int, rec: dict | None = None, severed: tuple | None = None
                ) -> list[tuple[int, int]]:
    """The links of the swarm at ``tick`` (undirected, as ``Result.graph_at``, which takes ``rec`` and ``severed``)."""
    return list(result.graph_at(tick, rec=rec, severed=severed).edges)


def plot_run(result: Result, path: Path, field: str | None = None, tick: int | None = None,
             labels: bool | None = None) -> Path:
    """Draw the swarm at ``tick`` (default: the last recorded tick) coloured by status ``field``.

    Args:
        result: a finished run.
        path: the PNG to write.
        field: status field that colours robots (None: plain discs).
        tick: tick to draw (needs the trace); default the last tick, or the final poses without a trace.
        labels: write robot ids; default only when there are at most ``LABEL_MAX`` robots.

    Returns:
        ``path``.
    """
    robots = result.robots
    if result.trace_path is not None:
        # streamed: one record in memory; the last tick in one pass with the cuts and partitions in force at it
        rec, severed = result.last_state() if tick is None else (result.record(tick), None)
        t = rec["t"]
        pos = {row[0]: row[1:3] for row in rec.get("pos", [])}
        edges = swarm_links(result, t, rec, severed)
    else:
        t = result["ticks"]
        pos = {rid: r["pose"][:2] for rid, r in robots.items() if r["alive"]}
        edges = []
    values = {rid: robots[rid].get("status", {}).get(field) for rid in pos if rid in robots} if field else {}
    dead = {rid: robots[rid]["pose"][:2] for rid, r in robots.items() if not r["alive"]}
    title = f"{result['scenario']['run']['name']} at tick {t}: links and {field or 'positions'}"
    marks = {"objects": {name: p[:2] for name, p in (result.data.get("objects") or {}).items()},
             **scenario_marks(result["scenario"])}
    world = result["scenario"].get("world") or {}
    space = None
    if world.get("obstacles") or world.get("map") or any(g.get("body_radius") or g.get("kind") == "flying"
                                                          for g in result["scenario"].get("robots", [])):
        full = {row[0]: row[1:] for row in rec.get("pos", [])} if result.trace_path is not None else {}
        space = {"world": world, "full": full,
                 "radius": {rid: r.get("body_radius", 0.0) for rid, r in _robot_specs(result).items()},
                 "flying": {rid for rid, r in _robot_specs(result).items() if r.get("kind") == "flying"}}
    return draw_swarm(path, pos, edges, field, values, dead, title, labels, space, marks)


def scenario_marks(sc: dict) -> dict[str, list]:
    """The points the scenario's behaviours work on (``Behavior.plot_marks``): label -> points, in order."""
    from swarmactors.robot.plugins import BEHAVIORS, PluginError, resolve

    out: dict[str, list] = {}
    for g in sc.get("robots", []):
        for spec in g.get("behaviors", []):
            try:
                cls = resolve(BEHAVIORS, spec["use"])
            except PluginError:
                continue
            for param, label in (getattr(cls, "plot_marks", None) or {}).items():
                points = spec.get(param)
                if isinstance(points, list) and label not in out:
                    out[label] = [list(p)[:2] for p in points if isinstance(p, (list, tuple)) and len(p) >= 2]
    return out


def _robot_specs(result: Result) -> dict[int, dict]:
    """Each robot's group parameters (body radius, kind), by id, from the resolved scenario's groups."""
    out, rid = {}, 0
    for g in result["scenario"].get("robots", []):
        for _ in range(g["count"]):
            out[rid] = g
            rid += 1
    return out


def draw_swarm(path: Path, pos: dict[int, tuple], edges: list[tuple[int, int]], field: str | None = None,
               values: dict[int, object] | None = None, dead: dict[int, tuple] | None = None, title: str = "",
               labels: bool | None = None, space: dict | None = None, marks: dict | None = None) -> Path:
    """Draw robots at ``pos`` (id -> (x, y)), ``edges`` between them, coloured by ``values`` of ``field``.

    Args:
        path: the PNG to write.
        pos: positions of the alive robots.
        edges: links as id pairs (pairs with an unknown end are skipped).
        field: name of the colouring field, for the legend or colour bar.
        values: the field's value per robot (missing or None: a white disc).
        dead: positions of failed robots, drawn as red crosses.
        title: the axes' title.
        labels: write ids; default only when ``len(pos) <= LABEL_MAX``.
        space: obstacles, bodies and flying robots to draw (plot_run builds it; swarmactors.tools.draw_space).
        marks: ``{"objects": {name: (x, y)}, label: [(x, y), ...]}``: world objects and the behaviours' points;
            a status ``field`` equal to a label indexes that label's points.

    Returns:
        ``path``.
    """
    values = values or {}
    dead = dead or {}
    n = len(pos) + len(dead)
    size = marker_size(n)
    fig, ax = plt.subplots(figsize=(7, 6.5), dpi=110)
    segs = [(*pos[a][:2], *pos[b][:2]) for a, b in edges if a in pos and b in pos]
    if segs:
        # one path through every link, broken by NaNs: one artist, one path (a path per link costs ~30 us)
        ends = np.asarray(segs, dtype=float).reshape(-1, 2, 2)
        line = np.concatenate([ends, np.full((len(ends), 1, 2), np.nan)], axis=1).reshape(-1, 2)
        lw = 0.8 if n <= 500 else 0.3
        ax.add_collection(LineCollection([line], colors="0.75", linewidths=lw, zorder=1))
    edge_kw = {"edgecolors": "k", "linewidths": 0.5} if n <= 2000 else {"linewidths": 0}
    have = [rid for rid in pos if values.get(rid) is not None]
    lack = [rid for rid in pos if values.get(rid) is None]
    handles = []
    colorbar = False
    marks = marks or {}
    indexed = marks.get(field) if field else None  # the field indexes these points (CBAA's task)
    extra_points = [p for name, pts in marks.items() if name != "objects" for p in pts]
    extra_points += list((marks.get("objects") or {}).values())
    if indexed:  # a value that indexes no point is drawn as no value
        good = [r for r in have if type(values[r]) is int and 0 <= values[r] < len(indexed)]
        lack += [r for r in have if r not in good]
        handles += _draw_indexed(ax, pos, values, good, indexed, field, size, edge_kw)
    elif have:
        xy = np.array([pos[r] for r in have], dtype=float)
        vals = [values[r] for r in have]
        if is_categorical(vals):
            cats = categories(vals)
            cmap = category_cmap(cats)
            ax.scatter(xy[:, 0], xy[:, 1], c=cmap(category_codes(cats, vals)), s=size, zorder=3, **edge_kw)
            handles += [Line2D([], [], marker="o", ls="", color=cmap(i), markeredgecolor="k", label=c)
                        for i, c in enumerate(cats)]
        else:
            sc = ax.scatter(xy[:, 0], xy[:, 1], c=np.asarray(vals, dtype=float), cmap="viridis", s=size,
                            zorder=3, **edge_kw)
            fig.colorbar(sc, ax=ax, label=field)
            colorbar = True
    for label, pts in marks.items():
        if label not in ("objects", field) and pts:
            handles += _draw_points(ax, pts, label)
    for name, p in (marks.get("objects") or {}).items():
        ax.scatter([p[0]], [p[1]], marker="D", c="#f1a340", s=70, edgecolors="k", zorder=5)
        ax.annotate(name, (p[0], p[1]), xytext=(5, 5), textcoords="offset points", fontsize=8)
    if marks.get("objects"):
        handles.append(Line2D([], [], marker="D", ls="", color="#f1a340", markeredgecolor="k", label="object"))
    if lack:
        xy = np.array([pos[r] for r in lack], dtype=float)
        ax.scatter(xy[:, 0], xy[:, 1], c="white", s=size, zorder=3, **({"edgecolors": "0.4"} | edge_kw))
        handles.append(Line2D([], [], marker="o", ls="", color="white", markeredgecolor="0.4",
                              label=f"no {field}" if field else "robot"))
    if dead:
        xy = np.array(list(dead.values()), dtype=float)
        ax.scatter(xy[:, 0], xy[:, 1], marker="x", c="red", s=max(size * 0.7, 4), zorder=4)
        handles.append(Line2D([], [], marker="x", ls="", color="red", label="failed"))
    if labels if labels is not None else n <= LABEL_MAX:
        write_ids(ax, pos)
    if handles:
        legend_title = field if field and len(handles) > 1 else None
        if colorbar:  # the colour bar holds the right side: the legend goes under the x label
            ax.legend(handles=handles, title=legend_title, loc="upper center", bbox_to_anchor=(0.5, -0.1),
                      ncol=min(len(handles), 4), fontsize=8, frameon=False)
        else:
            ax.legend(handles=handles, title=legend_title, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8,
                      frameon=False)
    extra = []
    if space:  # obstacles and maps under the robots, bodies to scale, flying robots marked (draw_space)
        from swarmactors.tools.draw_space import draw_bodies, draw_flying, draw_space, space_extent

        draw_space(ax, space["world"])
        draw_bodies(ax, pos, space["radius"])
        draw_flying(ax, space["full"] or pos, space["flying"], size, n <= LABEL_MAX)
        extra = space_extent(space["world"])
    _limits(ax, [*pos.values(), *dead.values(), *extra, *extra_points])
    ax.set_aspect("equal")
    ax.set_xlabel("x (length units)")
    ax.set_ylabel("y (length units)")
    ax.set_title(title)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def _draw_points(ax, points: list, label: str) -> list:
    """A behaviour's points (Swarm Relays' targets) as numbered stars; the legend handle."""
    xy = np.asarray(points, dtype=float)
    ax.scatter(xy[:, 0], xy[:, 1], marker="*", c="#e15759", s=160, edgecolors="k", linewidths=0.6, zorder=5)
    for i, p in enumerate(xy):
        ax.annotate(f"{label} {i}", (p[0], p[1]), xytext=(6, 4), textcoords="offset points", fontsize=8)
    return [Line2D([], [], marker="*", ls="", color="#e15759", markeredgecolor="k", markersize=11, label=label)]


def _draw_indexed(ax, pos: dict, values: dict, have: list, points: list, field: str, size: float,
                  edge_kw: dict) -> list:
    """Robots (``have``: a valid index) coloured by the point their ``field`` indexes, a dashed line to it."""
    cmap = category_cmap([str(i) for i in range(len(points))]) if len(points) <= 20 else plt.get_cmap("hsv")

    def colour(i):
        return cmap(i % 20) if len(points) <= 20 else cmap(i / len(points))

    xy = np.asarray(points, dtype=float)
    for i, p in enumerate(xy):
        ax.scatter([p[0]], [p[1]], marker="*", color=colour(i), s=170, edgecolors="k", linewidths=0.6, zorder=5)
        ax.annotate(f"{field} {i}", (p[0], p[1]), xytext=(6, 4), textcoords="offset points", fontsize=8)
    for r in have:
        p = xy[values[r]]
        ax.plot([pos[r][0], p[0]], [pos[r][1], p[1]], ls="--", lw=0.8, color=colour(values[r]), zorder=2)
    if have:
        robots = np.array([pos[r] for r in have], dtype=float)
        ax.scatter(robots[:, 0], robots[:, 1], c=[colour(values[r]) for r in have], s=size, zorder=3, **edge_kw)
    return [Line2D([], [], marker="*", ls="", color="0.5", markeredgecolor="k", markersize=11, label=field),
            Line2D([], [], marker="o", ls="--", color="0.5", markeredgecolor="k",
                   label=f"robot, to its {field} (same colour)")]


def _limits(ax, points: list) -> None:
    """Axis limits around every robot with a margin (cheaper than autoscaling thousands of markers)."""
    if not points:
        return
    xy = np.asarray([p[:2] for p in points], dtype=float)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    pad = np.maximum((hi - lo) * 0.05, 0.5)
    ax.set_xlim(lo[0] - pad[0], hi[0] + pad[0])
    ax.set_ylim(lo[1] - pad[1], hi[1] + pad[1])


def _natural(label: str) -> tuple:
    """Sort numeric-looking labels by value, the rest alphabetically after them."""
    try:
        return (0, float(label), "")
    except ValueError:
        return (1, 0.0, label)
