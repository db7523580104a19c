"""Table I and Fig. 5 of seed 003 (Panerati et al., ICRA 2018) with the SECS navigation controller.

Table I: one task in one direction; a prominence's latency to come within ``TOL`` m of points at the
paper's distances on that ray (2√2, 3√2, 10√2 m for δ = 120; 3√2, 5√2, 10√2, 15√2 m for δ = 240), its
maximum reach, and the link redundancy: the mean over the backbone robots of the number of node-disjoint
paths to the master in the true radio graph at the end. With one task the controller does not depend on the
task's distance (every robot joins the one arm and its direction is the same), so one run per (δ, N, seed)
measures every column: the task is placed at the farthest distance and the nearer points are read off the
same trace. Fig. 5: N = 16, three tasks 120° apart at ``FIG5_DISTANCE`` m, time until all three are reached.

    python -m protocols.secs.experiments.table1 [--reps 2] [--seconds 400] [--jobs 2] [--out JSON]

The same runs as sweeps (one trial a repetition; the post step writes table1.json beside trials.csv), locally
or on a Dask cluster:

    swarmactors sweep protocols/secs/experiments/table1.toml [--cluster tcp://SCHEDULER:8786] [--trials 5]
    swarmactors sweep protocols/secs/experiments/fig5.toml [--cluster ...]
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

TOL = 0.5
COLUMNS = {120.0: [2 * math.sqrt(2), 3 * math.sqrt(2), 10 * math.sqrt(2)],
           240.0: [3 * math.sqrt(2), 5 * math.sqrt(2), 10 * math.sqrt(2), 15 * math.sqrt(2)]}
# δ = 90 and 275 (§IV-A, Fig. 4) have no Table I row in the paper: read at the columns of the nearest δ
COLUMNS[90.0], COLUMNS[275.0] = COLUMNS[120.0], COLUMNS[240.0]
SIZES = (3, 5, 10, 15, 20)  # Table I's; the sweep files add N = 25
FIG5_DISTANCE = 5.0
PAPER = {  # Table I: latency (s) per column, None for n/a; and the bracketed maximum reach (m)
    120.0: {3: ([None, None, None], 1.89), 5: ([81.1, None, None], 3.39), 10: ([36.3, 69.8, None], 7.31),
            15: ([37.9, 56.4, None], 12.02), 20: ([50.9, 63.2, 345.0], 18.38)},
    240.0: {3: ([69.8, None, None, None], 4.95), 5: ([63.7, 195.1, None, None], 7.78),
            10: ([57.6, 100.1, None, None], 11.31), 15: ([41.9, 74.2, 327.4, 449.8], None),
            20: ([43.3, 86.1, 237.2, 322.6], None)},
}


def redundancy(graph, master: int) -> float:
    """Mean over the other robots of the number of node-disjoint paths to the master."""
    import networkx as nx

    vals = []
    for r in graph.nodes:
        if r == master:
            continue
        if not nx.has_path(graph, r, master):
            vals.append(0)
            continue
        g = graph.copy()
        direct = g.has_edge(r, master)
        if direct:
            g.remove_edge(r, master)
        k = nx.node_connectivity(g, r, master) if nx.has_path(g, r, master) else 0
        vals.append(k + direct)
    return float(np.mean(vals)) if vals else 0.0


def one(job: dict) -> dict:
    import swarmactors
    from protocols.secs import oracle
    from protocols.secs.scenarios import secs_scenario

    n, delta, seed, seconds, tasks = job["n"], job["delta"], job["seed"], job["seconds"], job["tasks"]
    distance = job["distance"]
    sc = secs_scenario(n, distance, tasks=tasks, delta=delta, seconds=seconds, seed=seed, name="secs-bench",
                       checks=[{"use": "secs.connected"}, {"use": "world.no_collisions"}])
    t0 = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        result = swarmactors.run(sc, out=tmp)
        checks = {c["name"]: c for c in result.checks}
        dt = 0.1
        out = {**job, "wall_s": round(time.time() - t0, 1),
               "connected_ticks_lost": checks["secs.connected"]["value"],
               "collisions": checks["world.no_collisions"]["value"]}
        if tasks == 1:
            a = math.pi / 4
            points = [np.array([d * math.cos(a), d * math.sin(a)]) for d in COLUMNS[delta]]
            first: list[float | None] = [None] * len(points)
            for rec in result.trace:
                ids, pos = oracle._pos(rec)
                back = pos[[k for k, i in enumerate(ids) if i != 0]]
                for c, p in enumerate(points):
                    if first[c] is None and np.min(np.linalg.norm(back - p, axis=1)) <= TOL:
                        first[c] = round(rec["t"] * dt, 1)
            out["latency"] = first
            out["reach"] = round(max(oracle.max_reach(result).values()), 2)
        else:
            times = oracle.reach_times(result, TOL)
            out["reached"] = times
            out["full_deployment"] = (max(times.values()) if all(v is not None for v in times.values()) else None)
        out["redundancy"] = round(redundancy(result.final_graph(), 0), 2)
    return out


def summarise(rows: list[dict]) -> dict:
    table: dict = {}
    for delta in COLUMNS:
        for n in sorted({r["n"] for r in rows}):
            cell = [r for r in rows if r["tasks"] == 1 and r["delta"] == delta and r["n"] == n]
            if not cell:
                continue
            cols = []
            for c in range(len(COLUMNS[delta])):
                vals = [r["latency"][c] for r in cell if r["latency"][c] is not None]
                cols.append({"mean": round(statistics.mean(vals), 1) if vals else None,
                             "sd": round(statistics.stdev(vals), 1) if len(vals) > 1 else None,
                             "reached": f"{len(vals)}/{len(cell)}"})
            reach = [r["reach"] for r in cell]
            table[f"{delta:g}/{n}"] = {
                "latency": cols, "reach_mean": round(statistics.mean(reach), 2),
                "reach_min": min(reach), "reach_max": max(reach),
                "redundancy": round(statistics.mean(r["redundancy"] for r in cell), 2),
                "disconnected_ticks": sum(r["connected_ticks_lost"] for r in cell),
                "collisions": sum(r["collisions"] for r in cell),
                "paper": ({"latency": PAPER[delta][n][0], "reach_below": PAPER[delta][n][1]}
                          if n in PAPER.get(delta, {}) else None)}
    for t in sorted({r["tasks"] for r in rows if r["tasks"] > 3}):  # T = 5 (§IV-A): every task reached when?
        runs = [r for r in rows if r["tasks"] == t]
        full = [r["full_deployment"] for r in runs if r["full_deployment"] is not None]
        table[f"tasks{t}"] = {"n": sorted({r["n"] for r in runs}), "delta": sorted({r["delta"] for r in runs}),
                              "full_deployment_mean": round(statistics.mean(full), 1) if full else None,
                              "deployed": f"{len(full)}/{len(runs)}", "reached": [r["reached"] for r in runs],
                              "redundancy": round(statistics.mean(r["redundancy"] for r in runs), 2),
                              "disconnected_ticks": sum(r["connected_ticks_lost"] for r in runs),
                              "collisions": sum(r["collisions"] for r in runs)}
    fig5 = [r for r in rows if r["tasks"] == 3]
    if fig5:
        full = [r["full_deployment"] for r in fig5 if r["full_deployment"] is not None]
        table["fig5"] = {"full_deployment_mean": round(statistics.mean(full), 1) if full else None,
                         "sd": round(statistics.stdev(full), 1) if len(full) > 1 else None,
                         "deployed": f"{len(full)}/{len(fig5)}", "paper": 180.0,
                         "redundancy": round(statistics.mean(r["redundancy"] for r in fig5), 2),
                         "disconnected_ticks": sum(r["connected_ticks_lost"] for r in fig5),
                         "collisions": sum(r["collisions"] for r in fig5)}
    return table


def sweep_trial(params: dict, *, seed: int, trial: int) -> dict:
    """One run of ``table1.toml`` (tasks = 1: n × δ, repetition ``trial``) or of the Fig. 5 file."""
    delta, tasks = float(params["delta"]), int(params.get("tasks", 1))
    distance = COLUMNS[delta][-1] if tasks == 1 else FIG5_DISTANCE
    return one({"n": int(params["n"]), "delta": delta, "seed": trial + 1, "seconds": float(params["seconds"]),
                "tasks": tasks, "distance": distance})


def sweep_figures(csv_path: Path, out_dir: Path) -> list[Path]:
    """The post step: Table I (and Fig. 5's full deployment time) beside the paper's, as ``table1.json``."""
    from swarmactors.tools.sweep import returned_values

    path = Path(out_dir) / "table1.json"
    path.write_text(json.dumps({"tol_m": TOL, "table": summarise(returned_values(csv_path))}, indent=1))
    return [path]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--seconds", type=float, default=400.0)
    ap.add_argument("--fig5-seconds", type=float, default=300.0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--sizes", default=",".join(map(str, SIZES)))
    ap.add_argument("--out", default=str(Path(__file__).resolve().parent / "results" / "table1.json"))
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    jobs = [{"n": n, "delta": d, "seed": s, "seconds": args.seconds, "tasks": 1, "distance": COLUMNS[d][-1]}
            for s in range(1, args.reps + 1) for d in COLUMNS for n in sizes]
    jobs += [{"n": 16, "delta": 240.0, "seed": s, "seconds": args.fig5_seconds, "tasks": 3,
              "distance": FIG5_DISTANCE} for s in range(1, args.reps + 1)]
    jobs.sort(key=lambda j: (j["seed"], -j["n"] * j["seconds"]))  # repetition by repetition, longest first
    rows = []
    t0 = time.time()
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    with ProcessPoolExecutor(args.jobs) as pool:
        for row in pool.map(one, jobs):  # the file is rewritten after every run: partial results survive
            rows.append(row)
            print(json.dumps(row), flush=True)
            out = {"rows": rows, "table": summarise(rows), "wall_s": round(time.time() - t0, 1), "tol_m": TOL,
                   "done": f"{len(rows)}/{len(jobs)}"}
            Path(args.out).write_text(json.dumps(out, indent=1))
    print(json.dumps(out["table"], indent=1))


if __name__ == "__main__":
    main()
