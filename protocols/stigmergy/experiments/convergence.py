#!/usr/bin/env python
"""Virtual stigmergy: convergence, cost and elections, measured in the emulator.

    python -m protocols.stigmergy.experiments.convergence [--quick] [--jobs 2] [--img docs/img] [--out JSON]

1. **Stigmergy convergence** (lockstep, c = 1 tick, range 1, uniform connected
   placements with 2.5 robots per unit area, about 7.9 neighbours each):
   N = 10 ... 200 robots, per-frame loss p = 0 ... 0.3, anti-entropy off and
   every 5 ticks. Ten scripted writes on five keys by random robots in ticks
   1-5 (so some are concurrent). Measured: whether every robot ends with the
   oracle's table (``stigmergy.consistent``), ticks from the last write to
   the last table change, VS frames and bytes per robot sent up to
   convergence, the anti-entropy's steady cost (digest frames and bytes per
   robot per tick), and without anti-entropy the fraction of robots left
   with a wrong table.
2. **Elections**: three exclusive lowest-bid elections (root and two
   workers) at N = 25, 50, 100; ticks from an election's opening to the last
   change of its key, VS frames per robot per election.

The plot goes to ``docs/img/stigmergy-convergence.png``; all numbers to the JSON file (by default
``results/convergence.json`` beside this module). Nothing is asserted. CBAA, which seed 002 runs beside the
stigmergy, has its own experiment in ``protocols/cbaa/experiments``.

Part 1 as a sweep (a trial = one run; the post step writes summary.json beside trials.csv), locally or on a
Dask cluster:

    swarmactors sweep protocols/stigmergy/experiments/convergence.toml [--cluster tcp://SCHEDULER:8786]
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

from protocols.stigmergy.oracle import oracle_tables  # noqa: E402
from swarmactors.runs.launcher import new_run_id, run_world  # noqa: E402
from swarmactors.runs.scenario import resolve_scenario  # noqa: E402
from transport import Endpoints  # noqa: E402

DENSITY = 2.5
VS_KINDS = ("VS_PUT", "VS_QUERY", "VS_DIGEST")


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


def _sent_by_tick(result, kinds) -> tuple[dict[int, int], dict[int, int], dict[str, int]]:
    frames, size, by_kind = {}, {}, {}
    for rec in result.trace:
        for _src, _seq, kind, _dst, nbytes in rec.get("sent", []):
            if kind in kinds:
                frames[rec["t"]] = frames.get(rec["t"], 0) + 1
                size[rec["t"]] = size.get(rec["t"], 0) + nbytes
                by_kind[kind] = by_kind.get(kind, 0) + 1
    return frames, size, by_kind


# ================================================================ 1. stigmergy convergence
def vs_case(n: int, loss: float, ae: int, seed: int, ticks: int = 150) -> dict:
    rng = np.random.default_rng([seed, n, 5])
    writes = []
    for _ in range(10):
        w = {"at": int(rng.integers(1, 6)), "robot": int(rng.integers(0, n)), "key": f"k{int(rng.integers(5))}"}
        w["value"] = int(rng.integers(0, 10_000))
        writes.append(w)
    side = math.sqrt(n / DENSITY)
    raw = {
        "run": {"name": f"vs{n}", "seed": seed, "ticks": ticks},
        "radio": {"range": 1.0, "latency": 1, "loss": loss},
        "world": {"bounds": [[0.0, 0.0], [side, side]]},
        "robots": [{"count": n, "placement": "uniform", "connected": True,
                    "behaviors": [{"use": "stigmergy", "anti_entropy": ae, "writes": writes}]}],
        "checks": [{"use": "stigmergy.consistent"}],
    }

    def measure(result) -> dict:
        reports = result.reports("stigmergy")
        oracle = oracle_tables(result)
        correct = sum(1 for r, rep in reports.items() if rep["table"] == oracle[r])
        last_write = max(w[0] for rep in reports.values() for w in rep["writes"])
        last_change = max(t for rep in reports.values() for t in rep["changed_at"].values())
        frames, size, by_kind = _sent_by_tick(result, VS_KINDS)
        converged = correct == n
        horizon = last_change if converged else ticks
        d_frames, d_bytes = 0, 0
        steady = range(ticks - 50, ticks)  # after convergence: the digests' cost
        for rec in result.trace:
            if rec["t"] in steady:
                for _s, _q, kind, _d, nbytes in rec.get("sent", []):
                    if kind == "VS_DIGEST":
                        d_frames += 1
                        d_bytes += nbytes
        diam = nx.diameter(result.graph_at(1))
        return {
            "n": n, "loss": loss, "anti_entropy": ae, "seed": seed, "diameter": diam,
            "converged": converged, "correct_fraction": correct / n,
            "ticks_to_converge": last_change - last_write if converged else None,
            "frames_per_robot": sum(v for t, v in frames.items() if t <= horizon) / n,
            "bytes_per_robot": sum(v for t, v in size.items() if t <= horizon) / n,
            "frames_by_kind": by_kind,
            "digest_frames_per_robot_tick": d_frames / (n * len(steady)),
            "digest_bytes_per_robot_tick": d_bytes / (n * len(steady)),
        }

    return _run(raw, measure)


# ================================================================ 2. elections
def election_case(n: int, seed: int) -> dict:
    side = math.sqrt(n / DENSITY)
    duration = 30
    raw = {
        "run": {"name": f"elect{n}", "seed": seed, "ticks": 2 + 3 * duration + 2},
        "radio": {"range": 1.0, "latency": 1},
        "world": {"bounds": [[0.0, 0.0], [side, side]]},
        "robots": [{"count": n, "placement": "uniform", "connected": True, "behaviors": [
            {"use": "election", "start": 2, "duration": duration, "elections": [
                {"key": "root", "target": [0.0, 0.0]}, {"key": "worker0", "target": [side, side]},
                {"key": "worker1", "target": [side, 0.0]}]}]}],
        "checks": [{"use": "stigmergy.election"}],
    }

    def measure(result) -> dict:
        reports = result.reports("election")
        frames, _size, _ = _sent_by_tick(result, VS_KINDS)
        settle, per_robot = {}, {}
        for i, key in enumerate(("root", "worker0", "worker1")):
            start = 2 + i * duration
            settle[key] = max(rep["agreed_at"][key] for rep in reports.values()) - start
            per_robot[key] = sum(v for t, v in frames.items() if start <= t < start + duration) / n
        return {"n": n, "seed": seed, "diameter": nx.diameter(result.graph_at(2)),
                "correct": result.check("stigmergy.election")["passed"],
                "ticks_to_agree": settle, "frames_per_robot": per_robot}

    return _run(raw, measure)


# ================================================================ driver
def _pool_map(fn, cases, jobs):
    if jobs <= 1:
        return [fn(*c) for c in cases]
    with ProcessPoolExecutor(jobs) as ex:
        return list(ex.map(fn, *zip(*cases, strict=True)))


def stigmergy_experiment(quick: bool, jobs: int) -> list[dict]:
    sizes = [10, 25, 50] if quick else [10, 25, 50, 100, 200]
    losses = [0.0, 0.3] if quick else [0.0, 0.1, 0.2, 0.3]
    seeds = [1] if quick else [1, 2, 3]
    cases = [(n, p, ae, s) for n in sizes for p in losses for ae in (0, 5) for s in seeds]
    return _pool_map(vs_case, cases, jobs)


def election_experiment(quick: bool, jobs: int) -> list[dict]:
    cases = [(n, s) for n in ([25] if quick else [25, 50, 100]) for s in ([1] if quick else [1, 2, 3])]
    return _pool_map(election_case, cases, jobs)


def stigmergy_trial(params: dict, *, seed: int, trial: int) -> dict:
    """One run of ``convergence.toml`` (beside this module): (N, loss, anti-entropy period), seed ``trial + 1``."""
    return vs_case(int(params["n"]), float(params["loss"]), int(params["anti_entropy"]), trial + 1)


def sweep_summary(csv_path: Path, out_dir: Path) -> list[Path]:
    """The post step of the sweep: the summary of ``summarise`` for the CSV's runs, as ``summary.json``."""
    from swarmactors.tools.sweep import returned_values

    vs = [r for r in returned_values(csv_path) if "anti_entropy" in r]
    data = {"stigmergy": summarise(vs, [])["stigmergy"]["summary"]}
    path = Path(out_dir) / "summary.json"
    path.write_text(json.dumps(data, indent=1, default=str))
    return [path]


