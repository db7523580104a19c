#!/usr/bin/env python
"""Task Scheduling Controller (seed 003 §IV-B, Table II, Figs. 6-8): TCTM and TDSM solve times on HiGHS.

    python -m protocols.tsc.experiments.tsc_experiments [--quick] [--per-cell 24] [--time-limit 60] [--jobs 2] \
        [--out benchmarks/results/tsc.json] [--img docs/img] [--resume]

Instances as in §IV-B: square arena of side L = sqrt(|N| π Γ² / D) (Eq. 15), |C| = 2, Γ = Ω = 1, μ = 0,
D in {0.005, 0.01, 0.05, 0.1, 0.2, 0.5}, five classes (CLASSES below: the paper prints none of |N|, |T|,
p_Rob, p_Tsk, β_max, δ_max; class 5 is class 1 with heterogeneous durations), 24 instances per (class, D):
720 in all. Each instance is solved as in the paper: TCTM, then TDSM bounded by TCTM's Λ, each with the time
limit; instances run in parallel worker processes (one HiGHS each). Every schedule is checked by
``protocols.tsc.schedule_check``. ``--per-cell K`` runs the first K instances of every cell (the same ones
whatever K); ``--resume`` skips the instances already in the output JSON or in the ``.partial.jsonl`` log an
interrupted run leaves beside it.

Writes the per-instance records and the Table II aggregates to the JSON file, and ``tsc-times.png`` (Table II
as curves, and Λ against D), ``tsc-dislocation.png`` (Fig. 7), ``tsc-arms.png`` (Fig. 8) and
``tsc-schedule.png`` (Fig. 6: one instance, both models) to the image directory. Nothing is asserted.

The same experiment as one sweep (``protocols/tsc/experiments/tsc-table2.toml``: a grid of class × D, 24
trials a cell, each trial one instance solved by ``sweep_trial``; ``sweep_figures`` draws Table II and Figs. 7-8
from trials.csv), locally or on a Dask cluster:

    swarmactors sweep protocols/tsc/experiments/tsc-table2.toml [--cluster tcp://SCHEDULER:8786] [--trials 8]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import scipy  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]  # the checkout: protocols/tsc/experiments/ is three levels down
sys.path.insert(0, str(ROOT))

from protocols.tsc.schedule import (  # noqa: E402
    DENSITIES,
    arm_cost,
    completion_time,
    dislocation,
    random_instance,
    solve_tctm,
    solve_tdsm,
    used_slots,
)
from protocols.tsc.schedule_check import check_schedule, euclidean_excess  # noqa: E402
from swarmactors.tools.sweep import returned_values  # noqa: E402

# One base class and one-factor variations of it (docs/protocols/tsc.md, "Instances"): sized so that HiGHS on
# one core solves most instances within the limit at large D and reaches it on part of the small-D ones.
CLASSES = {
    1: {"n_robots": 20, "n_tasks": 6, "p_rob": 0.5, "p_tsk": 0.5, "beta_max": 3, "delta_max": 1},  # base
    2: {"n_robots": 20, "n_tasks": 6, "p_rob": 0.8, "p_tsk": 0.2, "beta_max": 3, "delta_max": 1},  # versatile robots
    3: {"n_robots": 20, "n_tasks": 8, "p_rob": 0.5, "p_tsk": 0.5, "beta_max": 3, "delta_max": 1},  # more tasks
    4: {"n_robots": 20, "n_tasks": 6, "p_rob": 0.3, "p_tsk": 0.7, "beta_max": 5, "delta_max": 1},  # scarce, big
    5: {"n_robots": 20, "n_tasks": 6, "p_rob": 0.5, "p_tsk": 0.5, "beta_max": 3, "delta_max": 5},  # durations
}
QUICK = {c: p | {"n_robots": 8, "n_tasks": 4} for c, p in CLASSES.items()}
PER_CELL = 24
SEED = 2018
PAPER_TCTM = {1: [908.1, 206.4, 15.3, 7.0, 4.9, 0.8], 2: [210.7, 62.8, 3.8, 3.6, 2.8, 0.7],
              3: [1488.4, 479.6, 13.6, 12.2, 1.7, 1.9], 4: [1362.1, 202.2, 27.9, 44.8, 2.1, 3.3],
              5: [8038.6, 9626.5, 6350.4, 1006.1, 134.1, 9.0]}
PAPER_TDSM = {1: [2455.4, 1657.7, 811.8, 488.0, 2254.3, 44.3], 2: [1036.9, 1111.5, 530.8, 174.2, 2332.1, 50.5],
              3: [2817.4, 1998.0, 524.9, 1338.8, 772.1, 1049.3], 4: [4890.9, 2200.1, 781.1, 2149.4, 1249.0, 1453.8],
              5: [10800.0, 10800.0, 10800.0, 10094.7, 5719.1, 31.6]}


def instance(classes: dict, cls: int, density: float, idx: int):
    """Instance ``idx`` of cell (cls, D): seeded by (SEED, cls, D index, idx), independent of the others."""
    return random_instance(**classes[cls], density=density, seed=[SEED, cls, DENSITIES.index(density), idx])


def run_one(classes: dict, cls: int, density: float, idx: int, limit: float) -> dict:
    """TCTM then TDSM on one instance (§IV-B), both checked; the record the JSON keeps."""
    inst = instance(classes, cls, density, idx)
    rec = {"class": cls, "density": density, "index": idx, "robots": len(inst.robots), "tasks": len(inst.tasks),
           "side": inst.arena[0][1], "violations": []}
    tctm = solve_tctm(inst, limit)
    tdsm = solve_tdsm(inst, completion_time(inst, tctm), limit) if tctm.solved else None
    for sched in (tctm, tdsm):
        if sched is None:
            continue
        r = {"status": sched.status, "seconds": sched.seconds, "objective": sched.objective,
             "dual_bound": sched.dual_bound, "gap": sched.gap, "nodes": sched.nodes}
        if sched.solved:
            d = sched.to_dict()
            rec["violations"] += [f"{sched.model}: {v}" for v in check_schedule(inst.to_dict(), d)]
            r |= {"completion_time": completion_time(inst, sched), "slots": len(used_slots(sched)),
                  "dislocation": dislocation(inst, sched), "arm_cost": arm_cost(inst, sched),
                  "arm_cost_tight": arm_cost(inst, sched, tight=True),
                  "arm_excess": euclidean_excess(inst.to_dict(), d)}
        rec[sched.model] = r
    return rec


def aggregate(records: list[dict], limit: float) -> dict:
    """Table II: per model, class and D the mean and median solve time, the share at the limit and its gaps."""
    out: dict = {}
    for model in ("tctm", "tdsm"):
        table = {}
        for cls in sorted({r["class"] for r in records}):
            row = {}
            for d in DENSITIES:
                rs = [r[model] for r in records if r["class"] == cls and r["density"] == d and model in r]
                if not rs:
                    continue
                secs = [min(r["seconds"], limit) for r in rs]
                hit = [r for r in rs if r["status"] != "optimal"]
                gaps = [r["gap"] for r in hit if r["gap"] is not None]
                row[str(d)] = {
                    "n": len(rs), "mean_s": round(statistics.fmean(secs), 2),
                    "median_s": round(statistics.median(secs), 2),
                    "max_s": round(max(secs), 2), "at_limit": len(hit),
                    "no_solution": sum(r["status"] == "no_solution" for r in rs),
                    "mean_gap_at_limit": round(statistics.fmean(gaps), 4) if gaps else None,
                    "mean_completion": _mean(r.get("completion_time") for r in rs),
                    "mean_dislocation": _mean(r.get("dislocation") for r in rs),
                    "mean_arm_cost": _mean(r.get("arm_cost") for r in rs),
                    "mean_arm_cost_tight": _mean(r.get("arm_cost_tight") for r in rs),
                }
            table[str(cls)] = row
        out[model] = table
    both = [r for r in records if r.get("tdsm", {}).get("dislocation") is not None]
    out["fig7_fig8"] = {
        "instances": len(both),
        "tdsm_dislocation_below_tctm": sum(r["tdsm"]["dislocation"] < r["tctm"]["dislocation"] - 1e-9 for r in both),
        "median_dislocation_ratio": _median(r["tdsm"]["dislocation"] / r["tctm"]["dislocation"]
                                            for r in both if r["tctm"]["dislocation"] > 1e-9),
        "tdsm_arm_cost_below_tctm": sum(r["tdsm"]["arm_cost"] < r["tctm"]["arm_cost"] - 1e-9 for r in both),
        "tdsm_arm_cost_below_tctm_tight": sum(r["tdsm"]["arm_cost"] < r["tctm"]["arm_cost_tight"] - 1e-9
                                              for r in both),
        "median_arm_ratio": _median(r["tdsm"]["arm_cost"] / r["tctm"]["arm_cost"]
                                    for r in both if r["tctm"]["arm_cost"]),
        "median_arm_ratio_tight": _median(r["tdsm"]["arm_cost"] / r["tctm"]["arm_cost_tight"]
                                          for r in both if r["tctm"]["arm_cost_tight"]),
    }
    out["checks"] = {"schedules_checked": sum((m in r and r[m].get("slots") is not None) for r in records
                                              for m in ("tctm", "tdsm")),
                     "violations": sum(len(r["violations"]) for r in records),
                     "max_arm_excess": max((r[m]["arm_excess"] for r in records for m in ("tctm", "tdsm")
                                            if r.get(m, {}).get("arm_excess") is not None), default=None)}
    return out


def _mean(values):
    vs = [v for v in values if v is not None]
    return round(statistics.fmean(vs), 3) if vs else None


def _median(values):
    vs = list(values)
    return round(statistics.median(vs), 4) if vs else None


def plot_times(agg: dict, path: Path, limit: float) -> None:
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.4))
    for ax, model in zip(axes[:2], ("tctm", "tdsm"), strict=True):
        for cls, row in agg[model].items():
            ds = [float(d) for d in row]
            line, = ax.plot(ds, [row[d]["mean_s"] for d in row], marker="o", label=f"class {cls}")
            paper = PAPER_TCTM if model == "tctm" else PAPER_TDSM
            ax.plot(DENSITIES, paper[int(cls)], ls=":", lw=0.9, color=line.get_color())
            for d in row:
                if row[d]["at_limit"]:
                    ax.annotate(f"{row[d]['at_limit']}/{row[d]['n']}", (float(d), row[d]["mean_s"]), fontsize=6,
                                xytext=(2, 4), textcoords="offset points", color=line.get_color())
        ax.axhline(limit, color="0.5", lw=0.8, ls="--")
        ax.set(xscale="log", yscale="log", xlabel="communication density D", ylabel="mean solve time (s)",
               title=f"{model.upper()}: ours (solid, HiGHS, limit {limit:g} s) vs paper (dotted, CPLEX)")
        ax.title.set_fontsize(9)
        ax.legend(fontsize=7)
    for cls, row in agg["tctm"].items():
        axes[2].plot([float(d) for d in row], [row[d]["mean_completion"] for d in row], marker="o",
                     label=f"class {cls}")
    axes[2].set(xscale="log", xlabel="communication density D", ylabel="mean Λ (TCTM)",
                title="total completion time falls as D grows")
    axes[2].title.set_fontsize(9)
    axes[2].legend(fontsize=7)
    fig.text(0.01, 0.01, "n/m beside a point: m instances of the cell, n of them hit the time limit", fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_pairs(records: list[dict], key: str, path: Path, title: str) -> None:
    """Figs. 7-8: TDSM against TCTM on the same instances, by D."""
    both = [r for r in records if r.get("tdsm", {}).get(key) is not None]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4))
    cmap = plt.get_cmap("viridis")
    for r in both:
        c = cmap(DENSITIES.index(r["density"]) / (len(DENSITIES) - 1))
        axes[0].scatter(r["tctm"][key], r["tdsm"][key], s=10, color=c)
    hi = max([max(r["tctm"][key], r["tdsm"][key]) for r in both] + [1.0])
    axes[0].plot([0, hi], [0, hi], color="0.5", lw=0.8, ls="--")
    axes[0].set(xlabel=f"TCTM {key.replace('_', ' ')}", ylabel=f"TDSM {key.replace('_', ' ')}", title=title)
    axes[0].title.set_fontsize(9)
    for i, d in enumerate(DENSITIES):
        axes[0].scatter([], [], color=cmap(i / (len(DENSITIES) - 1)), s=10, label=f"D = {d}")
    axes[0].legend(fontsize=7)
    groups = [[_ratio(r, key) for r in both if r["density"] == d and _ratio(r, key) is not None] for d in DENSITIES]
    keep = [(d, g) for d, g in zip(DENSITIES, groups, strict=True) if g]
    if keep:
        axes[1].boxplot([g for _, g in keep], tick_labels=[str(d) for d, _ in keep])
    axes[1].axhline(1.0, color="0.5", lw=0.8, ls="--")
    axes[1].set(xlabel="communication density D", ylabel="TDSM / TCTM",
                title="ratio per instance (below 1: TDSM better)")
    axes[1].title.set_fontsize(9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _ratio(r: dict, key: str):
    a, b = r["tctm"][key], r["tdsm"][key]
    return b / a if a > 1e-9 else None


def plot_example(classes: dict, cls: int, density: float, idx: int, limit: float, path: Path) -> dict:
    from protocols.tsc.schedule_plot import save_schedule_figure

    inst = instance(classes, cls, density, idx)
    tctm = solve_tctm(inst, limit)
    tdsm = solve_tdsm(inst, completion_time(inst, tctm), limit)
    save_schedule_figure(inst, tctm, tdsm if tdsm.solved else None, path)
    return {"class": cls, "density": density, "index": idx, "tctm": tctm.status, "tdsm": tdsm.status}


def sweep_trial(params: dict, *, seed: int, trial: int) -> dict:
    """One trial of ``protocols/tsc/experiments/tsc-table2.toml``: instance number ``trial`` of cell (class, density).

    The instance depends on (class, D, trial) only, as in ``main`` (the sweep's seed is not used), so the
    sweep and the script solve the same instances.
    """
    classes = QUICK if params.get("quick") else CLASSES
    return run_one(classes, int(params["class"]), float(params["density"]), trial, float(params["time_limit"]))


def sweep_figures(csv_path: Path, out_dir: Path) -> list[Path]:
    """The sweep's post step: Table II aggregates (``table2.json``) and the Table II / Figs. 7-8 plots."""
    identity = json.loads((Path(out_dir) / "sweep.json").read_text())
    limit = float(identity["params"]["time_limit"])
    records = sorted(returned_values(csv_path), key=lambda r: (r["class"], r["density"], r["index"]))
    agg = aggregate(records, limit)
    out = Path(out_dir)
    (out / "table2.json").write_text(json.dumps({"time_limit_s": limit, "instances": len(records),
                                                  "table2": agg}, indent=1))
    paths = [out / "tsc-times.png", out / "tsc-dislocation.png", out / "tsc-arms.png"]
    plot_times(agg, paths[0], limit)
    plot_pairs(records, "dislocation", paths[1], "Fig. 7: dislocation Σ|Θ^s − Θ^{s−1}|₁ (TDSM reduces it)")
    plot_pairs(records, "arm_cost", paths[2], "Fig. 8: arm cost Σ (Γ/Ω) w (no improvement)")
    return [out / "table2.json", *paths]


def replot(results: Path, out_dir: Path) -> list[Path]:
    """Table II as curves and Figs. 7-8 re-drawn from the saved ``tsc.json``.

    Fig. 6 (one schedule, solved again) is drawn only by a run.
    """
    data = json.loads(Path(results).read_text())
    out = Path(out_dir)
    paths = [out / "tsc-times.png", out / "tsc-dislocation.png", out / "tsc-arms.png"]
    plot_times(data["table2"], paths[0], float(data["time_limit_s"]))
    plot_pairs(data["instances"], "dislocation", paths[1], "Fig. 7: dislocation Σ|Θ^s − Θ^{s−1}|₁ (TDSM reduces it)")
    plot_pairs(data["instances"], "arm_cost", paths[2], "Fig. 8: arm cost Σ (Γ/Ω) w (no improvement)")
    return paths


def markdown_tables(data: dict) -> str:
    """Table II as docs/protocols/tsc.md prints it (ours · the paper's per cell), from a written ``--out`` JSON."""
    agg, limit, per_cell = data["table2"], data["time_limit_s"], data["per_cell"]
    paper = {"tctm": PAPER_TCTM, "tdsm": PAPER_TDSM}
    lines = []
    for model in ("tctm", "tdsm"):
        lines += [f"| {model.upper()} | " + " | ".join(f"D = {d}" if k == 0 else str(d)
                                                     for k, d in enumerate(DENSITIES)) + " |",
                  "|---|" + "---|" * len(DENSITIES)]
        for cls, row in sorted(agg[model].items(), key=lambda kv: int(kv[0])):
            cells = []
            for k, d in enumerate(DENSITIES):
                c = row.get(str(d))
                if c is None:
                    cells.append("–")
                    continue
                at = ""
                if c["at_limit"]:
                    gap = "" if c["mean_gap_at_limit"] is None else f", gap {c['mean_gap_at_limit']:.2f}"
                    at = f" ({c['at_limit']}/{c['n']} at limit{gap})"
                cells.append(f"{c['mean_s']:.1f}{at} · {paper[model][int(cls)][k]:,.1f}")
            lines.append(f"| {cls} | " + " | ".join(cells) + " |")
        lines.append("")
    f = agg["fig7_fig8"]
    hits = {m: sum(c["at_limit"] for row in agg[m].values() for c in row.values()) for m in ("tctm", "tdsm")}
    total = sum(c["n"] for row in agg["tctm"].values() for c in row.values())
    lines += [f"{total} instances ({per_cell} per cell), limit {limit:.0f} s: {hits['tctm']} TCTM and "
              f"{hits['tdsm']} TDSM solves at the limit; schedules checked {agg['checks']['schedules_checked']}, "
              f"violations {agg['checks']['violations']}.",
              f"Figs. 7-8 on {f['instances']} instances: TDSM dislocation below TCTM's on "
              f"{f['tdsm_dislocation_below_tctm']} (median ratio {f['median_dislocation_ratio']:.2f}); arm cost "
              f"below on {f['tdsm_arm_cost_below_tctm']} (median ratio {f['median_arm_ratio']:.2f}), below the "
              f"tight arms on {f['tdsm_arm_cost_below_tctm_tight']} (median {f['median_arm_ratio_tight']:.2f})."]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="8 robots, 4 tasks, D in {0.005, 0.5}, one instance a cell")
    ap.add_argument("--per-cell", type=int, default=PER_CELL, help=f"instances per (class, D) (default {PER_CELL})")
    ap.add_argument("--classes", default="1,2,3,4,5", help="comma-separated classes to run")
    ap.add_argument("--time-limit", type=float, default=60.0, help="seconds per solve (default 60)")
    ap.add_argument("--jobs", type=int, default=max(1, min(2, os.cpu_count() or 1)), help="worker processes")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "tsc.json")
    ap.add_argument("--img", type=Path, default=ROOT / "docs" / "img")
    ap.add_argument("--resume", action="store_true", help="skip instances already in OUT or OUT.partial.jsonl")
    ap.add_argument("--markdown", action="store_true", help="print Table II from OUT as docs/protocols/tsc.md has it")
    args = ap.parse_args(argv)
    if args.markdown:
        print(markdown_tables(json.loads(args.out.read_text())))
        return 0
    classes = QUICK if args.quick else CLASSES
    densities = (DENSITIES[0], DENSITIES[-1]) if args.quick else DENSITIES
    per_cell = 1 if args.quick else args.per_cell
    limit = min(args.time_limit, 10.0) if args.quick else args.time_limit
    wanted = [int(c) for c in args.classes.split(",")]
    cells = [(c, d, i) for i in range(per_cell) for d in densities for c in wanted]  # interleaved: fair partials
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.img.mkdir(parents=True, exist_ok=True)
    partial = args.out.with_suffix(".partial.jsonl")
    records = []
    if args.resume:  # what a finished run wrote, then what an interrupted one logged
        if args.out.exists():
            records = json.loads(args.out.read_text()).get("instances", [])
        if partial.exists():
            records += [json.loads(line) for line in partial.read_text().splitlines() if line.strip()]
        keep = {(c, d, i) for c, d, i in cells}
        records = list({(r["class"], r["density"], r["index"]): r for r in records
                        if (r["class"], r["density"], r["index"]) in keep}.values())
        done = {(r["class"], r["density"], r["index"]) for r in records}
        cells = [c for c in cells if c not in done]
    elif partial.exists():
        partial.unlink()
    t0, cpu = time.perf_counter(), 0.0
    with ProcessPoolExecutor(max_workers=args.jobs) as pool, partial.open("a") as log:
        futures = {pool.submit(run_one, classes, c, d, i, limit): (c, d, i) for c, d, i in cells}
        for k, fut in enumerate(as_completed(futures), 1):
            rec = fut.result()
            records.append(rec)
            log.write(json.dumps(rec) + "\n")
            log.flush()
            print(f"[{k}/{len(cells)}] class {rec['class']} D={rec['density']} #{rec['index']}: "
                  f"TCTM {rec['tctm']['status']} {rec['tctm']['seconds']:.1f}s"
                  + (f", TDSM {rec['tdsm']['status']} {rec['tdsm']['seconds']:.1f}s" if "tdsm" in rec else "")
                  + (f"  VIOLATIONS {rec['violations']}" if rec["violations"] else ""), flush=True)
    wall = time.perf_counter() - t0
    cpu = sum(r[m]["seconds"] for r in records for m in ("tctm", "tdsm") if m in r)
    records.sort(key=lambda r: (r["class"], r["density"], r["index"]))
    agg = aggregate(records, limit)
    example = plot_example(classes, 1, densities[len(densities) // 2], 0, limit, args.img / "tsc-schedule.png")
    plot_times(agg, args.img / "tsc-times.png", limit)
    plot_pairs(records, "dislocation", args.img / "tsc-dislocation.png",
               "Fig. 7: dislocation Σ|Θ^s − Θ^{s−1}|₁ (TDSM reduces it)")
    plot_pairs(records, "arm_cost", args.img / "tsc-arms.png", "Fig. 8: arm cost Σ (Γ/Ω) w (no improvement)")
    out = {
        "what": "seed 003 §IV-B / Table II: TCTM then TDSM (bounded by TCTM's Λ) on HiGHS via scipy.optimize.milp",
        "mode": "quick" if args.quick else "full",
        "classes": {str(c): classes[c] for c in wanted},
        "densities": list(densities), "per_cell": per_cell, "seed": SEED, "time_limit_s": limit,
        "jobs": args.jobs, "wall_s_this_invocation": round(wall, 1), "solver_s_total": round(cpu, 1),
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "scipy": scipy.__version__,
                    "load_avg_at_end": os.getloadavg()},
        "paper": {"tctm": PAPER_TCTM, "tdsm": PAPER_TDSM, "limit_s": 10800, "solver": "CPLEX 12.7, 8 threads"},
        "example_figure": example,
        "table2": agg,
        "instances": records,
    }
    args.out.write_text(json.dumps(out, indent=1))
    partial.unlink(missing_ok=True)  # everything is in the JSON now
    print(f"{len(records)} instances, solver time {cpu:.0f} s, wall {wall:.0f} s; violations "
          f"{agg['checks']['violations']}; wrote {args.out}")
    return 0 if not math.isnan(cpu) else 1


if __name__ == "__main__":
    sys.exit(main())
