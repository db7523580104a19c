#!/usr/bin/env python
"""Small swarms at the floor: a lockstep tick at N = 10 against one Zenoh round trip, measured in one run.

    python benchmarks/small_swarm.py [--repeats 5] [--ticks 2000] [--pings 2000] [--profile] [--json OUT]

In one process, round-robin over ``--repeats`` (so that a burst of other load spreads over every case):

1. the raw Zenoh round trip: a spawned echo process (its own peer session, listening on loopback, as the
   world's) puts back every sample it receives; this process connects, puts a beacon-sized payload and waits
   for the echo, ``--pings`` times after a warm-up (callbacks on Zenoh's thread, ``indirect=False``, reliable
   and blocking publishers: what ``transport.Link`` declares). The median is one round trip;
2. the lockstep beacon (scenarios/beacon.toml with N = 10) with K = 0 (robots in this process) and K = 2 (two
   robot-host processes): milliseconds per tick = the tick loop's wall time / ticks (``bench_measure``).

``--idle`` adds robots that do nothing (``idle_behavior:Idle``), the fixed cost of a tick. Reported: the medians
over the repeats, the K = 2 tick in round trips, and the CPU time of this process per tick
(the world's, with K = 0 the robots' too; on a loaded machine it moves less than the wall time). ``--profile``:
cProfile of one K = 0 run, its top entries by own time. Nothing is asserted; docs/benchmarks.md ("Small swarms")
quotes the numbers.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import statistics
import sys
import threading
import time
import uuid
from pathlib import Path

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

import bench_measure as measure  # noqa: E402
import zenoh  # noqa: E402

from transport import Endpoints, make_config, pack  # noqa: E402

N = 10
TARGET_K2_RTTS = 2.0  # a K = 2 tick within two round trips
TARGET_K0_MS = 0.2


def _publisher(session: zenoh.Session, key: str) -> zenoh.Publisher:
    return session.declare_publisher(
        key, congestion_control=zenoh.CongestionControl.BLOCK, reliability=zenoh.Reliability.RELIABLE
    )


def _echo(ping: str, pong: str, ready: mp.Queue, stop) -> None:
    """Put every sample received on ``ping`` back on ``pong`` until ``stop`` is set."""
    session = zenoh.open(make_config(Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"])))
    pub = _publisher(session, pong)
    sub = session.declare_subscriber(ping, zenoh.handlers.Callback(lambda s: pub.put(s.payload), indirect=False))
    ready.put(measure.own_locator(session))
    stop.wait(600.0)
    sub.undeclare()
    pub.undeclare()
    session.close()


def zenoh_rtt(pings: int, payload: bytes, warmup: int = 200) -> dict:
    """Round trips (put, echo, callback) between this process and a spawned echo process, in ms."""
    ctx = mp.get_context("spawn")
    tag = uuid.uuid4().hex[:8]
    ping, pong = f"swarmbench/rtt/{tag}/ping", f"swarmbench/rtt/{tag}/pong"
    ready, stop = ctx.Queue(), ctx.Event()
    proc = ctx.Process(target=_echo, args=(ping, pong, ready, stop), daemon=True)
    proc.start()
    try:
        locator = ready.get(timeout=60)
        session = zenoh.open(make_config(Endpoints(mode="peer", connect=[locator])))
        got = threading.Event()
        sub = session.declare_subscriber(pong, zenoh.handlers.Callback(lambda s: got.set(), indirect=False))
        pub = _publisher(session, ping)
        deadline = time.monotonic() + 30.0
        while not pub.matching_status.matching:
            if time.monotonic() > deadline:
                raise RuntimeError("no echo subscriber within 30 s")
            time.sleep(0.01)
        samples, lost = [], 0
        for i in range(warmup + pings):
            got.clear()
            t0 = time.perf_counter()
            pub.put(payload)
            if not got.wait(2.0):
                lost += 1
                continue
            if i >= warmup:
                samples.append(1e3 * (time.perf_counter() - t0))
        sub.undeclare()
        pub.undeclare()
        session.close()
    finally:
        stop.set()
        proc.join(10)
        if proc.is_alive():
            proc.kill()
    samples.sort()
    return {
        "pings": len(samples),
        "lost": lost,
        "median_ms": statistics.median(samples),
        "p10_ms": samples[len(samples) // 10],
        "p90_ms": samples[9 * len(samples) // 10],
    }


def tick_run(k: int, ticks: int, behavior: str = "beacon") -> dict:
    run = measure.lockstep_run(N, k, ticks, behavior)
    run["ms_per_tick"] = 1e3 * run["wall_s"] / ticks
    # CPU of this process (world, and with K = 0 the robots) per tick: what other load on the machine moves least
    run["cpu_ms_per_tick"] = run["ms_per_tick"] * run["world_cpu_frac"] if run["world_cpu_frac"] else None
    return run


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=5, help="rounds of (round trip, K = 0, K = 2); medians reported")
    ap.add_argument("--ticks", type=int, default=2000, help="lockstep ticks per run")
    ap.add_argument("--pings", type=int, default=2000, help="round trips per measurement")
    ap.add_argument("--idle", action="store_true",
                    help="also robots that do nothing (idle_behavior:Idle): the fixed cost of a tick, K = 0 and 2")
    ap.add_argument("--profile", action="store_true", help="cProfile of one K = 0 run: the top entries")
    ap.add_argument("--top", type=int, default=25, help="profile entries shown")
    ap.add_argument("--json", type=Path, default=None, metavar="OUT", help="write every number to OUT")
    args = ap.parse_args(argv)

    res: dict = {"n": N, "ticks": args.ticks, "repeats": args.repeats, "machine": measure.machine()}
    payload = pack([1.0, b"\x00" * 8])  # a beacon frame body in lockstep
    rtts: list[dict] = []
    runs: dict[int, list[dict]] = {0: [], 2: []}
    idle: dict[int, list[dict]] = {0: [], 2: []}
    for rep in range(args.repeats):
        rtts.append(zenoh_rtt(args.pings, payload))
        for k in runs:
            runs[k].append(tick_run(k, args.ticks))
            for prob in runs[k][-1]["problems"]:
                print(f"K={k}: {prob}", file=sys.stderr)
        if args.idle:
            for k in idle:
                idle[k].append(tick_run(k, args.ticks, "idle"))
        print(f"[{rep + 1}/{args.repeats}] rtt {rtts[-1]['median_ms']:.3f} ms  "
              f"K=0 {runs[0][-1]['ms_per_tick']:.3f} ms/tick  K=2 {runs[2][-1]['ms_per_tick']:.3f} ms/tick  "
              f"load {os.getloadavg()[0]:.2f}", flush=True)

    rtt = statistics.median(r["median_ms"] for r in rtts)
    k0 = statistics.median(r["ms_per_tick"] for r in runs[0])
    k2 = statistics.median(r["ms_per_tick"] for r in runs[2])
    cpu = {k: statistics.median(r["cpu_ms_per_tick"] or float("nan") for r in rs) for k, rs in runs.items()}
    res.update({
        "rtt_ms": rtt,
        "k0_cpu_ms_per_tick": cpu[0],
        "k2_world_cpu_ms_per_tick": cpu[2],
        "k0_ms_per_tick": k0,
        "k2_ms_per_tick": k2,
        "k0_rtts": k0 / rtt,
        "k2_rtts": k2 / rtt,
        "k0_target_met": k0 <= TARGET_K0_MS,
        "k2_target_met": k2 <= TARGET_K2_RTTS * rtt,
        "rtt_runs": rtts,
        "runs": {str(k): rs for k, rs in runs.items()},
    })
    if args.idle:
        res["idle"] = {str(k): {"ms_per_tick": statistics.median(r["ms_per_tick"] for r in rs),
                                "cpu_ms_per_tick": statistics.median(r["cpu_ms_per_tick"] or float("nan") for r in rs),
                                "runs": rs} for k, rs in idle.items()}
    res["machine"]["loadavg_end"] = list(os.getloadavg())
    print(f"N = {N}, {args.ticks} ticks, median of {args.repeats}, load {res['machine']['loadavg_start'][0]:.2f}"
          f" -> {res['machine']['loadavg_end'][0]:.2f}")
    print(f"  Zenoh round trip   {rtt:.3f} ms")
    print(f"  K = 0              {k0:.3f} ms/tick  ({k0 / rtt:.2f} round trips; target {TARGET_K0_MS} ms: "
          f"{'met' if res['k0_target_met'] else 'missed'})")
    print(f"  K = 2              {k2:.3f} ms/tick  ({k2 / rtt:.2f} round trips; target {TARGET_K2_RTTS:g}: "
          f"{'met' if res['k2_target_met'] else 'missed'})")
    print(f"  CPU of this process per tick: K = 0 {cpu[0]:.3f} ms (world and robots), K = 2 {cpu[2]:.3f} ms (world)")
    for k, r in res.get("idle", {}).items():
        print(f"  idle robots, K = {k}  {r['ms_per_tick']:.3f} ms/tick ({r['ms_per_tick'] / rtt:.2f} round trips), "
              f"CPU {r['cpu_ms_per_tick']:.3f} ms/tick")

    if args.profile:
        prof = measure.profile_k0(N, args.ticks, top=args.top)
        res["profile_k0"] = prof
        print(f"cProfile, K = 0, {args.ticks} ticks ({prof['profiled_s']:.2f} s profiled; own time):")
        for row in prof["top_tottime"]:
            print(f"  {row['tottime_s']:8.4f} s {row['share']:6.1%} {row['calls']:>8} calls  {row['function']}")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(res, indent=1, default=float) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
