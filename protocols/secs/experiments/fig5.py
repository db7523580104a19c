"""Fig. 5 of seed 003 drawn from one run: N = 16 backbone robots, three tasks 120° apart, δ = 240.

    python -m protocols.secs.experiments.fig5 [--seconds 300] [--distance 5] [--seed 1] [--img docs/img/secs_fig5.png]

Draws every robot's trajectory (colour = its arm), the final positions, the master and the tasks, and
prints the time each task was reached and the check outcomes.
"""

from __future__ import annotations

import argparse
import tempfile


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=300.0)
    ap.add_argument("--distance", type=float, default=5.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--img", default="docs/img/secs_fig5.png")
    args = ap.parse_args()

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    import swarmactors
    from protocols.secs import oracle
    from protocols.secs.scenarios import secs_scenario

    sc = secs_scenario(16, args.distance, tasks=3, seconds=args.seconds, seed=args.seed, name="secs-fig5")
    with tempfile.TemporaryDirectory() as tmp:
        result = swarmactors.run(sc, out=tmp)
        reached = oracle.reach_times(result)
        reports = result.reports("secs")
        tracks: dict[int, list] = {}
        for rec in result.trace:
            for row in rec["pos"]:
                tracks.setdefault(int(row[0]), []).append(row[1:3])
        checks = [(c["name"], c["passed"], c.get("value")) for c in result.checks]
    fig, ax = plt.subplots(figsize=(6, 6))
    colours = ["tab:blue", "tab:orange", "tab:green"]
    for rid, pts in tracks.items():
        pts = np.array(pts)
        arm = reports[rid]["arm"]
        c = "black" if rid == 0 else colours[arm % 3] if arm is not None else "grey"
        ax.plot(pts[:, 0], pts[:, 1], lw=0.5, color=c, alpha=0.5)
        ax.plot(*pts[-1], "o", color=c, ms=6 if rid == 0 else 4)
    for k, (name, p) in enumerate(oracle._tasks(result)):
        ax.plot(*p, "*", color=colours[k], ms=14, mec="black")
        ax.annotate(f"{name}: {reached[name]} s", p, textcoords="offset points", xytext=(6, 6), fontsize=8)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"SECS, N = 16, three tasks at {args.distance} m, δ = 240, {args.seconds:g} s")
    fig.tight_layout()
    fig.savefig(args.img, dpi=110)
    print("reached", reached)
    print("checks", checks)


if __name__ == "__main__":
    main()
