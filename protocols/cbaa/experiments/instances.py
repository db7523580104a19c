#!/usr/bin/env python
"""CBAA (seed 002's recruiting): rounds, equality with greedy and quality, measured in the emulator.

    python -m protocols.cbaa.experiments.instances [--quick] [--jobs 2] [--img docs/img] [--out JSON]

Lockstep, max consensus, no loss: random instances with N = 2 ... 60 robots, M = 1 ... 2N tasks, three
densities and lines (to spread the diameter D); rounds to the last change against N_min * D, equality with
the sequential greedy assignment, and the total score against the optimum (scipy linear_sum_assignment).
Plus realtime runs (table consensus, jitter, loss 0.1): time to settle and equality with greedy.

The plot goes to ``docs/img/cbaa-rounds-and-ratio.png``; all numbers to the JSON file (by default
``results/instances.json`` beside this module). Nothing is asserted.

The lockstep instances as a sweep (a trial = one instance; the post step writes summary.json beside
trials.csv), locally or on a Dask cluster:

    swarmactors sweep protocols/cbaa/experiments/instances.toml [--cluster tcp://SCHEDULER:8786] [--trials 30]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import networkx as nx  # noqa: E402
import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]  # the checkout: docs/img

from protocols.cbaa.oracle import optimum, sequential_greedy  # noqa: E402
from swarmactors.runs.launcher import new_run_id, run_world  # noqa: E402
from swarmactors.runs.scenario import resolve_scenario  # noqa: E402
from transport import Endpoints  # noqa: E402

DENSITY = 2.5  # robots per unit area of the "medium" layout (the stigmergy experiments' density)


def _run(raw: dict, measure):
    """Run a scenario dict in a temporary directory and return ``measure(result)``."""
    sc = resolve_scenario(raw, "<experiment>")
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        result = asyncio.run(run_world(sc, Path(tmp), Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]),
                                       new_run_id(raw["run"]["name"])))
        out = measure(result)
        out["wall_s"] = round(time.perf_counter() - t0, 3)
        return out


def cbaa_case(n: int, m: int, layout: str, seed: int, clock: str = "lockstep", loss: float = 0.0) -> dict:
    rng = np.random.default_rng([seed, n, m, 9])
    if layout == "line":
        positions = [[0.9 * i, 0.0] for i in range(n)]
        lo, hi = np.array([0.0, -1.0]), np.array([0.9 * max(n - 1, 1), 1.0])
    else:
        density = {"sparse": 1.6, "medium": DENSITY, "dense": 6.0}[layout]
        side = math.sqrt(n / density)
        positions = None
        lo, hi = np.zeros(2), np.array([side, side])
    tasks = np.round(lo + rng.random((m, 2)) * (hi - lo), 4).tolist()
    group = {"behaviors": [{"use": "cbaa", "tasks": tasks, "at": 1}]}
    if positions is None:
        group.update(count=n, placement="uniform", connected=True, area=[lo.tolist(), hi.tolist()])
    else:
        group["positions"] = positions
    raw = {
        "run": {"name": f"cbaa{n}x{m}", "seed": seed, "ticks": 120 if clock == "lockstep" else 60, "clock": clock,
                "dt": 1.0 if clock == "lockstep" else 0.05},
        "radio": {"range": 1.0, "latency": 1, "loss": loss, "latency_s": 0.03, "latency_min_s": 0.002},
        "robots": [group],
        "checks": [{"use": "cbaa.greedy"}, {"use": "cbaa.conflict_free"}, {"use": "cbaa.optimality"}],
    }

    def measure(result) -> dict:
        reports = result.reports("cbaa")
        g = result.graph_at(1)
        d = nx.diameter(g)
        last = max(rep["changed_at"] for rep in reports.values())
        scores = {r: rep["scores"] for r, rep in reports.items()}
        greedy = sequential_greedy(scores)
        total = sum(scores[r][rep["task"]] for r, rep in reports.items() if rep["task"] is not None)
        best = optimum(scores, sorted(scores))
        return {
            "n": n, "m": m, "layout": layout, "seed": seed, "clock": clock, "loss": loss, "diameter": d,
            "n_min": min(n, m), "bound": min(n, m) * d, "rounds": last - 1,
            "settle_s": max(rep["changed_time"] for rep in reports.values()),
            "equals_greedy": result.check("cbaa.greedy")["passed"],
            "conflict_free": result.check("cbaa.conflict_free")["passed"],
            "greedy_total": sum(scores[r][j] for j, r in greedy.items()),
            "ratio": total / best if best > 0 else 1.0,
        }

    return _run(raw, measure)


def _pool_map(fn, cases, jobs):
    if jobs <= 1:
        return [fn(*c) for c in cases]
    with ProcessPoolExecutor(jobs) as ex:
        return list(ex.map(fn, *zip(*cases, strict=True)))


def cbaa_experiment(quick: bool, jobs: int) -> tuple[list[dict], list[dict]]:
    lock = _pool_map(cbaa_case, cbaa_instances(30 if quick else 160), jobs)
    sizes = [5, 10, 20, 30, 40, 15][: 2 if quick else 6]
    rt_cases = [(20, m, "medium", s, "realtime", 0.1) for s, m in enumerate(sizes)]
    rt = _pool_map(cbaa_case, rt_cases, 1)  # realtime runs are timed: never two at once
    return lock, rt


def cbaa_instances(count: int) -> list[tuple]:
    """The random CBAA instances (N, M, layout, k): the sweep's and ``cbaa_experiment``'s list."""
    rng = np.random.default_rng(2024)
    cases = []
    for k in range(count):
        layout = ["sparse", "medium", "dense", "line"][k % 4]
        n = int(rng.integers(2, 25 if layout == "line" else 61))
        m = int(rng.integers(1, 2 * n + 1))
        cases.append((n, m, layout, k))
    return cases


def cbaa_trial(params: dict, *, seed: int, trial: int) -> dict:
    """Instance ``trial`` of ``instances.toml`` (beside this module), lockstep, no loss."""
    return cbaa_case(*cbaa_instances(trial + 1)[trial])


def sweep_summary(csv_path: Path, out_dir: Path) -> list[Path]:
    """The post step of the sweep: ``summarise`` of the CSV's instances, without the per-run rows (summary.json)."""
    from swarmactors.tools.sweep import returned_values

    whole = summarise(returned_values(csv_path), [])
    path = Path(out_dir) / "summary.json"
    path.write_text(json.dumps({"cbaa": {k: v for k, v in whole.items() if not k.endswith("runs")}}, indent=1,
                               default=str))
    return [path]


