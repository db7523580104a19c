"""``trajectories.png``: where every robot went during a run, from the trace.

Up to ``PATHS_MAX`` robots, each robot's path is drawn coloured by time, or by a status field's value at each
tick (``field``: categories with a legend, numbers on a colour bar) (one ``LineCollection`` for the whole
swarm, ticks subsampled so that at most ``SEGMENTS_MAX`` segments are drawn), its start as a small dot and its
end as a disc. Above that, paths would be an unreadable tangle: a density heat map (how many robot-ticks fell in
each cell, log scale) is drawn instead. The world's bounds, when the scenario has them, frame the picture, so
nothing at the edge is cut off. A swarm in which no robot moved has no paths: its robots are drawn where they
stood, without a time colour bar, and the title says so. The title counts the run's ticks (first to last
record), not the records drawn.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from matplotlib.colors import LogNorm  # noqa: E402

PATHS_MAX = 200  # above this many robots: a density heat map
SEGMENTS_MAX = 200_000  # drawn path segments at most (ticks are subsampled beyond)
RECORDS_MAX = 2_000  # a finished run's trace is streamed and thinned to about this many ticks (and the last)


def tracks(records: list[dict]) -> tuple[np.ndarray, dict[int, np.ndarray]]:
    """Ticks and, per robot, its (x, y) at each tick (NaN when it was not alive or not yet there).

    Args:
        records: the trace's tick records.

    Returns:
        ``(ticks, {id: array of shape (len(ticks), 2)})``.
    """
    ticks = np.array([rec["t"] for rec in records], dtype=float)
    ids = sorted({row[0] for rec in records for row in rec.get("pos", ())})
    col = {rid: i for i, rid in enumerate(ids)}
    xy = np.full((len(ids), len(records), 2), np.nan)
    for k, rec in enumerate(records):
        for row in rec.get("pos", ()):
            xy[col[row[0]], k] = row[1:3]
    return ticks, {rid: xy[col[rid]] for rid in ids}


def status_track(records: list[dict], ids: list[int], field: str) -> dict[int, list]:
    """Per robot, the value of status ``field`` at each record (the last value set so far; None before any)."""
    out = {rid: [None] * len(records) for rid in ids}
    cur: dict[int, object] = {}
    for k, rec in enumerate(records):
        for rid, changes in rec.get("status", {}).items():
            if field in changes:
                cur[int(rid)] = changes[field]
        for rid, v in cur.items():
            if rid in out:
                out[rid][k] = v
    return out


def plot_trajectories(records: list[dict], path: Path, title: str = "", bounds: list | None = None,
                      density: bool | None = None, field: str | None = None) -> Path:
    """Write ``path``: robots' paths coloured by tick (or by status ``field``), or a density heat map.

    Args:
        records: the trace's tick records.
        path: the PNG to write.
        title: the picture's title.
        bounds: the world's ``[[xmin, ymin], [xmax, ymax]]`` (None: fit the data).
        density: force the heat map (True) or the paths (False); default: heat map above ``PATHS_MAX`` robots.
        field: colour each path segment by this status field's value at its end tick (None: by tick).

    Returns:
        ``path``.
    """
    ticks, by_robot = tracks(records)
    n = len(by_robot)
    span = int(ticks[-1] - ticks[0]) + 1 if len(ticks) else 0  # the run's ticks, whatever was thinned
    fig, ax = plt.subplots(figsize=(7, 6.5), dpi=110)
    allxy = np.concatenate(list(by_robot.values())) if by_robot else np.zeros((0, 2))
    allxy = allxy[~np.isnan(allxy).any(axis=1)]
    lo, hi = _extent(allxy, bounds)
    if density if density is not None else n > PATHS_MAX:
        bins = int(np.clip(np.sqrt(len(allxy)) / 4, 20, 200))
        h, xe, ye = np.histogram2d(allxy[:, 0], allxy[:, 1], bins=bins, range=[[lo[0], hi[0]], [lo[1], hi[1]]])
        im = ax.imshow(np.ma.masked_equal(h.T, 0), origin="lower", extent=(xe[0], xe[-1], ye[0], ye[-1]),
                       cmap="magma_r", norm=LogNorm(vmin=1, vmax=max(h.max(), 1)), aspect="equal",
                       interpolation="nearest")
        fig.colorbar(im, ax=ax, label="robot-ticks per cell")
        what = f"density of {n} robots over {span} ticks"
    else:
        stride = max(1, int(np.ceil(n * max(len(ticks) - 1, 1) / SEGMENTS_MAX)))
        keep = np.arange(0, len(ticks), stride)
        if len(ticks) and keep[-1] != len(ticks) - 1:
            keep = np.append(keep, len(ticks) - 1)
        segs, times, values = [], [], []
        status = status_track(records, list(by_robot), field) if field else {}
        for rid, xy in by_robot.items():
            p = xy[keep]
            s = np.stack([p[:-1], p[1:]], axis=1)
            ok = ~np.isnan(s).any(axis=(1, 2))
            segs.append(s[ok])
            times.append(ticks[keep][1:][ok])
            if field:
                vals = [status[rid][k] for k in keep[1:]]
                values += [v for v, good in zip(vals, ok, strict=True) if good]
        t0, t1 = (ticks[0], ticks[-1]) if len(ticks) else (0, 1)
        handles = []
        moved = any(bool(np.any(np.abs(s[:, 1] - s[:, 0]) > 0)) for s in segs if len(s))
        if moved:
            lw = 1.0 if n <= 50 else 0.5
            if field:
                handles = _by_field(fig, ax, np.concatenate(segs), values, field, lw)
            else:
                lc = LineCollection(np.concatenate(segs), array=np.concatenate(times), cmap="viridis",
                                    linewidths=lw, zorder=2)
                lc.set_clim(t0, max(t1, t0 + 1))
                ax.add_collection(lc)
                fig.colorbar(lc, ax=ax, label="tick")
        starts = np.array([xy[~np.isnan(xy).any(axis=1)][0] for xy in by_robot.values()
                           if (~np.isnan(xy).any(axis=1)).any()])
        ends = np.array([xy[~np.isnan(xy).any(axis=1)][-1] for xy in by_robot.values()
                         if (~np.isnan(xy).any(axis=1)).any()])
        size = float(np.clip(3000.0 / max(n, 1), 4.0, 40.0))
        if len(starts):
            ax.scatter(starts[:, 0], starts[:, 1], s=size / 3, c="0.5", zorder=3, label="start")
            ax.scatter(ends[:, 0], ends[:, 1], s=size, c="white", edgecolors="k", linewidths=0.5, zorder=4,
                       label="end (or failure)")
            if moved:
                ax.legend(handles=[*handles, *ax.get_legend_handles_labels()[0]], loc="best", fontsize=8,
                          framealpha=0.7, title=field if handles else None)
        if moved:
            step = round((ticks[-1] - ticks[0]) / max(len(ticks) - 1, 1)) * stride if len(ticks) > 1 else 1
            what = f"paths of {n} robots over {span} ticks" + (f" by {field}" if field else "")
            what += f" (every {step} ticks)" if step > 1 else ""
        else:
            what = f"{n} robots, none of which moved in {span} ticks"
    if bounds and _extent(allxy, bounds)[0] is not None and (hi - lo).max() >= 0.9 * _size(bounds):
        ax.add_patch(plt.Rectangle(tuple(bounds[0][:2]), bounds[1][0] - bounds[0][0], bounds[1][1] - bounds[0][1],
                                   fill=False, ec="0.3", lw=1, ls="--", zorder=1))
    pad = np.maximum((hi - lo) * 0.04, 0.2)
    ax.set_xlim(lo[0] - pad[0], hi[0] + pad[0])
    ax.set_ylim(lo[1] - pad[1], hi[1] + pad[1])
    ax.set_aspect("equal")
    ax.set_xlabel("x (length units)")
    ax.set_ylabel("y (length units)")
    ax.set_title(f"{title}: {what}" if title else what, fontsize=10)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def plot_result_trajectories(result, path: Path, density: bool | None = None, field: str | None = None) -> Path:
    """``plot_trajectories`` for a finished run (``swarmactors.oracle.result.Result`` with a trace)."""
    sc = result["scenario"]
    return plot_trajectories(thinned_records(result), path, sc["run"]["name"], sc.get("world", {}).get("bounds"),
                             density, field)


def thinned_records(result, most: int = RECORDS_MAX) -> list[dict]:
    """The trace streamed and thinned to every k-th tick record (about ``most``, and always the last one).

    A kept record holds ``t``, ``pos`` and the status changes since the previous kept one (so status tracks
    stay exact at the kept ticks); memory is O(N · most), whatever the trace's length.
    """
    every = max(1, -(-int(result.data.get("ticks") or 1) // most))
    kept: list[dict] = []
    status: dict = {}
    last = None
    for k, rec in enumerate(result.records()):
        for rid, changes in rec.get("status", {}).items():
            status.setdefault(rid, {}).update(changes)
        last = {"t": rec["t"], "pos": rec.get("pos", [])}
        if k % every == 0:
            last["status"], status = status, {}
            kept.append(last)
    if last is not None and (not kept or kept[-1] is not last):
        last["status"] = status
        kept.append(last)
    return kept


def _by_field(fig, ax, segs: np.ndarray, values: list, field: str, lw: float) -> list:
    """Draw path segments coloured by a status field's values; return the legend handles (categories)."""
    from matplotlib.lines import Line2D

    from swarmactors.tools.plots import categories, category_cmap, category_codes, is_categorical

    known = [v for v in values if v is not None]
    if known and is_categorical(known):
        cats = categories(known)
        cmap = category_cmap(cats)
        codes = category_codes(cats, values)
        colours = [cmap(c) if v is not None else (0.7, 0.7, 0.7, 1.0) for c, v in zip(codes, values, strict=True)]
        ax.add_collection(LineCollection(segs, colors=colours, linewidths=lw, zorder=2))
        handles = [Line2D([], [], color=cmap(i), lw=2, label=c) for i, c in enumerate(cats)]
        if len(known) < len(values):
            handles.append(Line2D([], [], color=(0.7, 0.7, 0.7, 1.0), lw=2, label=f"no {field}"))
        return handles
    arr = np.array([float(v) if v is not None else np.nan for v in values])
    cmap = plt.get_cmap("viridis").with_extremes(bad="0.7")  # no value yet: grey
    lc = LineCollection(segs, array=arr, cmap=cmap, linewidths=lw, zorder=2)
    ax.add_collection(lc)
    fig.colorbar(lc, ax=ax, label=field)
    return []


