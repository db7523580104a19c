"""Fig. 2 of seed 003 (Sec. II-B) in the emulator: iterations until the λ2 estimate is within 1 %, per robot.

    python -m protocols.lambda2.experiments.fig2 [--jobs 2]              # K = 10: PI1, PI2, wave, every p
    python -m protocols.lambda2.experiments.fig2 --authors [--jobs 2]    # the paper's literal PI2 at K = 10
    python -m protocols.lambda2.experiments.fig2 --large 50 100 --graphs 1 [--methods pi2]
    python -m protocols.lambda2.experiments.fig2 --plot                  # the figures from the saved results

Each call adds its runs to ``--out`` (protocols/lambda2/experiments/results/fig2.json), replacing the runs of
the same (rule, K, method); the figures go to docs/img/lambda2-fig2.png and docs/img/lambda2-error.png.

Every point is a real run (lockstep, c = 1 tick, range 1, one L2 frame per robot per tick, per-receiver loss
p, drop semantics ``drop``, the authors' ``makeAnoisy``) on connected random geometric graphs
(``swarmactors.runs.conformance.random_geometric``, about 4 neighbours at K = 10, 6 at K = 50 and 100). Measured per
run against numpy's λ2 of the true Laplacian: every robot's final error, their worst, 90th percentile and
median (robots at a zero of the Fiedler vector named and left out, the rule of ``oracle.accurate``), the
iteration from which every judged robot stays within 1 % (None: not within the horizon), the same for the
median estimate (the authors' metric), and L2 frames and bytes per robot per iteration.

``--authors``: PI2 as the authors' code runs it, one power step per consensus (``power`` = 1) with their
constants (γ = 0.8/K, consensus weight 0.8/(K − 1)) and C = 150 consensus steps (their stopping test
max − min < 0.01 takes 66–436 steps, median about 145, on these graphs); and, beside the runs, the authors'
rule in matrix form (``authors_matrix``: the mean removed and the norm taken with global knowledge, as in
their Octave code) on the same graphs. Nothing is asserted.

The K = 10 part as one sweep (``fig2.toml``), locally or on a Dask cluster:

    swarmactors sweep protocols/lambda2/experiments/fig2.toml [--cluster tcp://SCHEDULER:8786] [--trials 4]
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
HERE = Path(__file__).resolve().parent
PS = [0.0, 0.05, 0.1, 0.2, 0.3]
TICKS = {"pi1": 1000, "pi2": 3000, "wave": 1000}
WARMUP = 12
AUTHORS_CONSENSUS = 150


def params_for(rule: str, k: int, power: int) -> dict:
    """The behaviour's PI2 parameters: ours (``power`` steps, constants from d_max) or the authors' literal rule."""
    if rule == "authors":
        return {"power": 1, "gamma": 0.8 / k, "eps": 0.8 / (k - 1), "consensus": AUTHORS_CONSENSUS}
    return {"power": power} if power != 20 else {}


def one(job: dict) -> dict:
    from protocols.lambda2 import oracle
    from protocols.lambda2.suite import lambda2_scenario
    from swarmactors.runs.conformance import random_geometric
    from swarmactors.runs.launcher import run

    k, seed, method, p, drop = job["K"], job["seed"], job["method"], job["p"], job["drop"]
    ticks, rule = job["ticks"], job.get("rule", "ours")
    extra = params_for(rule, k, job.get("power", 20)) if method == "pi2" else {}
    pos = random_geometric(k, seed, degree=4.0 if k <= 10 else 6.0)
    sc = lambda2_scenario(pos, ticks + WARMUP, method=method, loss=p, seed=seed, drop=drop,
                          name=f"l2-{rule}-{method}-{k}-{seed}-{p}-{drop}", checks=[], **extra)
    t0 = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        res = run(sc, out=tmp)
        rec, severed = res.last_state()
        g = res.graph_at(rec["t"], rec=rec, severed=severed)
        robots = sorted(max(oracle.nx.connected_components(g), key=len))
        l2, weight = oracle.fiedler_weights(g.subgraph(robots))
        reports = res.reports("lambda2")
        errors = oracle.error_series(reports, robots, l2)
        judged = [r for r in robots if weight[r] >= 0.1]
        per = oracle.robot_errors(reports, judged, l2)
        settle = oracle.per_robot_iterations({r: reports[r] for r in judged}, l2, 1.0)
        sizes = [row[4] for rec in res.trace for row in rec.get("sent", []) if row[2] == "L2"]
        iters = max(len(r["estimates"]) + 1 + WARMUP for r in reports.values())
    finite = [e if math.isfinite(e) else 1e9 for e in errors]
    dist = oracle.distribution([e if math.isfinite(e) else 1e9 for e in per.values()])
    every = None if any(v is None for v in settle.values()) else max(settle.values())
    return {**job, "rule": rule, "lambda2": l2, "settled": oracle.settled(errors, 1.0),
            "first": oracle.first_within(errors, 1.0), "final_error": finite[-1] if finite else None,
            "every_robot_settled": every, "robot_worst": dist["worst"], "robot_p90": dist["p90"],
            "robot_median": dist["median"], "robots_within": sum(e <= 1.0 for e in per.values()),
            "robots_judged": len(judged), "at_zero": [r for r in robots if weight[r] < 0.1],
            "curve": [round(finite[i], 4) for i in range(0, len(finite), 10)],
            "frames_per_robot_iter": len(sizes) / (k * iters), "bytes_per_robot_iter": sum(sizes) / (k * iters),
            "bytes_per_frame": sum(sizes) / max(len(sizes), 1), "wall_s": round(time.time() - t0, 2)}


def jobs(graphs0: int = 20, graphs: int = 5) -> list[dict]:
    """Return the K = 10 runs, drop semantics ``drop`` (the authors: 20 graphs per point).

    PI2 (ours) on ``graphs0`` graphs at p = 0, PI1 and the wave on half as many; every method on ``graphs``
    graphs at each p > 0.
    """
    out = []
    for p in PS:
        for method in ("pi2", "pi1", "wave"):
            n = (graphs0 if method == "pi2" else max(graphs0 // 2, graphs)) if p == 0 else graphs
            out += [{"K": 10, "seed": s, "method": method, "p": p, "drop": "drop", "ticks": TICKS[method]}
                    for s in range(1, n + 1)]
    return out


def authors_jobs(graphs0: int = 20, graphs: int = 5) -> list[dict]:
    """Return the runs of the literal PI2 at K = 10.

    ``graphs0`` graphs at p = 0 over 8001 iterations (the authors' horizon), ``graphs`` graphs at each p > 0
    over 3000.
    """
    return [{"K": 10, "seed": s, "method": "pi2", "p": p, "drop": "drop", "rule": "authors",
             "ticks": 8001 if p == 0 else TICKS["pi2"]}
            for p in PS for s in range(1, (graphs0 if p == 0 else graphs) + 1)]


def large_jobs(ks: list[int], graphs: int, methods: list[str], ps: list[float], power: int = 20,
               ticks: int | None = None) -> list[dict]:
    """K = ``ks``, ``graphs`` graphs each; horizons the K = 10 ones doubled for PI1 and the wave (or ``ticks``)."""
    return [{"K": k, "seed": seed, "method": method, "p": p, "drop": "drop",
             "ticks": ticks or (2 * TICKS[method] if method != "pi2" else TICKS[method]),
             **({"power": power} if method == "pi2" else {})}
            for seed in range(1, graphs + 1) for k in sorted(ks) for p in ps for method in methods]


def authors_matrix(k: int, seed: int, iterations: int = 8001) -> dict:
    """The authors' Di Lorenzo rule in matrix form (their Octave code's reading, global knowledge).

    x ← B·x with B = I − (0.8/K)L − 11ᵀ/K once per round, then average consensus with weights 0.8/(K − 1)
    until max − min < 0.01 (each step one iteration; a first consensus before the first round), then x/‖x‖;
    start (0, 1, …, K − 1)/K normalised. Returns each robot's error after ``iterations`` (estimate
    (Lx)_i/x_i), the worst/90th percentile/median over robots judged by the oracle's rule, and the
    median-of-robots error the authors plot.
    """
    from protocols.lambda2 import oracle
    from swarmactors.runs.conformance import random_geometric

    pos = np.array(random_geometric(k, seed, degree=4.0 if k <= 10 else 6.0))
    d = np.linalg.norm(pos[:, None] - pos[None], axis=2)
    a = ((d <= 1.0) & (d > 0)).astype(float)
    lap = np.diag(a.sum(1)) - a
    g = oracle.nx.from_numpy_array(a)
    l2, weight = oracle.fiedler_weights(g)
    b = np.eye(k) - 0.8 / k * lap - np.ones((k, k)) / k
    w = np.eye(k) - 0.8 / (k - 1) * lap
    x = np.arange(k) / k
    x = x / np.linalg.norm(x)
    it, cv, lengths = 0, x.copy(), []
    while it < iterations:
        it += 1
        cv = w @ cv
        if cv.max() - cv.min() < 0.01:
            break
    while it < iterations:
        it += 1
        x, c = b @ x, 0
        cv = x.copy()
        while it < iterations:
            it, c = it + 1, c + 1
            cv = w @ cv
            if cv.max() - cv.min() < 0.01:
                x = x / np.linalg.norm(x)
                lengths.append(c)
                break
    with np.errstate(all="ignore"):
        est = (lap @ x) / x
    errs = np.abs(est - l2) / (1e-2 * l2)
    judged = [i for i in range(k) if weight[i] >= 0.1]
    dist = oracle.distribution([float(errs[i]) if np.isfinite(errs[i]) else 1e9 for i in judged])
    return {"K": k, "seed": seed, "iterations": iterations, "lambda2": l2,
            "median_of_robot_errors": float(np.median(errs[np.isfinite(errs)])), **{f"robot_{q}": v for q, v in
            dist.items()}, "robots_within": int(sum(errs[i] <= 1.0 for i in judged)), "robots_judged": len(judged),
            "consensus_lengths_median": float(np.median(lengths)) if lengths else None}


def _power(r: dict) -> int:
    """PI2's power steps per round (1 for the authors' rule), 0 for the other methods."""
    if r["method"] != "pi2":
        return 0
    return 1 if r.get("rule", "ours") == "authors" else r.get("power", 20)


def _key(r: dict) -> tuple:
    return (r.get("rule", "ours"), r["K"], r["method"], _power(r), r["drop"], r["p"])


def _med(vals: list) -> float | None:
    vals = [v for v in vals if v is not None]
    return float(np.median(vals)) if vals else None


def summarise(rows: list[dict]) -> list[dict]:
    """Per (rule, K, method, drop semantics, p): the median-estimate metric and the per-robot one."""
    out = []
    for key in sorted({_key(r) for r in rows}):
        rule, k, method, power, drop, p = key
        sel = [r for r in rows if _key(r) == key]
        its = [r["settled"] if r["settled"] is not None else math.inf for r in sel]
        conv = [i for i in its if math.isfinite(i)]
        every = [r.get("every_robot_settled") for r in sel if "robot_worst" in r]
        every_conv = [i for i in every if i is not None]
        out.append({"rule": rule, "K": k, "method": method, "power": power, "drop": drop, "p": p, "runs": len(sel),
                    "horizon": max(r["ticks"] for r in sel), "converged": len(conv),
                    "median_iterations": float(np.median(its)) if len(conv) * 2 > len(its) else None,
                    "q25": float(np.percentile(its, 25, method="lower")) if conv else None,
                    "q75": float(np.percentile(its, 75, method="higher")) if len(conv) * 4 >= 3 * len(its) else None,
                    "median_final_error": _med([r["final_error"] for r in sel]),
                    "per_robot_runs": len(every),
                    "every_robot_converged": len(every_conv),
                    "every_robot_median_iterations": (float(np.median([i if i is not None else math.inf
                                                                       for i in every]))
                                                      if every and len(every_conv) * 2 > len(every) else None),
                    "robot_worst_median": _med([r.get("robot_worst") for r in sel]),
                    "robot_worst_max": max((r["robot_worst"] for r in sel if r.get("robot_worst") is not None),
                                           default=None),
                    "robot_p90_median": _med([r.get("robot_p90") for r in sel]),
                    "robot_median_median": _med([r.get("robot_median") for r in sel]),
                    "robots_within": sum(r.get("robots_within", 0) for r in sel),
                    "robots_judged": sum(r.get("robots_judged", 0) for r in sel),
                    "frames_per_robot_iter": float(np.mean([r["frames_per_robot_iter"] for r in sel])),
                    "bytes_per_robot_iter": float(np.mean([r["bytes_per_robot_iter"] for r in sel]))})
    return out


def plot(rows: list[dict], summary: list[dict], img: Path) -> None:
    """Draw lambda2-fig2.png and lambda2-error.png.

    lambda2-fig2.png: per K, iterations until every robot stays within 1 % against p (runs where some robot
    never does are drawn above the horizon); lambda2-error.png: the worst and the median robot's final error
    against p at K = 10.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    def style(rule: str, method: str, power: int) -> tuple[str, str, str]:
        if method == "pi2":
            if rule == "authors":
                return "tab:red", "--s", "PI2 literal, P = 1"
            return ("tab:red" if power == 20 else "tab:purple", "-o" if power == 20 else "-^",
                    f"PI2, P = {power} (ours)")
        return {"pi1": ("tab:blue", "-o", "PI1"), "wave": ("tab:green", "-o", "Wave")}[method]

    series = {(s["rule"], s["method"], s["power"]): style(s["rule"], s["method"], s["power"]) for s in summary}
    ks = sorted({s["K"] for s in summary if s["per_robot_runs"]})
    fig, axes = plt.subplots(1, len(ks), figsize=(5.5 * len(ks), 4.2), squeeze=False)
    for ax, k in zip(axes[0], ks, strict=True):
        top = 1
        for (rule, method, power), (c, line, label) in series.items():
            sel = [s for s in summary if (s["rule"], s["K"], s["method"], s["power"], s["drop"])
                   == (rule, k, method, power, "drop") and s["per_robot_runs"]]
            if not sel:
                continue
            horizon = max(s["horizon"] for s in sel)
            top = max(top, horizon)
            dx = {"pi1": -0.006, "pi2": 0.0, "wave": 0.006}[method] + (0.003 if rule == "authors" else 0.0)
            for s in sel:
                runs = [r for r in rows if _key(r) == (rule, k, method, power, "drop", s["p"]) and "robot_worst" in r]
                ys = [r["every_robot_settled"] or r["ticks"] * 1.15 for r in runs]
                ax.scatter([s["p"] + dx] * len(ys), ys, s=8, color=c, alpha=0.35)
            ax.plot([s["p"] + dx for s in sel],
                    [s["every_robot_median_iterations"] or s["horizon"] * 1.15 for s in sel], line, color=c,
                    label=f"{label} (horizon {horizon})")
        ax.set_yscale("log")
        ax.set_xlabel("packet drop p")
        ax.set_ylabel("iterations until every robot stays within 1 %")
        ax.set_title(f"K = {k} (points above the horizon: not every robot within 1 %)", fontsize=9)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(img / "lambda2-fig2.png", dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    for (rule, method, power), (c, line, label) in series.items():
        sel = [s for s in summary if (s["rule"], s["K"], s["method"], s["power"], s["drop"])
               == (rule, 10, method, power, "drop") and s["per_robot_runs"]]
        if not sel:
            continue
        ax.plot([s["p"] for s in sel], [max(s["robot_worst_median"], 1e-14) for s in sel], line, color=c,
                label=f"{label}: worst robot")
        ax.plot([s["p"] for s in sel], [max(s["robot_median_median"], 1e-14) for s in sel], line, color=c,
                alpha=0.4, label=f"{label}: median robot")
    ax.set_yscale("log")
    ax.axhline(1.0, color="k", lw=0.6)
    ax.set_xlabel("packet drop p")
    ax.set_ylabel("final per-robot e (%), median over graphs")
    ax.set_title("K = 10, drop semantics 'drop' (the authors' makeAnoisy), at the end of each horizon", fontsize=9)
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(img / "lambda2-error.png", dpi=110)
    plt.close(fig)


def _pct(e: float | None) -> str:
    if e is None:
        return "–"
    return f"{e:.2g}" if e < 1e-3 or e >= 1e4 else f"{e:.3g}"


def markdown(summary: list[dict]) -> str:
    """The summary as a markdown table (the docs' tables): one row per (rule, K, method, P), one column per p.

    A cell: runs where every judged robot stays within 1 % / runs, the median iteration from which they do
    (when more than half do), and the final per-robot e: worst robot (median over graphs) / median robot.
    """
    rows = sorted({(s["rule"], s["K"], s["method"], s["power"]) for s in summary if s["per_robot_runs"]},
                  key=lambda r: (r[1], r[2], r[0] != "ours", r[3]))
    ps = sorted({s["p"] for s in summary})
    out = ["| K | method (horizon) | " + " | ".join(f"p = {p:g}" for p in ps) + " |",
           "|---|---|" + "---|" * len(ps)]
    for rule, k, method, power in rows:
        cells, horizon = [], 0
        for p in ps:
            sel = [s for s in summary if (s["rule"], s["K"], s["method"], s["power"], s["p"])
                   == (rule, k, method, power, p) and s["per_robot_runs"]]
            if not sel:
                cells.append("")
                continue
            s = sel[0]
            horizon = max(horizon, s["horizon"])
            it = s["every_robot_median_iterations"]
            cells.append(f"{s['every_robot_converged']}/{s['per_robot_runs']}" + (f", from {it:g}" if it else "")
                         + f"; {_pct(s['robot_worst_median'])} / {_pct(s['robot_median_median'])}")
        name = {"pi1": "PI1", "wave": "Wave"}.get(method) or (
            "PI2 literal (P = 1)" if rule == "authors" else f"PI2, P = {power}")
        out.append(f"| {k} | {name} ({horizon}) | " + " | ".join(cells) + " |")
    return "\n".join(out)


def sweep_trial(params: dict, *, seed: int, trial: int) -> dict:
    """One trial of ``fig2.toml``: graph number ``trial + 1``, one method and p (PI2 ours, or ``rule``)."""
    method = params["method"]
    ticks = params.get("ticks", {}).get(method, TICKS[method])
    return one({"K": int(params["K"]), "seed": trial + 1, "method": method, "p": float(params["p"]),
                "drop": params["drop"], "ticks": int(ticks), "rule": params.get("rule", "ours")})


def sweep_figures(csv_path: Path, out_dir: Path) -> list[Path]:
    """The sweep's post step: the summary (``fig2.json``) and both plots, from trials.csv."""
    from swarmactors.tools.sweep import returned_values

    rows = returned_values(csv_path)
    summary = summarise(rows)
    out = Path(out_dir)
    (out / "fig2.json").write_text(json.dumps({"summary": summary}, indent=1))
    plot(rows, summary, out)
    return [out / "fig2.json", out / "lambda2-fig2.png", out / "lambda2-error.png"]


def replot(results: Path, out_dir: Path) -> list[Path]:
    """Re-draw both figures from a saved results file (the script's ``fig2.json``) into ``out_dir``."""
    rows = json.loads(Path(results).read_text())["runs"]
    plot(rows, summarise(rows), Path(out_dir))
    return [Path(out_dir) / "lambda2-fig2.png", Path(out_dir) / "lambda2-error.png"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--img", type=Path, default=ROOT / "docs" / "img")
    ap.add_argument("--out", type=Path, default=HERE / "results" / "fig2.json")
    ap.add_argument("--authors", action="store_true", help="the paper's literal PI2 (runs and matrix form)")
    ap.add_argument("--large", type=int, nargs="+", metavar="K", help="run these K instead of K = 10")
    ap.add_argument("--graphs", type=int, default=5, help="graphs per point at p > 0 (and with --large)")
    ap.add_argument("--graphs0", type=int, default=20, help="graphs per point at p = 0 (K = 10)")
    ap.add_argument("--methods", nargs="+", default=["pi1", "wave", "pi2"], help="with --large")
    ap.add_argument("--ps", type=float, nargs="+", default=PS, help="with --large")
    ap.add_argument("--power", type=int, default=20, help="PI2's power steps per round, with --large")
    ap.add_argument("--ticks", type=int, help="the horizon, with --large (default: per method)")
    ap.add_argument("--plot", action="store_true", help="only redraw the figures from --out")
    ap.add_argument("--table", action="store_true", help="only print the summary of --out as a markdown table")
    args = ap.parse_args()
    saved = json.loads(args.out.read_text()) if args.out.exists() else {"runs": []}
    rows, extra = saved["runs"], {k: v for k, v in saved.items() if k not in ("runs", "summary")}
    if args.table:
        print(markdown(summarise(rows)))
        return
    t0 = time.time()
    if not args.plot:
        if args.large:
            todo = large_jobs(args.large, args.graphs, args.methods, args.ps, args.power, args.ticks)
        elif args.authors:
            todo = authors_jobs(args.graphs0, args.graphs)
            extra["authors_matrix"] = [authors_matrix(10, s) for s in range(1, args.graphs0 + 1)]
        else:
            todo = jobs(args.graphs0, args.graphs)
        groups = {_key(j)[:4] for j in todo}
        rows = [r for r in rows if _key(r)[:4] not in groups]
        with ProcessPoolExecutor(args.jobs) as pool:
            for i, row in enumerate(pool.map(one, todo), 1):
                rows.append(row)
                print(f"{i}/{len(todo)} runs, {time.time() - t0:.0f} s: {row['rule']} K={row['K']} {row['method']} "
                      f"p={row['p']} graph {row['seed']}: every robot from {row['every_robot_settled']}, worst e "
                      f"{row['robot_worst']:.3g} %, median-estimate e {row['final_error']}", flush=True)
        extra.setdefault("wall_s", {})[" ".join(sorted(f"{r}/K{k}/{m}/P{pw}" for r, k, m, pw in groups))] = round(
            time.time() - t0, 1)
    summary = summarise(rows)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"summary": summary, **extra, "runs": rows}, indent=1))
    plot(rows, summary, args.img)
    for s in summary:
        print(json.dumps({k: (round(v, 4) if isinstance(v, float) else v) for k, v in s.items()}))
    for m in extra.get("authors_matrix", []) if args.authors else []:
        print(json.dumps({k: (round(v, 4) if isinstance(v, float) else v) for k, v in m.items()}))


if __name__ == "__main__":
    main()