def summarise(cb: list[dict], rt: list[dict]) -> dict:
    """The lockstep instances' tallies and the realtime runs (the JSON's ``cbaa`` table)."""
    lock_ok = [r for r in cb if r["equals_greedy"] and r["conflict_free"]]
    return {} if not cb else {
        "instances": len(cb),
        "equal_greedy": len(lock_ok),
        "within_nmin_d": sum(1 for r in cb if r["rounds"] <= r["bound"]),
        "rounds_over_bound_max": max((r["rounds"] / r["bound"] for r in cb if r["bound"] > 0), default=None),
        "rounds_minus_diameter_max": max(r["rounds"] - r["diameter"] for r in cb),
        "ratio_min": min(r["ratio"] for r in cb),
        "ratio_mean": float(np.mean([r["ratio"] for r in cb])),
        "realtime_equal_greedy": f"{sum(1 for r in rt if r['equals_greedy'])}/{len(rt)}",
        "realtime_settle_s": [round(r["settle_s"], 3) for r in rt],
        "runs": cb, "realtime_runs": rt,
    }


def plots(data: dict, img: Path) -> list[Path]:
    img.mkdir(parents=True, exist_ok=True)
    paths = []
    cb = data["cbaa"]["runs"]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.4), dpi=110)
    marks = {"sparse": "o", "medium": "s", "dense": "^", "line": "x"}
    for layout, mk in marks.items():
        rows = [r for r in cb if r["layout"] == layout]
        axes[0].scatter([r["bound"] for r in rows], [r["rounds"] for r in rows], marker=mk, s=18, label=layout)
        axes[1].scatter([r["diameter"] for r in rows], [r["rounds"] for r in rows], marker=mk, s=18, label=layout)
    top = max(r["bound"] for r in cb)
    axes[0].plot([1, top], [1, top], "k--", lw=1, label="rounds = N_min·D")
    axes[0].set(xscale="log", yscale="log", xlabel="N_min · D", ylabel="rounds to the last change",
                title="CBAA rounds vs the N_min·D bound")
    dmax = max(r["diameter"] for r in cb)
    axes[1].plot([0, dmax], [0, dmax], "k:", lw=1, label="rounds = D")
    axes[1].set(xlabel="network diameter D", ylabel="rounds to the last change", title="Rounds vs diameter")
    ratios = [r["ratio"] for r in cb]
    for layout, mk in marks.items():
        rows = [r for r in cb if r["layout"] == layout]
        axes[2].scatter([r["n"] for r in rows], [r["ratio"] for r in rows], marker=mk, s=18, label=layout)
    axes[2].axhline(0.5, color="k", ls="--", lw=1, label="guarantee 1/2")
    axes[2].set(xlabel="robots N", ylabel="CBAA total score / optimum", ylim=(0.45, 1.02),
                title=f"Score ratio, {len(cb)} instances (min {min(ratios):.3f}, mean {np.mean(ratios):.3f})")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    paths.append(img / "cbaa-rounds-and-ratio.png")
    fig.savefig(paths[-1])
    plt.close(fig)
    return paths


def replot(results: Path, out_dir: Path) -> list[Path]:
    """The figure re-drawn from the saved ``instances.json``."""
    return plots(json.loads(Path(results).read_text()), Path(out_dir))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="a few cases only (a smoke test of the script)")
    ap.add_argument("--jobs", type=int, default=2, help="parallel lockstep runs (processes)")
    ap.add_argument("--img", type=Path, default=ROOT / "docs" / "img")
    ap.add_argument("--out", type=Path, default=HERE / "results" / "instances.json")
    args = ap.parse_args()
    t0 = time.perf_counter()
    cb, rt = cbaa_experiment(args.quick, args.jobs)
    data = {"cbaa": summarise(cb, rt), "wall_s": round(time.perf_counter() - t0, 1)}
    paths = plots(data, args.img)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(data, indent=1, default=float))
    c = {k: v for k, v in data["cbaa"].items() if k not in ("runs", "realtime_runs")}
    print("cbaa", c)
    print("plots:", ", ".join(map(str, paths)), "| numbers:", args.out, f"| {data['wall_s']} s")


if __name__ == "__main__":
    main()
