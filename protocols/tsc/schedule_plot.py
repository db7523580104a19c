"""A schedule drawn like the paper's Fig. 6: deployment points, the swarm's path, one arm per task, by slot."""

from __future__ import annotations

from pathlib import Path

from protocols.tsc.schedule import Instance, Schedule, dislocation, used_slots

__all__ = ["plot_schedule", "save_schedule_figure"]


def plot_schedule(inst: Instance, sched: Schedule, ax, title: str | None = None) -> None:
    """Draw ``sched`` on a matplotlib axis: tasks coloured by slot, arms Θ^s → σ_t labelled with w_t^s."""
    import matplotlib.pyplot as plt

    (x0, x1), (y0, y1) = inst.arena
    ax.add_patch(plt.Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, lw=0.8, color="0.6"))
    slots = used_slots(sched)
    cmap = plt.get_cmap("tab10" if len(slots) <= 10 else "tab20")
    path = [inst.start] + [tuple(sched.theta[s]) for s in slots]
    ax.plot(*zip(*path, strict=True), ls="--", lw=1.0, color="0.35", zorder=1)
    ax.plot(*inst.start, marker="s", ms=8, color="0.2", zorder=4, ls="none", label="start Θ₀")
    for k, s in enumerate(slots):
        c = cmap(k % cmap.N)
        th = sched.theta[s]
        for t, task in enumerate(inst.tasks):
            if not sched.x[t][s]:
                continue
            ax.plot([th[0], task.position[0]], [th[1], task.position[1]], color=c, lw=1.6, alpha=0.8, zorder=2)
            ax.plot(*task.position, marker="o", ms=4 + 2 * task.robots, color=c, mec="k", mew=0.5, zorder=3)
            mid = ((th[0] + task.position[0]) / 2, (th[1] + task.position[1]) / 2)
            ax.annotate(str(sched.w[t][s]), mid, fontsize=7, color=c, ha="center", va="bottom")
            ax.annotate(task.id, task.position, fontsize=7, xytext=(3, 3), textcoords="offset points")
        ax.plot(*th, marker="*", ms=14, color=c, mec="k", mew=0.6, zorder=5, ls="none",
                label=f"slot {k + 1} (z = {sched.z[s]:g})")
    ax.set_xlim(x0 - 0.03 * (x1 - x0), x1 + 0.03 * (x1 - x0))
    ax.set_ylim(y0 - 0.03 * (y1 - y0), y1 + 0.03 * (y1 - y0))
    ax.set_aspect("equal")
    ax.legend(fontsize=6, loc="upper right", framealpha=0.7)
    if title is None:
        title = f"{sched.model.upper()}: {len(slots)} slots, dislocation {dislocation(inst, sched):.3g}"
    ax.set_title(title, fontsize=9)


def save_schedule_figure(inst: Instance, tctm: Schedule, tdsm: Schedule | None, path: Path) -> Path:
    """TCTM's schedule and, when given, TDSM's side by side (Figs. 6-8's comparison on one instance)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [tctm] + ([tdsm] if tdsm is not None else [])
    fig, axes = plt.subplots(1, len(panels), figsize=(5.2 * len(panels), 5.2), squeeze=False)
    for ax, sched in zip(axes[0], panels, strict=True):
        plot_schedule(inst, sched, ax)
    fig.suptitle(f"{len(inst.robots)} robots, {len(inst.tasks)} tasks: deployment points (★), path from Θ₀ "
                 f"(dashed), arms labelled with w", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
