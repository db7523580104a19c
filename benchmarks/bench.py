#!/usr/bin/env python
"""swarmactors benchmarks: one command, one run, one set of tables, one JSON file, one chart.

    python benchmarks/bench.py [--quick] [--out benchmarks/results.json] [--chart docs/img/bench_scaling.png]
    python benchmarks/bench.py --markdown benchmarks/results.json    # the tables of a results file, as Markdown
    python benchmarks/bench.py --redraw benchmarks/results.json      # its chart

Measures on this machine (docs/benchmarks.md explains each number; the measuring is in
``benchmarks/bench_measure.py``, the tables and the chart in ``benchmarks/bench_report.py``):

1. lockstep throughput: robot-ticks per second of the beacon workload (scenarios/beacon.toml: every robot
   broadcasts one small frame per tick, grid placement, ~8 neighbours each) at N = 10 ... 10,000 robots with
   K = 0, 1 and 2 robot-host processes, and the chart of robot-ticks/s against N;
2. the floor: the same at N = 1000 with robots that do nothing (``idle_behavior:Idle``);
3. how the cost per robot-tick grows with N;
4. deliveries per second: the emulator's (N = 1000, K = 2) against raw Zenoh pub/sub between two spawned
   processes, one message per (frame, receiver), same payload size, same run (also the chart's raw line);
5. realtime latency error: N = 100 ``latency_probe`` robots in the realtime clock, c = 10 ms;
6. where the time goes: cProfile of one N = 1000 lockstep run (K = 0) and of the world and host processes of
   one N = 1000, K = 2 run (full mode only).

Every case runs ``--repeats`` times (5; 1 with ``--quick``), round-robin over the cases so that a burst of other
load spreads over all of them; the tables give the median and the best run, every run and the load average
before it are in the JSON. ``--quick`` (fewer N, fewer ticks, no K = 2 profile; under a minute) exists so that CI
can check that the benchmark still runs (tests/test_bench_quick.py). Nothing here is asserted.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

import bench_measure as measure  # noqa: E402
import bench_report as report  # noqa: E402
from rich.console import Console  # noqa: E402

from transport import pack  # noqa: E402

FULL = {
    "repeats": 5,
    "n": [10, 100, 1000, 10_000],
    "k": [0, 1, 2],
    "ticks": {10: 3000, 100: 300, 1000: 40, 10_000: 6},
    "floor_n": 1000,
    "floor_k": [0, 2],
    "profile_ticks": 30,
    "raw_s": 3.0,
    "realtime_s": 4.0,
    "realtime_k": [0, 2],
    "k2_profile": True,
}
QUICK = {
    "repeats": 1,
    "n": [10, 1000],
    "k": [0, 1, 2],
    "ticks": {10: 200, 1000: 4},
    "floor_n": 1000,
    "floor_k": [0],
    "profile_ticks": 3,
    "raw_s": 1.0,
    "realtime_s": 1.0,
    "realtime_k": [0],
    "k2_profile": False,
}
FOCUS = {  # the N = 1000 targets only: lockstep K = 0 and 2, the floor at K = 2, raw Zenoh; no realtime
    "repeats": 5,
    "n": [1000],
    "k": [0, 2],
    "ticks": {1000: 40},
    "floor_n": 1000,
    "floor_k": [2],
    "profile_ticks": 30,
    "raw_s": 3.0,
    "realtime_s": 4.0,
    "realtime_k": [],
    "k2_profile": False,
}
CHART = HERE.parent / "docs" / "img" / "bench_scaling.png"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="N = 10 and 1000, few ticks, one repeat (under a minute)")
    ap.add_argument("--focus", action="store_true",
                    help="N = 1000 only: lockstep K = 0 and 2, the floor at K = 2, raw Zenoh (no realtime)")
    ap.add_argument("--out", type=Path, default=HERE / "results.json", help="JSON results (default %(default)s)")
    ap.add_argument("--chart", type=Path, default=None,
                    help=f"the chart of robot-ticks/s against N (default: {CHART} for a full run, beside --out "
                    "with --quick)")
    ap.add_argument("--repeats", type=int, default=None, help="runs per case (median and best reported)")
    ap.add_argument("--wait-quiet", type=float, default=0.0, metavar="SECONDS",
                    help="first wait up to SECONDS for the 1-minute load average to fall below 0.5")
    ap.add_argument("--markdown", type=Path, metavar="RESULTS_JSON",
                    help="print the tables of an existing results file as Markdown and exit (runs nothing)")
    ap.add_argument("--redraw", type=Path, metavar="RESULTS_JSON",
                    help="draw the chart of an existing results file (to --chart, default %s) and exit" % CHART)
    args = ap.parse_args(argv)
    console = Console(width=160) if not sys.stdout.isatty() else Console()
    if args.markdown:
        print(report.to_markdown(report.tables(json.loads(args.markdown.read_text()))), end="")
        return 0
    if args.redraw:
        console.log(f"wrote {report.chart(json.loads(args.redraw.read_text()), args.chart or CHART)}")
        return 0
    cfg = dict(QUICK if args.quick else FOCUS if args.focus else FULL)
    if args.repeats:
        cfg["repeats"] = args.repeats
    chart = args.chart or (args.out.with_suffix(".png") if args.quick or args.focus else CHART)
    if args.wait_quiet > 0:
        deadline = time.monotonic() + args.wait_quiet
        while os.getloadavg()[0] >= 0.5 and time.monotonic() < deadline:
            console.log(f"waiting for a quiet machine (load average {os.getloadavg()[0]:.2f})")
            time.sleep(15)
    t_start = time.perf_counter()
    mode = "quick" if args.quick else "focus" if args.focus else "full"
    res: dict = {"config": {"mode": mode, **cfg}, "targets_def": report.TARGETS}
    res["machine"] = measure.machine()
    if res["machine"]["loadavg_start"][0] > 0.5:
        console.log(f"[yellow]load average {res['machine']['loadavg_start'][0]:.2f} before starting: other work on "
                    "this machine will lower and scatter the numbers")

    # Round-robin over the cases, repeat by repeat, so that a burst of load spreads over every case.
    cases = [("beacon", n, k) for n in cfg["n"] for k in cfg["k"]]
    cases += [("idle", cfg["floor_n"], k) for k in cfg["floor_k"]]
    runs: dict[tuple, list] = {c: [] for c in cases}
    for rep in range(cfg["repeats"]):
        for behavior, n, k in cases:
            ticks = cfg["ticks"][n]
            console.log(f"[{rep + 1}/{cfg['repeats']}] lockstep {behavior} N={n} K={k}, {ticks} ticks")
            run = measure.lockstep_run(n, k, ticks, behavior)
            for prob in run["problems"]:
                if behavior == "beacon" or "dropped" not in prob:
                    console.log(f"[red]{behavior} N={n} K={k}: {prob}")
            runs[(behavior, n, k)].append(run)
    res["lockstep"] = [measure.aggregate(n, k, cfg["ticks"][n], runs[(b, n, k)], b) for b, n, k in cases]

    payload = pack([1.0, b"\x00" * 8])  # == a beacon frame body in lockstep: [ctx.now, 8 zero bytes]
    raws: dict[bool, list] = {True: [], False: []}
    for rep in range(cfg["repeats"]):
        for indirect in (True, False):
            console.log(f"[{rep + 1}/{cfg['repeats']}] raw Zenoh pub/sub, {cfg['raw_s']} s, indirect={indirect}")
            raws[indirect].append(measure.raw_zenoh(cfg["raw_s"], payload, indirect=indirect))

    def median_raw(rs: list[dict]) -> dict:
        ordered = sorted(rs, key=lambda r: r.get("msgs_per_s") or 0)
        out = dict(ordered[len(ordered) // 2])
        out["all_msgs_per_s"] = [r.get("msgs_per_s") for r in rs]
        return out

    raw, raw_direct = median_raw(raws[True]), median_raw(raws[False])
    by = {(c["n"], c["k"]): c for c in res["lockstep"] if c["behavior"] == "beacon"}
    emu_case = (1000, 2) if (1000, 2) in by else max(by)
    emu = by[emu_case]["deliveries_per_s_median"]
    res["deliveries"] = {
        "raw": raw,
        "raw_indirect_false": raw_direct,
        "emulator_case": f"N = {emu_case[0]}, K = {emu_case[1]} lockstep beacon",
        "emulator_per_s": emu,
        "beacon_body_bytes": len(payload),
        "ratio": emu / raw["msgs_per_s"] if raw.get("msgs_per_s") else None,
        "ratio_vs_indirect_false": emu / raw_direct["msgs_per_s"] if raw_direct.get("msgs_per_s") else None,
    }

    rt_runs: dict[int, list] = {k: [] for k in cfg["realtime_k"]}
    for rep in range(cfg["repeats"]):
        for k in rt_runs:
            console.log(f"[{rep + 1}/{cfg['repeats']}] realtime latency probe N=100 K={k}, {cfg['realtime_s']} s")
            rt_runs[k].append(measure.realtime_case(100, k, cfg["realtime_s"]))

    def best_rt(rs: list[dict]) -> dict:
        ordered = sorted(rs, key=lambda r: r["error_ms"].get("p99", float("inf")))
        out = dict(ordered[0])
        out["p99_all_runs_ms"] = [r["error_ms"].get("p99") for r in rs]
        out["p99_median_ms"] = ordered[len(ordered) // 2]["error_ms"].get("p99")
        return out

    res["realtime"] = [best_rt(rs) for rs in rt_runs.values()]

    console.log("profiling N=1000 K=0")
    res["profile"] = {"k0": measure.profile_k0(1000, cfg["profile_ticks"])}
    if cfg["k2_profile"]:
        console.log("profiling N=1000 K=2 (world and hosts)")
        res["profile"]["k2"] = measure.profile_k2(1000, cfg["profile_ticks"])

    res["targets"] = report.targets(res)
    res["machine"]["loadavg_end"] = list(os.getloadavg())
    res["bench_s"] = time.perf_counter() - t_start
    report.to_rich(report.tables(res), console)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(res, indent=1, default=float, allow_nan=True) + "\n")
    drawn = report.chart(res, chart)
    console.log(f"wrote {args.out} and {drawn} ({res['bench_s']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
