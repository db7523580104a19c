"""Swarm Relays (seed 002): the paper's Figs. 6 and 7 as scripts and sweep files; see README.md here."""

def replot_fig6(results, out_dir):
    """Fig. 6 re-drawn from the saved sweep rows: the time factor (``results``) and the failures beside it."""
    from pathlib import Path

    from protocols.relays.experiments.fig6 import plot
    from swarmactors.tools.sweep import returned_values

    rows = returned_values(results)
    failures = Path(results).with_name("fig6_failures_sweep.csv")
    rows += returned_values(failures) if failures.exists() else []
    path = Path(out_dir) / "relays_fig6.png"
    plot(rows, path)
    return [path]


def replot_fig7(results, out_dir):
    """Fig. 7 re-drawn from the saved sweep rows (``results``), without the sweep's printed summary.

    Arena 1 (ground only) comes from ``fig7_arena1_35.csv`` beside them when it is there: its 35 runs a cell
    replace the reduced rows of that arena (whose trials 0-2 they repeat).
    """
    from pathlib import Path

    from protocols.relays.experiments.fig7 import plot
    from swarmactors.tools.sweep import returned_values

    rows = returned_values(results)
    arena1 = Path(results).with_name("fig7_arena1_35.csv")
    if arena1.exists():
        rows = [r for r in rows if (r["arena"], r.get("hetero", 0)) != (1, 0)] + returned_values(arena1)
    path = Path(out_dir) / "relays_fig7.png"
    plot(rows, path)
    return [path]


# The paper's figures this package reproduces, for ``swarmactors figures`` (swarmactors/tools/figures.py).
FIGURES = [
    {"id": "relays-fig6", "paper": "seed 002, Fig. 6",
     "title": "time factor in 12 conditions (top/middle); recovery after f = 1-5 failed networkers (bottom)",
     "results": "results/fig6_sweep.csv", "plot": "protocols.relays.experiments:replot_fig6",
     "images": ["relays_fig6.png"], "sweep": "protocols/relays/experiments/fig6.toml",
     "docs": "protocols/relays.md#fig-6-middletop-time-factor", "repetitions": "35 runs a condition"},
    {"id": "relays-fig6-failures", "paper": "seed 002, Fig. 6 bottom",
     "title": "recovery after f = 1-5 consecutive failed networkers", "results": "results/fig6_failures_sweep.csv",
     "plot": None, "sweep": "protocols/relays/experiments/fig6-failures.toml",
     "docs": "protocols/relays.md#fig-6-bottom-recovery-after-consecutive-failures", "repetitions": "35 chains"},
    {"id": "relays-fig7", "paper": "seed 002, Fig. 7",
     "title": "maze arenas, C_n = 1-3 chains, random failures F", "results": "results/fig7.csv",
     "plot": "protocols.relays.experiments:replot_fig7", "images": ["relays_fig7.png"],
     "sweep": "protocols/relays/experiments/fig7.toml",
     "docs": "protocols/relays.md#fig-7-reduced-maze-arenas-c_n--13-chains-random-failures",
     "repetitions": "35 runs a cell"},
]
