#!/usr/bin/env python
"""Trace size and cost with and without Zstandard compression (``run.trace_compression``).

    python benchmarks/trace_compression.py [--robots 300] [--ticks 500] [--repeats 3]

A beacon swarm (every robot broadcasts every tick), K = 0, lockstep; the same scenario with
``trace_compression = "none"`` and ``"zstd"``, interleaved. Reports bytes per robot-tick, the compression ratio,
the run's wall time, the time to read the whole trace back, and checks that both traces give the same hash.
Nothing is asserted beyond the hash; results go to benchmarks/results/trace_compression.json.
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

from swarmactors.oracle.trace import read_trace
from swarmactors.runs.launcher import run

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--robots", type=int, default=300)
    ap.add_argument("--ticks", type=int, default=500)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    raw = {"run": {"name": "tracez", "ticks": args.ticks, "seed": 1},
           "robots": [{"count": args.robots, "placement": "uniform", "behaviors": [{"use": "beacon"}]}]}
    rows: dict[str, dict[str, list[float]]] = {m: {"bytes": [], "run_s": [], "read_s": []} for m in ("none", "zstd")}
    hashes = {}
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.repeats):
            for mode in ("none", "zstd"):
                t0 = time.perf_counter()
                result = run(raw, out=Path(tmp) / f"{mode}{i}", processes=0, run__trace_compression=mode)
                rows[mode]["run_s"].append(time.perf_counter() - t0)
                rows[mode]["bytes"].append(result.trace_path.stat().st_size)
                t0 = time.perf_counter()
                read_trace(result.trace_path)
                rows[mode]["read_s"].append(time.perf_counter() - t0)
                hashes[mode] = result["trace_hash"]
    robot_ticks = args.robots * args.ticks
    out = {"robots": args.robots, "ticks": args.ticks, "repeats": args.repeats,
           "same_hash": len(set(hashes.values())) == 1}
    for mode, r in rows.items():
        out[mode] = {"bytes_per_robot_tick": round(statistics.median(r["bytes"]) / robot_ticks, 2),
                     "run_s": round(statistics.median(r["run_s"]), 2),
                     "read_s": round(statistics.median(r["read_s"]), 2)}
    out["ratio"] = round(statistics.median(rows["none"]["bytes"]) / statistics.median(rows["zstd"]["bytes"]), 2)
    path = ROOT / "benchmarks" / "results" / "trace_compression.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
