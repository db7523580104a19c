"""Leader-follower navigation (Sano et al.): §5.1 Figs. 7–9 and §5.2 Figs. 10–11 reproduced, with plots.

    python -m protocols.leader_follower.experiments.paper [OUT_DIR]     # default out/leader-follower-paper

Runs scenarios/leader-follower.toml (proposed) and scenarios/leader-follower-prior.toml (prior method [17]),
both Table 1 at 0.01 s, and scenarios/leader-follower-experiment.toml (Table 2, 10 Hz); prints the numbers the
docs page quotes (first collision, first switch, margins, largest speed) and writes docs/img/leader_follower_*.png
(the panels of Figs. 8, 9 and 11: paths, distance to target, min distance to others − ρ″ and − size, speed, σ).
"""

from __future__ import annotations

import math
import sys
import tomllib
from pathlib import Path

from protocols.leader_follower import oracle
from swarmactors.runs.launcher import run

ROOT = Path(__file__).resolve().parents[3]  # the checkout: scenarios/, docs/img, out/
IMG = ROOT / "docs" / "img"


def series(r) -> dict:
    """Per-follower time series: distance to target, min distance to others − ρ″ / − size, ‖u‖, σ."""
    ru = oracle.load(r)
    dt = r["scenario"]["run"]["dt"]
    out = {i: {"t": [], "target": [], "others_rho2": [], "others_size": [], "speed": [], "sigma": []}
           for i in ru.followers}
    speed = {i: 0.0 for i in ru.agents}
    sig = {i: 0.0 for i in ru.agents}
    cmd_at: dict[int, list] = {}
    for t, rid, u in ru.cmd:
        cmd_at.setdefault(t, []).append((rid, u))
    sig_at: dict[int, list] = {}
    for t, rid, s in ru.sigma:
        sig_at.setdefault(t, []).append((rid, s))
    for k, t in enumerate(ru.ticks):
        for rid, u in cmd_at.get(t, []):
            speed[rid] = u
        for rid, s in sig_at.get(t, []):
            sig[rid] = s
        for i in ru.followers:
            j = ru.target[k].get(i)
            others = [ru.gap(k, i, m) for m in ru.pos[k] if m not in (i, j)]
            d = min(others) if others else math.nan
            a = ru.agents[i]
            s = out[i]
            s["t"].append(t * dt)
            s["target"].append(ru.gap(k, i, j) if j is not None else math.nan)
            s["others_rho2"].append(d - a.rho2)
            s["others_size"].append(d - a.size)
            s["speed"].append(speed[i])
            s["sigma"].append(sig[i])
    return out


def numbers(r, label: str) -> dict:
    ru = oracle.load(r)
    dt = r["scenario"]["run"]["dt"]
    col = r["world"].get("collisions") or {"robot_robot": 0, "episodes": []}
    first_col = min((e["start"] for e in col["episodes"]), default=None)
    reps = r.reports("leader_follower")
    switches = sorted((s[0], i, s[1], s[2]) for i, rep in reps.items() if rep.get("role") == "follower"
                      for s in rep["switches"])
    m = oracle.margins(ru)
    top = max((u / ru.agents[rid].U for _, rid, u in ru.cmd), default=0.0)
    out = {"label": label, "collisions": col["robot_robot"],
           "first_collision_s": None if first_col is None else round(first_col * dt, 2),
           "first_collision": col["episodes"][0]["collision"] if col["episodes"] else None,
           "switches": [(round(t * dt, 2), i, a, b) for t, i, a, b in switches],
           "target_margin_low": round(m["target_low"], 4), "target_margin_high": round(m["target_high"], 4),
           "body_margin": round(m["body"], 4), "max_speed_over_U": round(top, 4),
           "checks": r.verdicts()}
    return out


def plot(r, stem: str, title: str) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ru = oracle.load(r)
    s = series(r)
    fig, axes = plt.subplots(2, 3, figsize=(15, 8))
    ax = axes[0][0]
    for rid in sorted(ru.agents):
        xs = [p[rid][0] for p in ru.pos if rid in p]
        ys = [p[rid][1] for p in ru.pos if rid in p]
        color = plt.cm.tab20(rid % 20)
        ax.plot(xs, ys, lw=0.8, color=color, label="L" if rid == ru.leader else f"F{rid}")
        ax.plot(xs[:1], ys[:1], "o", ms=4, color=color)
    ax.set_aspect("equal")
    ax.set_title("(a) paths (circles: start)")
    ax.legend(fontsize=6, ncol=2)
    panels = [("target", "(b) distance to target [m]"), ("others_rho2", "(c) min distance to others − ρ″ [m]"),
              ("others_size", "(d) min distance to others − size [m]"), ("speed", "(e) ‖u‖ commanded [m/s]"),
              ("sigma", "(f) σ")]
    for (key, name), ax in zip(panels, [axes[0][1], axes[0][2], axes[1][0], axes[1][1], axes[1][2]], strict=True):
        for i, d in s.items():
            ax.plot(d["t"], d[key], lw=0.7, color=plt.cm.tab20(i % 20), label=f"F{i}")
        if key in ("others_rho2", "others_size"):
            ax.axhline(0.0, color="k", lw=0.6)
        ax.set_title(name)
        ax.set_xlabel("t [s]")
    fig.suptitle(title)
    fig.tight_layout()
    IMG.mkdir(parents=True, exist_ok=True)
    path = IMG / f"{stem}.png"
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def main(out_dir: Path) -> None:
    runs = [("leader-follower.toml", "leader_follower_proposed", "§5.1 proposed method (Table 1, 0.01 s)"),
            ("leader-follower-prior.toml", "leader_follower_prior", "§5.1 prior method [17] (Table 1, 0.01 s)"),
            ("leader-follower-experiment.toml", "leader_follower_experiment", "§5.2 four followers, 10 Hz")]
    for name, stem, title in runs:
        sc = tomllib.loads((ROOT / "scenarios" / name).read_text())
        r = run(sc, out=out_dir / stem)
        print(numbers(r, stem), flush=True)
        print("plot:", plot(r, stem, title), flush=True)


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "out" / "leader-follower-paper")
