#!/usr/bin/env python
"""Time to draw ``swarm.png`` as the swarm grows.

    python benchmarks/plot_scale.py [--sizes 50 500 2000 10000] [--old-sizes 50 500] [--old FILE]

Robots are placed uniformly at random in a square sized for a mean degree of about 6 (radio range 1); links are
the pairs within range (a k-d tree, as the world computes them); a categorical status field (``role``, four
values) colours them. Timed: ``draw_swarm`` from figure creation to the PNG on disk (median of ``--repeat``
runs), separately the link computation, and ``plot_run`` end to end (the radio graph from a one-tick trace
with ``Result.graph_at``, then the drawing). ``--old FILE`` also times the earlier drawing code (one
``plot`` call per link, one ``annotate`` per robot), given as a copy of that ``plots.py``'s ``plot_run`` loop.
Nothing is asserted; results go to stdout and ``--json``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from functools import partial
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from swarmactors.tools.plots import draw_swarm, plot_run

ROLES = ("base", "repeater", "leader", "explorer")


def swarm(n: int, seed: int = 1) -> tuple[dict, list, dict]:
    """Positions, links and a categorical field for ``n`` robots at mean degree about 6."""
    rng = np.random.default_rng(seed)
    side = float(np.sqrt(n * np.pi / 6.0))
    xy = rng.uniform(0, side, size=(n, 2))
    pos = {i: (float(x), float(y)) for i, (x, y) in enumerate(xy)}
    values = {i: ROLES[int(k)] for i, k in enumerate(rng.integers(0, 4, n))}
    return pos, xy, values


def links(xy: np.ndarray) -> list[tuple[int, int]]:
    return [tuple(p) for p in cKDTree(xy).query_pairs(1.0, output_type="ndarray").tolist()]


def old_draw(path: Path, pos: dict, edges: list, values: dict) -> None:
    """The earlier drawing loop of swarmactors/tools/plots.py (numeric colour, one artist per link/label)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 6.5), dpi=110)
    for a, b in edges:
        ax.plot(*zip(pos[a], pos[b], strict=True), color="0.8", lw=0.8, zorder=1)
    xy = np.array(list(pos.values()))
    sc = ax.scatter(xy[:, 0], xy[:, 1], c=[ROLES.index(values[r]) for r in pos], cmap="viridis", s=90, zorder=3,
                    edgecolors="k")
    fig.colorbar(sc, ax=ax, label="role")
    for rid, (x, y) in pos.items():
        ax.annotate(str(rid), (x, y), fontsize=6, ha="center", va="center", zorder=5)
    ax.set_aspect("equal")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def fake_result(pos: dict, values: dict):
    """A Result whose trace is one tick record at ``pos`` (no run): for timing ``plot_run`` end to end."""
    from swarmactors.oracle.result import Result

    n = len(pos)
    data = {"trace": "trace.msgpack", "ticks": 1, "scenario": {"run": {"name": "bench"}, "radio": {"range": 1.0},
                                                               "robots": [{"count": n, "range": 1.0}]},
            "robots": {str(i): {"alive": True, "pose": [*pos[i], 0.0], "status": {"role": values[i]}} for i in pos}}
    result = Result(data, Path("/nonexistent/result.json"))
    result.__dict__["trace"] = [{"t": 0, "pos": [[i, *pos[i]] for i in pos]}]
    result.ranges = lambda: dict.fromkeys(pos, 1.0)
    return result


def timed(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[50, 500, 2000, 10000])
    ap.add_argument("--old-sizes", type=int, nargs="*", default=[50, 500])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        png = Path(tmp) / "swarm.png"
        draw_swarm(png, swarm(10)[0], [], title="warm-up")  # imports, font cache
        for n in sorted(set(args.sizes) | set(args.old_sizes)):
            pos, xy, values = swarm(n)
            t0 = time.perf_counter()
            edges = links(xy)
            t_links = time.perf_counter() - t0
            row = {"n": n, "links": len(edges), "links_s": round(t_links, 4)}
            if n in args.sizes:
                row["draw_s"] = round(timed(partial(draw_swarm, png, pos, edges, "role", values, title="bench"),
                                            args.repeat), 3)
                row["png_kb"] = round(png.stat().st_size / 1024)
                row["plot_run_s"] = round(timed(partial(plot_run, fake_result(pos, values), png, "role"), 1), 3)
            if n in args.old_sizes:
                row["old_draw_s"] = round(timed(partial(old_draw, png, pos, edges, values), 1), 3)
            rows.append(row)
            print(json.dumps(row), flush=True)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