def summarise(vs: list[dict], el: list[dict]) -> dict:
    out: dict = {"stigmergy": {}, "election": {}}
    for r in vs:
        key = f"N={r['n']} p={r['loss']} ae={r['anti_entropy']}"
        out["stigmergy"].setdefault(key, []).append(r)
    table = {}
    for key, rows in out["stigmergy"].items():
        conv = [r["ticks_to_converge"] for r in rows if r["converged"]]
        table[key] = {
            "converged_runs": f"{len(conv)}/{len(rows)}",
            "ticks_to_converge_mean": float(np.mean(conv)) if conv else None,
            "diameter_mean": float(np.mean([r["diameter"] for r in rows])),
            "frames_per_robot_mean": float(np.mean([r["frames_per_robot"] for r in rows])),
            "bytes_per_robot_mean": float(np.mean([r["bytes_per_robot"] for r in rows])),
            "correct_fraction_mean": float(np.mean([r["correct_fraction"] for r in rows])),
            "digest_frames_per_robot_tick": float(np.mean([r["digest_frames_per_robot_tick"] for r in rows])),
            "digest_bytes_per_robot_tick": float(np.mean([r["digest_bytes_per_robot_tick"] for r in rows])),
        }
    out["stigmergy"] = {"summary": table, "runs": vs}
    out["election"] = {"runs": el}
    return out


