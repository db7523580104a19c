"""The run plot: robot positions, radio links, and a status field as colour."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from swarmactors.result import Result  # noqa: E402


def plot_run(result: Result, path: Path, field: str | None = None, tick: int | None = None) -> Path:
    """Draw the swarm at ``tick`` (default: the origination-free final tick) coloured by status ``field``."""
    robots = result.robots
    if result.trace_path is not None:
        rec = result.trace[-1] if tick is None else result.record(tick)
        t = rec["t"]
        pos = {row[0]: row[1:3] for row in rec.get("pos", [])}
        g = result.graph_at(t)
    else:
        t = result["ticks"]
        pos = {rid: r["pose"][:2] for rid, r in robots.items() if r["alive"]}
        g = None
    fig, ax = plt.subplots(figsize=(7, 6.5), dpi=110)
    if g is not None:
        for a, b in g.edges:
            if a in pos and b in pos:
                ax.plot(*zip(pos[a], pos[b], strict=True), color="0.8", lw=0.8, zorder=1)
    values = {rid: robots[rid].get("status", {}).get(field) for rid in pos} if field else {}
    have = [rid for rid in pos if values.get(rid) is not None]
    lack = [rid for rid in pos if values.get(rid) is None]
    if have:
        xy = np.array([pos[r] for r in have])
        sc = ax.scatter(xy[:, 0], xy[:, 1], c=[values[r] for r in have], cmap="viridis", s=90, zorder=3,
                        edgecolors="k")
        fig.colorbar(sc, ax=ax, label=field)
    if lack:
        xy = np.array([pos[r] for r in lack])
        ax.scatter(xy[:, 0], xy[:, 1], c="white", s=90, zorder=3, edgecolors="0.4",
                   label=f"no {field}" if field else "robot")
        ax.legend(loc="upper right")
    dead = [rid for rid, r in robots.items() if not r["alive"]]
    if dead:
        xy = np.array([robots[r]["pose"][:2] for r in dead])
        ax.scatter(xy[:, 0], xy[:, 1], marker="x", c="red", s=60, zorder=4, label="failed")
    for rid, (x, y) in pos.items():
        ax.annotate(str(rid), (x, y), fontsize=6, ha="center", va="center", zorder=5)
    ax.set_aspect("equal")
    ax.set_xlabel("x (length units)")
    ax.set_ylabel("y (length units)")
    ax.set_title(f"{result['scenario']['run']['name']} at tick {t}: links and {field or 'positions'}")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path
