"""Why our SECS arm differs from Table I of seed 003 (Panerati et al., ICRA 2018): Table I cells under variants.

Each variant is the SECS controller with opt-in parameters (all OFF by default, so the pinned traces are
unchanged): differential-drive kinematics with a turn rate (§IV-A's foot-bots), the alignment hysteresis
(§III-B-5b), an alignment strip of constant width, the walk back to the master of a robot that loses its
alignment (§III-B-5b "its control goes back"), and the Lennard-Jones scaling (ε, Eq. 2). Per run it records
the arm's reach along the task's ray, the latency to each Table I column, every robot's alignment losses,
how many robots are aligned at the end, and the core (backbone robots within the master's 3 m range).

    python -m protocols.secs.experiments.causes [--sizes 5,10] [--deltas 240] [--seeds 1,2] [--seconds 300]
        [--variants baseline,diffdrive,...] [--jobs 1] [--inprocess] [--out JSON]

Results: ``results/causes.json`` (rewritten after every run), the table docs/protocols/secs.md quotes.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from protocols.secs.experiments.table1 import COLUMNS, PAPER, TOL

VARIANTS: dict[str, dict] = {
    "baseline": {},
    "diffdrive": {"turn_rate": 2.0},  # foot-bot: 15 cm/s wheels 14 cm apart turn at most ≈ 2.1 rad/s
    "nohyst": {"align_release": 1.0},  # one threshold both ways (the Buzz code's rule)
    "hyst4": {"align_release": 4.0},  # lost only beyond 4 × 5°
    "strip": {"strip": 0.3},  # aligned also within 0.3 m of the informer's arm line
    "walkback": {"walk_back": True},
    "eps1e4": {"epsilon": 1e4},  # Lennard-Jones 100× weaker: not saturated within ≈ 40 cm of δ
    "walkback+diffdrive": {"walk_back": True, "turn_rate": 2.0},
    "hyst3": {"align_release": 3.0},
    "diffdrive+hyst3": {"turn_rate": 2.0, "align_release": 3.0},
    "diffdrive+hyst4": {"turn_rate": 2.0, "align_release": 4.0},
    "diffdrive+nohyst": {"turn_rate": 2.0, "align_release": 1.0},
}


def one(job: dict) -> dict:
    import swarmactors
    from protocols.secs import oracle
    from protocols.secs.scenarios import secs_scenario

    n, delta, seed, seconds = job["n"], job["delta"], job["seed"], job["seconds"]
    params = VARIANTS[job["variant"]]
    sc = secs_scenario(n, COLUMNS[delta][-1], delta=delta, seconds=seconds, seed=seed, name="secs-causes",
                       checks=[{"use": "secs.connected"}, {"use": "world.no_collisions"}], **params)
    t0 = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        if job.get("inprocess"):  # no Zenoh: the same trace hash (tests/unit/test_inprocess.py), faster
            from swarmactors.runs.inprocess import run_inprocess

            result = run_inprocess(sc, out=tmp)
        else:
            result = swarmactors.run(sc, out=tmp)
        checks = {c["name"]: c for c in result.checks}
        a = math.pi / 4
        u = np.array([math.cos(a), math.sin(a)])
        points = [d * u for d in COLUMNS[delta]]
        first: list[float | None] = [None] * len(points)
        core = []
        for rec in result.trace:
            ids, pos = oracle._pos(rec)
            back = pos[[k for k, i in enumerate(ids) if i != 0]]
            if len(back) == 0:
                continue
            for c, p in enumerate(points):
                if first[c] is None and np.min(np.linalg.norm(back - p, axis=1)) <= TOL:
                    first[c] = round(rec["t"] * 0.1, 1)
            last = back
        core = int(np.sum(np.linalg.norm(last, axis=1) <= 3.0))
        along = last @ u
        reports = result.reports("secs")
        losses = [int(r.get("lost_alignment", 0)) for i, r in sorted(reports.items()) if i != 0]
        job = {k: v for k, v in job.items() if k != "inprocess"}
        return {**job, "params": params, "wall_s": round(time.time() - t0, 1), "latency": first,
                "reach": round(max(oracle.max_reach(result).values()), 2),
                "reach_end": round(float(np.max(along)), 2),
                "core_end": core, "beyond_3m_end": len(last) - core,
                "aligned_end": sum(bool(r.get("aligned")) for i, r in reports.items() if i != 0),
                "losses": losses, "disconnected_ticks": checks["secs.connected"]["value"],
                "collisions": checks["world.no_collisions"]["value"]}


def summarise(rows: list[dict]) -> dict:
    """Per (variant, δ, N): mean latency per column, reach, losses, aligned at end, against the paper."""
    out: dict = {}
    for key in sorted({(r["variant"], r["delta"], r["n"]) for r in rows}):
        cell = [r for r in rows if (r["variant"], r["delta"], r["n"]) == key]
        v, delta, n = key
        paper_lat, paper_reach = PAPER.get(delta, {}).get(n, ([None] * len(COLUMNS[delta]), None))
        cols = []
        for c in range(len(COLUMNS[delta])):
            vals = [r["latency"][c] for r in cell if r["latency"][c] is not None]
            mean = round(statistics.mean(vals), 1) if vals else None
            p = paper_lat[c]
            ratio = round(mean / p, 2) if (mean is not None and p) else None
            cols.append({"mean": mean, "reached": f"{len(vals)}/{len(cell)}", "paper": p, "ratio": ratio,
                         "within_25pct": (ratio is not None and 0.75 <= ratio <= 1.25) if p else
                         (mean is None and len(vals) == 0)})
        reach = statistics.mean(r["reach"] for r in cell)
        losses = [x for r in cell for x in r["losses"]]
        out[f"{v}/{delta:g}/{n}"] = {
            "variant": v, "delta": delta, "n": n, "runs": len(cell), "seeds": sorted(r["seed"] for r in cell),
            "latency": cols, "reach_mean": round(reach, 2), "reach": [r["reach"] for r in cell],
            "paper_reach_below": paper_reach,
            "reach_ratio": round(reach / paper_reach, 2) if paper_reach else None,
            "losses_per_robot_min_max": [min(losses), max(losses)] if losses else None,
            "losses_per_robot_mean": round(statistics.mean(losses), 1) if losses else None,
            "aligned_end": [r["aligned_end"] for r in cell], "core_end": [r["core_end"] for r in cell],
            "disconnected_ticks": sum(r["disconnected_ticks"] for r in cell),
            "collisions": sum(r["collisions"] for r in cell)}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="5,10")
    ap.add_argument("--deltas", default="240")
    ap.add_argument("--seeds", default="1,2")
    ap.add_argument("--seconds", type=float, default=300.0)
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", default=str(Path(__file__).resolve().parent / "results" / "causes.json"))
    ap.add_argument("--inprocess", action="store_true",
                    help="step the simulation and the robots in this process, without Zenoh (same traces, faster)")
    ap.add_argument("--fresh", action="store_true", help="ignore the runs already in --out (default: keep them)")
    args = ap.parse_args()
    jobs = [{"variant": v, "delta": float(d), "n": int(n), "seed": int(s), "seconds": args.seconds,
             **({"inprocess": True} if args.inprocess else {})}
            for v in args.variants.split(",") for d in args.deltas.split(",") for n in args.sizes.split(",")
            for s in args.seeds.split(",")]
    rows: list[dict] = []
    if not args.fresh and Path(args.out).exists():  # the controller is deterministic per seed: a run done is done
        rows = [r for r in json.loads(Path(args.out).read_text())["rows"] if r["variant"] in VARIANTS]
        done = {(r["variant"], r["delta"], r["n"], r["seed"], r["seconds"]) for r in rows}
        jobs = [j for j in jobs if (j["variant"], j["delta"], j["n"], j["seed"], j["seconds"]) not in done]
    total = len(rows) + len(jobs)
    t0 = time.time()
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    with ProcessPoolExecutor(args.jobs) as pool:
        for row in pool.map(one, jobs):  # rewritten after every run: partial results survive
            rows.append(row)
            print(json.dumps({k: row[k] for k in ("variant", "delta", "n", "seed", "latency", "reach",
                                                 "aligned_end", "core_end", "losses", "wall_s")}), flush=True)
            Path(args.out).write_text(json.dumps(
                {"tol_m": TOL, "done": f"{len(rows)}/{total}", "wall_s": round(time.time() - t0, 1),
                 "table": summarise(rows), "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
