"""Per-run PNG charts from the trace, written beside result.json.

* ``connectivity.png`` - the true radio graph over time: share of the alive
  robots in the largest connected component, number of components, robots
  alive;
* ``messages.png`` - frames sent and deliveries per alive robot per tick, and
  drops per tick by cause;
* ``roles.png`` - when robots report a ``role`` status field: each robot's
  role over time (and the count of each role);
* ``convergence.png`` - for the status field a behaviour colours its robots by
  (``Behavior.plot_field``: flooding's ``hop``, CBAA's ``task``, stigmergy's
  ``keys``, …): the share of alive robots that hold a value, and the share that
  already hold their final value, over time. A real-valued field (λ2's ``l2``)
  is rarely equal to its final value before the end: for it the lower panel
  shows each robot's distance to its own final value (relative to that value),
  its median and its maximum over the robots, on a log scale.

The charts use only the trace and the resolved scenario, so they work for every
protocol family; a family is charted through the status fields it reports.
Long runs are sampled to at most ``MAX_COLUMNS`` ticks.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from swarmactors.oracle.result import Result
from swarmactors.tools.scene import initial_ranges

MAX_COLUMNS = 400
MAX_RASTER_ROBOTS = 300
CAUSE_COLOURS = {"range": "#bab0ac", "loss": "#e15759", "cut": "#b07aa1", "bandwidth": "#edc948",
                 "dead": "#4e79a7", "malformed": "#9c755f"}
PALETTE = ["#4e79a7", "#f28e2b", "#59a14f", "#b07aa1", "#76b7b2", "#edc948", "#ff9da7", "#9c755f", "#bab0ac",
           "#86bcb6"]


@contextmanager
def style() -> Iterator:
    """The one look of every chart: small type, light grid, no top/right spines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with plt.rc_context({"font.size": 9, "axes.titlesize": 10, "axes.labelsize": 9, "axes.grid": True,
                         "grid.alpha": 0.3, "axes.spines.top": False, "axes.spines.right": False,
                         "figure.dpi": 110, "savefig.bbox": "tight", "legend.fontsize": 8,
                         "legend.frameon": False}):
        yield plt


def write_charts(result: Result, out_dir: Path, field: str | None = None) -> list[Path]:
    """Write every chart that applies to this run; return their paths.

    The trace is streamed once (``Result.records``): per tick only counts are kept, positions only for the
    sampled ticks, and status changes as they come, so memory does not grow with the trace's full size.
    """
    counts, records, history = _digest(result)
    if not counts:
        return []
    name = result["scenario"]["run"]["name"]
    ranges = {**initial_ranges(result["scenario"]), **result.ranges()}
    from swarmactors.runs.scenario import occluding_space

    out = [connectivity(records, ranges, out_dir / "connectivity.png", name, occluding_space(result["scenario"])),
           messages(counts, out_dir / "messages.png", name)]
    if any("role" in fields for fields in history.values()):
        out.append(roles(records, history, out_dir / "roles.png", name))
    if field:
        out.append(convergence(records, history, field, out_dir / "convergence.png", name))
    return out