def plots(data: dict, img: Path) -> list[Path]:
    img.mkdir(parents=True, exist_ok=True)
    paths = []
    runs = data["stigmergy"]["runs"]
    sizes = sorted({r["n"] for r in runs})
    losses = sorted({r["loss"] for r in runs})
    colors = plt.cm.viridis(np.linspace(0, 0.9, len(losses)))

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.4), dpi=110)
    for p, col in zip(losses, colors, strict=True):
        for ae, style in ((5, "-o"), (0, "--s")):
            xs, ys, fs, cf = [], [], [], []
            for n in sizes:
                rows = [r for r in runs if r["n"] == n and r["loss"] == p and r["anti_entropy"] == ae]
                conv = [r["ticks_to_converge"] for r in rows if r["converged"]]
                xs.append(n)
                ys.append(np.mean(conv) if len(conv) == len(rows) else np.nan)
                fs.append(np.mean([r["frames_per_robot"] for r in rows]))
                cf.append(np.mean([r["correct_fraction"] for r in rows]))
            label = f"p={p} {'AE 5' if ae else 'no AE'}"
            axes[0].plot(xs, ys, style, color=col, label=label, ms=4)
            axes[1].plot(xs, fs, style, color=col, label=label, ms=4)
            if ae == 0:
                axes[2].plot(xs, cf, style, color=col, label=f"p={p}, no AE", ms=4)
    axes[0].set(xscale="log", xlabel="robots N", ylabel="ticks from last write to convergence",
                title="Convergence (missing point: some run never converged)")
    axes[1].set(xscale="log", xlabel="robots N", ylabel="VS frames sent per robot (until convergence)",
                title="Messages per robot")
    axes[2].set(xscale="log", xlabel="robots N", ylabel="fraction of robots with the oracle's table",
                title="Without anti-entropy, after 150 ticks", ylim=(0, 1.05))
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=7, ncol=2)
    axes[2].legend(fontsize=7)
    fig.tight_layout()
    paths.append(img / "stigmergy-convergence.png")
    fig.savefig(paths[-1])
    plt.close(fig)

    return paths


def replot(results: Path, out_dir: Path) -> list[Path]:
    """The figure re-drawn from the saved ``convergence.json``."""
    return plots(json.loads(Path(results).read_text()), Path(out_dir))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="a few cases only (a smoke test of the script)")
    ap.add_argument("--jobs", type=int, default=2, help="parallel lockstep runs (processes)")
    ap.add_argument("--img", type=Path, default=ROOT / "docs" / "img")
    ap.add_argument("--out", type=Path, default=HERE / "results" / "convergence.json")
    args = ap.parse_args()
    t0 = time.perf_counter()
    vs = stigmergy_experiment(args.quick, args.jobs)
    el = election_experiment(args.quick, args.jobs)
    data = summarise(vs, el)
    data["wall_s"] = round(time.perf_counter() - t0, 1)
    paths = plots(data, args.img)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(data, indent=1, default=float))
    for key, row in data["stigmergy"]["summary"].items():
        print(f"{key:24s} {row}")
    for r in el:
        print("election", r)
    print("plots:", ", ".join(map(str, paths)), "| numbers:", args.out, f"| {data['wall_s']} s")


if __name__ == "__main__":
    main()