def _size(bounds: list) -> float:
    return float(max(bounds[1][0] - bounds[0][0], bounds[1][1] - bounds[0][1]))


def _extent(xy: np.ndarray, bounds: list | None) -> tuple[np.ndarray, np.ndarray]:
    if bounds and len(xy):  # bounds far larger than where the robots went would shrink the paths to a dot
        span = np.ptp(xy, axis=0).max()
        if span < 0.25 * (np.array(bounds[1][:2], dtype=float) - np.array(bounds[0][:2], dtype=float)).max():
            bounds = None
    if bounds:
        lo = np.array(bounds[0][:2], dtype=float)
        hi = np.array(bounds[1][:2], dtype=float)
        if len(xy):
            lo, hi = np.minimum(lo, xy.min(axis=0)), np.maximum(hi, xy.max(axis=0))
        return lo, hi
    if not len(xy):
        return np.zeros(2), np.ones(2)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    same = hi - lo < 1e-9
    return lo - same * 0.5, hi + same * 0.5


def write_trajectories(result, out_dir: Path, err=None) -> Path | None:
    """Write ``out_dir/trajectories.png`` after a run; a failure is reported on ``err``, never fatal."""
    try:
        return plot_result_trajectories(result, Path(out_dir) / "trajectories.png")
    except Exception as exc:  # a picture must never cost the run its result
        if err is not None:
            err.print(f"[yellow]trajectories skipped:[/] {exc.__class__.__name__}: {exc}")
        return None