def _digest(result: Result) -> tuple[list[dict], list[dict], dict[int, dict]]:
    """One pass over the trace: per-tick counts, the records of about ``MAX_COLUMNS`` sampled ticks, statuses.

    Counts are ``{"t", "n" (robots alive), "sent", "del", "ovh", "drop": {cause: count}}``; the sampled records keep
    ``t`` and ``pos`` (every k-th tick, k from the run's tick count, and always the last).
    """
    every = max(1, -(-int(result.data.get("ticks") or 1) // MAX_COLUMNS))
    counts: list[dict] = []
    sampled: list[dict] = []
    history: dict[int, dict] = {}
    last = None
    for k, rec in enumerate(result.records()):
        drops: dict[str, int] = {}
        for d in rec.get("drop", ()):
            drops[d[3]] = drops.get(d[3], 0) + 1
        counts.append({"t": rec["t"], "n": len(rec.get("pos", ())), "sent": len(rec.get("sent", ())),
                       "del": len(rec.get("del", ())), "ovh": len(rec.get("ovh", ())), "drop": drops})
        _add_status(history, rec)
        last = {"t": rec["t"], "pos": rec.get("pos", [])}
        if k % every == 0:
            sampled.append(last)
    if last is not None and sampled[-1] is not last:
        sampled.append(last)
    return counts, sampled, history


def _sampled(records: list[dict]) -> list[int]:
    n = len(records)
    if n <= MAX_COLUMNS:
        return list(range(n))
    return sorted(set(np.linspace(0, n - 1, MAX_COLUMNS).round().astype(int).tolist()))


def connectivity(records: list[dict], ranges: dict[int, float], path: Path, name: str, space=None) -> Path:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from swarmactors.runs.scenario import mutual_links
    from transport.severance import Severance

    ticks, largest, components, alive = [], [], [], []
    links, sampled = Severance(), set(_sampled(records))  # cuts and partitions replayed from the events
    for i, rec in enumerate(records):
        for ev in rec.get("ev", ()):
            links.apply(ev)
        if i not in sampled:
            continue
        rows = rec.get("pos", [])
        ticks.append(rec["t"])
        alive.append(len(rows))
        if not rows:
            largest.append(0.0)
            components.append(0)
            continue
        ids = [r[0] for r in rows]
        xy = np.array([r[1:] for r in rows], dtype=float)
        rng = np.array([ranges.get(r, 1.0) for r in ids])
        pairs = np.array(mutual_links(xy, rng, space), dtype=int).reshape(-1, 2)
        if links and len(pairs):
            pairs = pairs[~links.mask(np.array(ids)[pairs[:, 0]], np.array(ids)[pairs[:, 1]])]
        g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])) if len(pairs) else
                       (np.zeros(0), (np.zeros(0, int), np.zeros(0, int))), shape=(len(ids), len(ids)))
        k, labels = connected_components(g, directed=False)
        components.append(int(k))
        largest.append(float(np.bincount(labels).max()) / len(ids))
    with style() as plt:
        fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 4.6), sharex=True)
        a1.plot(ticks, largest, color=PALETTE[0], lw=1.5)
        a1.set_ylim(-0.02, 1.02)
        a1.set_ylabel("largest component\n(share of alive robots)")
        a1.set_title(f"{name}: connectivity of the radio graph (mutual links)")
        a2.step(ticks, components, where="post", color=PALETTE[1], lw=1.5, label="components")
        a2.step(ticks, alive, where="post", color=PALETTE[2], lw=1.2, ls="--", label="robots alive")
        a2.set_ylabel("count")
        a2.set_xlabel("tick")
        a2.legend(loc="best")
        fig.savefig(path)
        plt.close(fig)
    return path


def messages(counts: list[dict], path: Path, name: str) -> Path:
    """Frames sent and delivered per alive robot, and drops by cause, per tick (``counts`` from ``_digest``)."""
    ticks = [c["t"] for c in counts]
    alive = np.array([max(c["n"], 1) for c in counts], dtype=float)
    sent = np.array([c["sent"] for c in counts], dtype=float)
    delivered = np.array([c["del"] for c in counts], dtype=float)
    overheard = np.array([c.get("ovh", 0) for c in counts], dtype=float)
    causes = sorted({cause for c in counts for cause in c["drop"]})
    drops = {cause: np.array([c["drop"].get(cause, 0) for c in counts]) for cause in causes}
    with style() as plt:
        fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 4.6), sharex=True)
        a1.plot(ticks, sent / alive, color=PALETTE[0], lw=1.2, label="frames sent")
        a1.plot(ticks, delivered / alive, color=PALETTE[2], lw=1.2, label="deliveries")
        if overheard.any():  # copies to excluded robots the radio carried (world/radio.py)
            a1.plot(ticks, overheard / alive, color=PALETTE[2], lw=1.0, ls=":", label="overheard")
        a1.set_ylabel("per alive robot\nper tick")
        a1.set_title(f"{name}: messages ({int(sent.sum())} frames, {int(delivered.sum())} deliveries)")
        a1.legend(loc="best")
        if causes:
            bottom = np.zeros(len(ticks))
            for c in causes:
                a2.bar(ticks, drops[c], bottom=bottom, width=1.0, color=CAUSE_COLOURS.get(c, "0.5"),
                       label=f"{c} ({int(drops[c].sum())})")
                bottom += drops[c]
            a2.legend(loc="best", title="cause")
        else:
            a2.text(0.5, 0.5, "no drops", transform=a2.transAxes, ha="center", va="center", color="0.4")
        a2.set_ylabel("drops per tick\n(frame, receiver)")
        a2.set_xlabel("tick")
        fig.savefig(path)
        plt.close(fig)
    return path


