#!/usr/bin/env python
"""Fig. 2 of seed 003 (Sec. II-B) in the emulator: iterations until the λ2 estimate is within 1 %.

    python benchmarks/lambda2_fig2.py [--quick] [--jobs 2] [--img docs/img] \
        [--out docs/img/lambda2-fig2-data.json]
    python benchmarks/lambda2_fig2.py --large 50 100 --graphs 3 --jobs 2   # add K = 50, 100 to --out's runs

Every point is a real run (lockstep, c = 1 tick, range 1, one L2 frame per robot per tick, per-receiver
loss p): the three methods (PI1, PI2, Wave) on connected random geometric graphs
(``swarmactors.conformance.random_geometric``, about 4 neighbours for K = 10, 6 for K = 50 and 100), for
p in {0, 0.05, 0.1, 0.2, 0.3} and both drop semantics at K = 10, fewer graphs and the default semantics at
K = 50 and 100. Measured per run: the swarm's error e(k) (median over robots, the authors' metric) against
numpy's λ2 of the true Laplacian, the iteration from which e stays ≤ 1 % (None: not within the horizon),
the first iteration with e ≤ 1 %, the final e, and L2 frames and bytes per robot per iteration (from the
trace). Plots: docs/img/lambda2-fig2.png (iterations vs p) and docs/img/lambda2-error.png (median e(k)).
Nothing is asserted.

The K = 10 part as one sweep (``benchmarks/lambda2-fig2.toml``: a grid of method × p × drop semantics, one
trial per graph, each trial ``sweep_trial``; ``sweep_figures`` draws both plots from trials.csv), locally or
on a Dask cluster:

    swarmactors sweep benchmarks/lambda2-fig2.toml [--cluster tcp://SCHEDULER:8786] [--trials 4]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

PS = [0.0, 0.05, 0.1, 0.2, 0.3]
TICKS = {"pi1": 1000, "pi2": 3000, "wave": 1000}


def one(job: dict) -> dict:
    from protocols.lambda2 import oracle
    from protocols.lambda2.suite import lambda2_scenario
    from swarmactors.conformance import random_geometric
    from swarmactors.launcher import run

    k, seed, method, p, drop = job["K"], job["seed"], job["method"], job["p"], job["drop"]
    ticks = job["ticks"]
    pos = random_geometric(k, seed, degree=4.0 if k <= 10 else 6.0)
    sc = lambda2_scenario(pos, ticks + 12, method=method, loss=p, seed=seed, drop=drop,
                          name=f"l2-{method}-{k}-{seed}-{p}-{drop}", checks=[])
    t0 = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        res = run(sc, out=tmp)
        comps = oracle.components(res)
        robots, l2 = max(comps, key=lambda c: len(c[0]))
        reports = res.reports("lambda2")
        errors = oracle.error_series(reports, robots, l2)
        sizes = [row[4] for rec in res.trace for row in rec.get("sent", []) if row[2] == "L2"]
        iters = max(len(r["estimates"]) + 1 + 12 for r in reports.values())
    finite = [e if math.isfinite(e) else 1e9 for e in errors]
    return {**job, "lambda2": l2, "settled": oracle.settled(errors, 1.0), "first": oracle.first_within(errors, 1.0),
            "final_error": finite[-1] if finite else None,
            "curve": [round(finite[i], 4) for i in range(0, len(finite), 10)],
            "frames_per_robot_iter": len(sizes) / (k * iters), "bytes_per_robot_iter": sum(sizes) / (k * iters),
            "bytes_per_frame": sum(sizes) / max(len(sizes), 1), "wall_s": round(time.time() - t0, 2)}


def jobs(quick: bool) -> list[dict]:
    """Return the runs.

    ``quick`` (what docs/protocols/lambda2.md reports): 4 graphs at K = 10 with shorter horizons and one graph
    at K = 50 for p = 0 and 0.1; the full set: 8 graphs at K = 10, then K = 50 and 100.
    """
    out = []
    graphs10 = 4 if quick else 8
    ticks = {"pi1": 600, "pi2": 2000, "wave": 600} if quick else TICKS
    for method in ("pi1", "pi2", "wave"):
        for p in PS:
            for drop in ("drop", "reuse"):
                for seed in range(1, graphs10 + 1):
                    out.append({"K": 10, "seed": seed, "method": method, "p": p, "drop": drop,
                                "ticks": ticks[method]})
    big = ((50, 1, [0.0, 0.1]),) if quick else ((50, 2, [0.0, 0.1, 0.3]), (100, 1, [0.0, 0.1, 0.3]))
    for k, graphs, ps in big:
        for method in ("pi1", "pi2", "wave"):
            for p in ps:
                for seed in range(1, graphs + 1):
                    out.append({"K": k, "seed": seed, "method": method, "p": p, "drop": "drop",
                                "ticks": 2 * ticks[method] if method != "pi2" else ticks[method]})
    return out


def large_jobs(ks: list[int], graphs: int) -> list[dict]:
    """The runs of ``--large``: K = ``ks`` only, every p, ``graphs`` graphs each, the default drop semantics.

    Horizons: the full ones doubled for PI1 and the wave (their rate falls with K), PI2's as it is. Graph by
    graph (every K and p for graph 1, then graph 2, ...), so an interrupted run has whole curves of every K.
    """
    return [{"K": k, "seed": seed, "method": method, "p": p, "drop": "drop",
             "ticks": 2 * TICKS[method] if method != "pi2" else TICKS[method]}
            for seed in range(1, graphs + 1) for k in sorted(ks) for p in PS for method in ("pi1", "wave", "pi2")]


def summarise(rows: list[dict]) -> list[dict]:
    out = []
    keys = sorted({(r["K"], r["method"], r["drop"], r["p"]) for r in rows})
    for k, method, drop, p in keys:
        sel = [r for r in rows if (r["K"], r["method"], r["drop"], r["p"]) == (k, method, drop, p)]
        horizon = sel[0]["ticks"]
        its = [r["settled"] if r["settled"] is not None else math.inf for r in sel]
        conv = [i for i in its if math.isfinite(i)]
        out.append({"K": k, "method": method, "drop": drop, "p": p, "runs": len(sel), "horizon": horizon,
                    "converged": len(conv),
                    "median_iterations": float(np.median(its)) if len(conv) * 2 > len(its) else None,
                    "q25": float(np.percentile(its, 25)) if conv else None,
                    "q75": float(np.percentile(its, 75)) if len(conv) * 4 >= 3 * len(its) else None,
                    "median_final_error": float(np.median([r["final_error"] for r in sel])),
                    "frames_per_robot_iter": float(np.mean([r["frames_per_robot_iter"] for r in sel])),
                    "bytes_per_robot_iter": float(np.mean([r["bytes_per_robot_iter"] for r in sel]))})
    return out


def plot(rows: list[dict], summary: list[dict], img: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colours = {"pi1": "tab:blue", "pi2": "tab:red", "wave": "tab:green"}
    ks = sorted({s["K"] for s in summary})
    fig, axes = plt.subplots(1, len(ks) + 1, figsize=(5 * (len(ks) + 1), 4), squeeze=False)
    for ax, (k, drop) in zip(axes[0], [(10, "drop"), (10, "reuse")] + [(k, "drop") for k in ks if k != 10],
                             strict=False):
        for method, c in colours.items():
            sel = [s for s in summary if s["K"] == k and s["drop"] == drop and s["method"] == method]
            if not sel:
                continue
            horizon = sel[0]["horizon"]
            for s in sel:
                runs = [r for r in rows if (r["K"], r["method"], r["drop"], r["p"]) == (k, method, drop, s["p"])]
                ys = [r["settled"] if r["settled"] is not None else horizon * 1.15 for r in runs]
                ax.scatter([s["p"] + {"pi1": -0.006, "pi2": 0, "wave": 0.006}[method]] * len(ys), ys, s=8,
                           color=c, alpha=0.35)
            ax.plot([s["p"] for s in sel],
                    [s["median_iterations"] if s["median_iterations"] is not None else horizon * 1.15
                     for s in sel], "-o", color=c, label=f"{method.upper()} (horizon {horizon})")
        ax.set_yscale("log")
        ax.set_xlabel("packet drop p")
        ax.set_ylabel("iterations until e stays ≤ 1 %")
        ax.set_title(f"K = {k}, drop semantics: {drop}\n(points above the horizon: not converged)", fontsize=9)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(img / "lambda2-fig2.png", dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(8, 4.5))
    styles = {0.0: "-", 0.05: "--", 0.1: ":"}
    for method, c in colours.items():
        for p, ls in styles.items():
            curves = [r["curve"] for r in rows if (r["K"], r["method"], r["drop"], r["p"]) == (10, method, "drop", p)]
            if not curves:
                continue
            n = min(len(cv) for cv in curves)
            med = np.median(np.array([cv[:n] for cv in curves]), axis=0)
            ax.plot(np.arange(n) * 10 + 1, med, ls, color=c, label=f"{method.upper()} p={p}")
    ax.set_yscale("log")
    ax.set_ylim(1e-4, 1e4)
    ax.axhline(1.0, color="k", lw=0.6)
    ax.set_xlabel("iteration (tick)")
    ax.set_ylabel("e (%) of the median estimate, median over graphs")
    ax.set_title("K = 10, drop semantics 'drop' (the authors' makeAnoisy)", fontsize=9)
    ax.legend(fontsize=7, ncol=3)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(img / "lambda2-error.png", dpi=110)
    plt.close(fig)


def sweep_trial(params: dict, *, seed: int, trial: int) -> dict:
    """One trial of ``benchmarks/lambda2-fig2.toml``: graph number ``trial + 1`` (as ``jobs``), one method and p."""
    method = params["method"]
    ticks = params.get("ticks", {}).get(method, TICKS[method])
    return one({"K": int(params["K"]), "seed": trial + 1, "method": method, "p": float(params["p"]),
                "drop": params["drop"], "ticks": int(ticks)})


def sweep_figures(csv_path: Path, out_dir: Path) -> list[Path]:
    """The sweep's post step: the summary (``fig2.json``) and both plots, from trials.csv."""
    from swarmactors.sweep import returned_values

    rows = returned_values(csv_path)
    summary = summarise(rows)
    out = Path(out_dir)
    (out / "fig2.json").write_text(json.dumps({"summary": summary}, indent=1))
    plot(rows, summary, out)
    return [out / "fig2.json", out / "lambda2-fig2.png", out / "lambda2-error.png"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--img", type=Path, default=ROOT / "docs" / "img")
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "img" / "lambda2-fig2-data.json")
    ap.add_argument("--large", type=int, nargs="+", metavar="K",
                    help="run only these K (every p, --graphs graphs) and add them to the runs already in --out "
                         "(replacing that K's old runs); an interrupted run resumes from OUT.partial.jsonl")
    ap.add_argument("--graphs", type=int, default=3, help="graphs per point with --large")
    args = ap.parse_args()
    kept, done = [], []
    partial = args.out.with_suffix(".partial.jsonl")
    if args.large:
        todo = large_jobs(args.large, args.graphs)
        if args.out.exists():
            kept = [r for r in json.loads(args.out.read_text())["runs"] if r["K"] not in args.large]
        if partial.exists():
            done = [json.loads(line) for line in partial.read_text().splitlines() if line.strip()]
            key = lambda r: (r["K"], r["seed"], r["method"], r["p"], r["drop"], r["ticks"])  # noqa: E731
            have = {key(r) for r in done}
            todo = [j for j in todo if key(j) not in have]
    else:
        todo = jobs(args.quick)
    t0 = time.time()
    with ProcessPoolExecutor(args.jobs) as pool, open(partial, "a") as log:
        rows = list(done)
        for i, row in enumerate(pool.map(one, todo), 1):
            rows.append(row)
            log.write(json.dumps(row) + "\n")
            log.flush()
            print(f"{i}/{len(todo)} runs, {time.time() - t0:.0f} s: K={row['K']} {row['method']} p={row['p']} "
                  f"graph {row['seed']}: settled {row['settled']}, final e {row['final_error']}", flush=True)
    rows = kept + rows
    summary = summarise(rows)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"summary": summary, "runs": rows, "wall_s": round(time.time() - t0, 1)},
                                   indent=1))
    plot(rows, summary, args.img)
    partial.unlink(missing_ok=True)
    for s in summary:
        print(json.dumps({k: (round(v, 3) if isinstance(v, float) else v) for k, v in s.items()}))


if __name__ == "__main__":
    main()
