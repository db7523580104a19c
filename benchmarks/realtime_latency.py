#!/usr/bin/env python
"""How far realtime deliveries land from the radio's latency c (issue 22).

    python benchmarks/realtime_latency.py [--seconds 6] [--repeats 3] [--big]

Beacon robots with ``benchmarks/latency_probe.py`` in the realtime clock, dt = 50 ms, c = 10 ms (c_min = c):
every robot broadcasts each tick and every receiver records ``on_frame`` time minus the sender's
``ctx.broadcast`` time, on one machine's clock. Reported per configuration (N = 100 with K = 0 and K = 2;
N = 1000 with K = 2 with ``--big``), median over ``--repeats`` interleaved runs of each percentile:

* ``call``: latency - c from the ``ctx.broadcast`` call to the ``on_frame`` call, both on ``time.monotonic()``
  (the target's measure; never negative: a frame delivered before c is a defect);
* ``error`` (step clock): the same on ``ctx.now``, which is fixed for a host's whole step or batch, so it also
  counts the robots stepped before the sender and the frames handed over before this one;
* ``uplink``: from the broadcast call to the world receiving the frame (``frame.sent`` - sent). Since the latency
  runs from the broadcast call, the uplink, the world's decision and the downlink all happen inside c; what is
  left in ``error`` is the receiving host's lateness in handing the frame over at its due time.

Raw Zenoh's round trip on this machine is measured in ``benchmarks/bench.py`` (docs/benchmarks.md).
Results: benchmarks/results/realtime_latency.json. Nothing is asserted but "never early".
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import bench_measure as bench  # noqa: E402  (benchmarks/ is not a package)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=6.0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--big", action="store_true", help="also N = 1000, K = 2")
    args = ap.parse_args()
    configs = [(100, 0), (100, 2)] + ([(1000, 2)] if args.big else [])
    runs: dict[str, list[dict]] = {f"N={n} K={k}": [] for n, k in configs}
    for _ in range(args.repeats):
        for n, k in configs:  # interleaved
            runs[f"N={n} K={k}"].append(bench.realtime_case(n, k, args.seconds))
    out = {"machine": bench.machine(), "seconds": args.seconds, "repeats": args.repeats, "c_ms": 10.0, "cases": {}}
    for name, rs in runs.items():
        case = {"samples": sum(r["samples"] for r in rs),
                "never_early": all(r["call_ms"].get("min", 0.0) >= 0.0 for r in rs),
                "min_error_ms": min(r["call_ms"].get("min", 0.0) for r in rs)}
        for part in ("call_ms", "error_ms", "uplink_ms"):
            for q in ("p50", "p99"):
                case[f"{part[:-3]}_{q}_ms"] = round(statistics.median(r[part][q] for r in rs), 3)
        out["cases"][name] = case
        print(f"{name:12s} call-to-call p50 {case['call_p50_ms']:6.3f} ms  p99 {case['call_p99_ms']:6.3f} ms   "
              f"step clock p50 {case['error_p50_ms']:6.3f}  p99 {case['error_p99_ms']:6.3f}   "
              f"uplink p50 {case['uplink_p50_ms']:6.3f}  p99 {case['uplink_p99_ms']:6.3f}   "
              f"min {case['min_error_ms']:.3f}  ({case['samples']} samples)")
    path = HERE / "results" / "realtime_latency.json"
    path.parent.mkdir(exist_ok=True)
    path.write_text(json.dumps(out, indent=2) + "\n")


if __name__ == "__main__":
    main()