def _add_status(hist: dict[int, dict], rec: dict) -> None:
    """Add one record's status changes to ``hist``: robot id -> field -> [(tick, value), ...]."""
    for rid, changes in rec.get("status", {}).items():
        fields = hist.setdefault(rid, {})
        for k, v in changes.items():
            fields.setdefault(k, []).append((rec["t"], v))


def _value_at(changes: list[tuple[int, object]], t: int):
    value = None
    for tick, v in changes:
        if tick > t:
            break
        value = v
    return value


def roles(records: list[dict], history: dict[int, dict], path: Path, name: str) -> Path:
    cols = _sampled(records)
    ticks = [records[i]["t"] for i in cols]
    robots = sorted(rid for rid, f in history.items() if "role" in f)
    names = sorted({str(v) for rid in robots for _, v in history[rid]["role"] if v is not None})
    code = {n: i for i, n in enumerate(names)}
    grid = np.full((len(robots), len(ticks)), -1)
    for r, rid in enumerate(robots):
        ch = history[rid]["role"]
        for c, t in enumerate(ticks):
            v = _value_at(ch, t)
            if v is not None:
                grid[r, c] = code[str(v)]
    # robots not alive: blank
    for c, i in enumerate(cols):
        alive = {row[0] for row in records[i].get("pos", [])}
        for r, rid in enumerate(robots):
            if rid not in alive:
                grid[r, c] = -1
    with style() as plt:
        from matplotlib.colors import ListedColormap
        from matplotlib.patches import Patch

        raster = len(robots) <= MAX_RASTER_ROBOTS
        fig, axes = plt.subplots(2 if raster else 1, 1, figsize=(7, 5.2 if raster else 3), sharex=True,
                                 squeeze=False, gridspec_kw={"height_ratios": [3, 1.4]} if raster else None)
        colours = ["#ffffff"] + [PALETTE[i % len(PALETTE)] for i in range(len(names))]
        if raster:
            ax = axes[0, 0]
            step = (ticks[-1] - ticks[0]) / max(len(ticks) - 1, 1) if len(ticks) > 1 else 1
            ax.imshow(grid + 1, aspect="auto", interpolation="nearest", cmap=ListedColormap(colours),
                      vmin=0, vmax=len(colours) - 1, origin="lower",
                      extent=(ticks[0] - step / 2, ticks[-1] + step / 2, -0.5, len(robots) - 0.5))
            ax.grid(False)
            ax.set_ylabel("robot")
            shown = list(range(0, len(robots), max(1, len(robots) // 12)))
            ax.set_yticks(shown, [str(robots[i]) for i in shown])
            ax.set_title(f"{name}: role timeline")
            handles = [Patch(color=colours[i + 1], label=n) for i, n in enumerate(names)]
            ax.legend(handles=handles + [Patch(facecolor="white", edgecolor="0.5", label="none / failed")],
                      loc="upper left", bbox_to_anchor=(1.01, 1))
        ax = axes[-1, 0]
        for i, n in enumerate(names):
            ax.step(ticks, (grid == i).sum(axis=0), where="post", color=colours[i + 1], lw=1.4, label=n)
        ax.set_ylabel("robots")
        ax.set_xlabel("tick")
        if not raster:
            ax.set_title(f"{name}: robots per role")
            ax.legend(loc="best")
        fig.savefig(path)
        plt.close(fig)
    return path


def is_real_valued(values: list) -> bool:
    """Numbers of which some are not whole: a field that converges in distance, not in equality."""
    numbers = [v for v in values if v is not None]
    return bool(numbers) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in numbers) and any(
        isinstance(v, float) and not float(v).is_integer() for v in numbers)


def convergence(records: list[dict], history: dict[int, dict], field: str, path: Path, name: str) -> Path:
    if is_real_valued([v for f in history.values() for _, v in f.get(field, [])]):
        return convergence_distance(records, history, field, path, name)
    cols = _sampled(records)
    ticks = [records[i]["t"] for i in cols]
    final = {rid: f[field][-1][1] for rid, f in history.items() if field in f}
    have, settled = [], []
    for i, t in zip(cols, ticks, strict=True):
        alive = [row[0] for row in records[i].get("pos", [])]
        n = max(len(alive), 1)
        vals = {rid: _value_at(history.get(rid, {}).get(field, []), t) for rid in alive}
        have.append(sum(v is not None for v in vals.values()) / n)
        settled.append(sum(rid in final and vals[rid] == final[rid] and vals[rid] is not None for rid in alive) / n)
    with style() as plt:
        fig, ax = plt.subplots(figsize=(7, 3.2))
        ax.step(ticks, have, where="post", color=PALETTE[0], lw=1.5, label=f"robots with a {field}")
        ax.step(ticks, settled, where="post", color=PALETTE[1], lw=1.5, ls="--", label=f"{field} at its final value")
        ax.set_ylim(-0.02, 1.02)
        ax.set_ylabel("share of alive robots")
        ax.set_xlabel("tick")
        ax.set_title(f"{name}: convergence of status field {field!r}")
        ax.legend(loc="best")
        fig.savefig(path)
        plt.close(fig)
    return path


def convergence_distance(records: list[dict], history: dict[int, dict], field: str, path: Path, name: str) -> Path:
    """A real-valued field: the share of robots holding a value, and their distance to their final value.

    A robot's distance at a tick is |v - v_final| / |v_final| (|v - v_final| when its final value is 0); the
    chart draws the median and the largest over the alive robots that hold a value.
    """
    cols = _sampled(records)
    ticks = [records[i]["t"] for i in cols]
    final = {rid: float(f[field][-1][1]) for rid, f in history.items()
             if field in f and isinstance(f[field][-1][1], (int, float))}
    have, median, worst = [], [], []
    for i, t in zip(cols, ticks, strict=True):
        alive = [row[0] for row in records[i].get("pos", [])]
        vals = {rid: _value_at(history.get(rid, {}).get(field, []), t) for rid in alive}
        have.append(sum(v is not None for v in vals.values()) / max(len(alive), 1))
        d = [abs(float(v) - final[rid]) / (abs(final[rid]) or 1.0) for rid, v in vals.items()
             if isinstance(v, (int, float)) and not isinstance(v, bool) and rid in final]
        median.append(float(np.median(d)) if d else np.nan)
        worst.append(max(d) if d else np.nan)
    with style() as plt:
        fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 4.8), sharex=True, gridspec_kw={"height_ratios": [1, 2]})
        a1.step(ticks, have, where="post", color=PALETTE[0], lw=1.5)
        a1.set_ylim(-0.02, 1.02)
        a1.set_ylabel(f"robots with\na {field} (share)")
        a1.set_title(f"{name}: convergence of status field {field!r}")
        floor = 1e-6  # a robot at its final value: drawn at the floor of the log scale
        a2.step(ticks, np.maximum(median, floor), where="post", color=PALETTE[1], lw=1.5, label="median over robots")
        a2.step(ticks, np.maximum(worst, floor), where="post", color=PALETTE[3], lw=1.2, ls="--",
                label="largest over robots")
        a2.set_yscale("log")
        a2.set_ylabel(f"distance of {field} to its\nfinal value (relative)")
        a2.set_xlabel("tick")
        a2.legend(loc="best")
        fig.savefig(path)
        plt.close(fig)
    return path
