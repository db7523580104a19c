#!/usr/bin/env python
"""How far realtime deliveries land from the radio's latency c.

    python benchmarks/realtime_latency.py [--seconds 6] [--repeats 3] [--big] [--tree A=/path --tree B=/path]

Beacon robots with ``benchmarks/latency_probe.py`` in the realtime clock, dt = 50 ms, c = 10 ms (c_min = c):
every robot broadcasts each tick and every receiver records ``on_frame`` time minus the sender's
``ctx.broadcast`` time, on one machine's clock. Reported per configuration (N = 100 with K = 0 and K = 2;
N = 1000 with K = 2 with ``--big``), median over ``--repeats`` interleaved runs of each percentile:

* ``call``: latency - c from the ``ctx.broadcast`` call to the ``on_frame`` call, both on ``time.monotonic()``
  (the target's measure; never negative: a frame delivered before c is a defect);
* ``error`` (step clock): the same on ``ctx.now``, which is fixed for a host's whole step or batch, so it also
  counts the robots stepped before the sender and the frames handed over before this one;
* the split of each delivery (hosts run with ``SWARMACTORS_RT_STAMPS=1``, on ``time.time()``, ms):
  ``uplink`` broadcast call -> the world scheduled the delivery (the sender's host, Zenoh, the world's loop and
  radio); ``downlink`` -> the receiving host's loop took the downlink (the world's encoding, Zenoh, the host's
  loop wait); ``slack`` = due time - arrival (negative: it arrived late); ``timer`` -> the precise timer's thread
  woke, minus the due time (or the arrival, when later); ``loop`` -> the loop began handing it over (the host's
  loop busy with something else); ``queue`` -> ``on_frame`` was called (frames of the same hand-over before it).
  ``late`` = on_frame - due = (arrived late) + timer + loop + queue.

Each run is its own process (``--one``), so that ``--tree NAME=PATH`` can put another source tree first on
``PYTHONPATH`` for an A/B comparison in one interleaved run (the measuring code is always this file's). The
1-minute load average is recorded before every run. Results: benchmarks/results/realtime_latency.json (or
``--out``). Nothing is asserted but "never early".
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
PARTS = ("uplink", "downlink", "slack", "timer", "loop", "queue", "late")


def _cpu_s(pid: int) -> float:
    """A process's CPU time so far (user + system), from /proc (Linux), seconds."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def one(n: int, k: int, seconds: float, spread: float = 0.0) -> dict:
    """One run in this process (hosts inherit the stamps switch); percentiles of every measure."""
    os.environ.setdefault("SWARMACTORS_RT_STAMPS", "1")
    sys.path.insert(0, str(HERE))
    import bench_measure as bench  # (benchmarks/ is not a package; imported after the switch is set)
    import numpy as np

    c = bench.REALTIME_C
    import multiprocessing
    import time

    # (tick, wall clock, the world's process CPU, the host processes' CPU) at each tick's end
    marks: list[tuple[int, float, float, list[float]]] = []

    def on_tick(world) -> None:
        hosts = []
        for p in multiprocessing.active_children():
            try:
                hosts.append(_cpu_s(p.pid))
            except (OSError, IndexError, ValueError):  # a host that has just exited
                hosts.append(float("nan"))
        marks.append((world.tick, time.perf_counter(), time.process_time(), hosts))

    params = f"spread = {spread}" if spread else ""
    data, _ = bench.run_emulator(bench.realtime_scenario(n, seconds, params=params), k, on_tick=on_tick)
    delays, mono, parts = [], [], []
    for r in data["robots"].values():
        rep = r.get("latency_probe") or {}
        delays += rep.get("delays", [])
        mono += rep.get("delays_mono", [])
        parts += rep.get("parts", [])

    def dist(a) -> dict:
        a = np.asarray(a, dtype=float)
        if not a.size:
            return {}
        q = np.percentile(a, [50, 90, 99, 99.9])
        return {"p50": float(q[0]), "p90": float(q[1]), "p99": float(q[2]), "p999": float(q[3]),
                "max": float(a.max()), "min": float(a.min())}

    ticked = max(1, marks[-1][0] - marks[0][0]) if len(marks) > 1 else 0
    out = {"n": n, "k": k, "spread": spread, "ticks": data["ticks"], "samples": len(mono), "load1": os.getloadavg()[0],
           "call_ms": dist((np.array(mono) - c) * 1e3), "error_ms": dist((np.array(delays) - c) * 1e3),
           "problems": bench.check_run(data, n, data["ticks"]),
           "deliveries_per_tick": data["world"]["deliveries"] / max(1, data["ticks"]),
           # the world's process (with the robots when K = 0), from the end of the first tick to that of the last
           "world_cpu_ms_per_tick": (marks[-1][2] - marks[0][2]) * 1e3 / ticked if ticked else None,
           # each host process (K > 0), the same span; with the world's, the share of the machine's cores in use
           "host_cpu_ms_per_tick": ([(b - a) * 1e3 / ticked for a, b in zip(marks[0][3], marks[-1][3], strict=False)]
                                    if ticked else None)}
    if ticked:  # CPU seconds per second of the run: how many of the machine's cores the processes kept busy
        busy = (marks[-1][2] - marks[0][2]) + sum(b - a for a, b in zip(marks[0][3], marks[-1][3], strict=False))
        out["cores_busy"] = busy / (marks[-1][1] - marks[0][1])
        out["tick_wall_ms"] = (marks[-1][1] - marks[0][1]) * 1e3 / ticked
    if parts:
        p = np.array(parts) * 1e3  # ms after the broadcast call: scheduled, arrived, woke, handed, on_frame
        due = c * 1e3
        sched, arr, woke, handed, call = p.T
        out["stamped"] = len(p)
        split = {"uplink": sched, "downlink": arr - sched, "slack": due - arr,
                 "timer": woke - np.maximum(due, arr), "loop": handed - woke, "queue": call - handed,
                 "late": call - due}
        for name, a in split.items():
            out[f"{name}_ms"] = dist(a)
        out["arrived_late_share"] = float((arr > due).mean())
        tail = split["late"] >= np.percentile(split["late"], 99)  # what the worst 1 % is made of (means, ms)
        out["tail_ms"] = {name: float(a[tail].mean()) for name, a in split.items()}
    return out


def floor(n_host: int, per_robot: float, repeats: int = 5) -> dict:
    """CPU cost of one realtime host's work per tick, in this process, no Zenoh: ``n_host`` probe robots.

    A tick's deliveries for the host (``per_robot`` each, random senders, all due already) are handed over in
    one burst (``RobotRuntime.take_deliveries``: grouped by due time, then handed to the robots), the same
    frames' ``on_frame`` calls are made alone, the host steps its robots once (``RobotRuntime.take_inputs`` in
    one slice, each robot's frame encoded and sealed for the uplink), and the downlink's ``Deliveries`` message
    is decoded. Medians of ``repeats``, CPU time of this thread.
    """
    import asyncio
    import time

    import numpy as np

    sys.path.insert(0, str(HERE))
    from swarmactors.robot import RobotRuntime
    from swarmactors.robot.behavior import Frame
    from transport import pack, seal
    from transport.messages import (
        Deliveries,
        Downlink,
        FrameIn,
        Inputs,
        RobotDescr,
        RobotIn,
        RunInfo,
        Uplink,
        decode,
        encode,
    )

    def uplink(rows) -> None:  # the uplink's bytes are built (encoded, sealed) and then dropped
        seal(b"k" * 32, encode(Uplink("h1", 1, rows)))

    class NoTimer:  # every copy is due already: none waits
        def add(self, due, item):
            raise AssertionError("a copy went on the timer")

    rng = np.random.default_rng(1)
    d_total = int(round(n_host * per_robot))
    out: dict[str, list[float]] = {"handover_ms": [], "on_frame_only_ms": [], "step_ms": [], "decode_ms": []}
    cpu = time.thread_time

    async def once() -> None:
        runtime = RobotRuntime(RunInfo("realtime", 0.05, 1, 100, 5.0, 0), allow=("latency_probe",))
        runtime.adopt([RobotDescr(i, [float(i), 0.0, 0.0], [{"use": "latency_probe:LatencyProbe"}], "r", 10.0, 5.0,
                                  1.0) for i in range(n_host)])
        runtime.start_realtime(uplink, NoTimer(), slice_size=n_host)  # one slice: the whole step at once
        now = time.time()
        dst = rng.integers(0, n_host, d_total)
        src = rng.integers(0, 2 * n_host, d_total)
        senders, refs = np.unique(src, return_inverse=True)  # each sender's frame once in the table
        table = [FrameIn(int(s), "PROBE", 1, pack([0.0, time.monotonic(), now]), 0.0) for s in senders.tolist()]
        order = np.argsort(dst, kind="stable")
        msg = Deliveries.of(table, dst[order], refs[order], np.full(d_total, now))
        wire = encode(msg)
        t = cpu()
        decode(wire, Downlink, what="floor")
        out["decode_ms"].append((cpu() - t) * 1e3)
        t = cpu()
        runtime.take_deliveries(msg)
        out["handover_ms"].append((cpu() - t) * 1e3)
        robots = runtime.robots
        frames = [(robots[d], Frame(table[k].src, "PROBE", [0.0, 0.0, 0.0], 1, 0.0))
                  for d, k in zip(dst[order].tolist(), refs[order].tolist(), strict=True)]
        t = cpu()
        for robot, f in frames:
            robot.behaviors[0].on_frame(robot.ctx, f)
        out["on_frame_only_ms"].append((cpu() - t) * 1e3)
        msg = Inputs.from_rows(1, 0.0, [RobotIn(i, [float(i), 0.0, 0.0], ([], []), []) for i in range(n_host)],
                               epoch=now)
        t = cpu()
        runtime.take_inputs(msg)
        out["step_ms"].append((cpu() - t) * 1e3)
        runtime.stop()
        await runtime.close()

    for _ in range(repeats):
        asyncio.run(once())
    res = {"robots": n_host, "deliveries": d_total, "repeats": repeats}
    for key, vals in out.items():
        res[key] = round(statistics.median(vals), 3)
    res["handover_us_per_delivery"] = round(res["handover_ms"] * 1e3 / d_total, 3)
    res["on_frame_us_per_delivery"] = round(res["on_frame_only_ms"] * 1e3 / d_total, 3)
    res["step_us_per_robot"] = round(res["step_ms"] * 1e3 / n_host, 3)
    return res


def _child(args: list[str], env: dict | None = None, what: str = "") -> dict:
    """Run this file with ``args`` in a fresh process; its last line of output, as JSON."""
    res = subprocess.run([sys.executable, __file__, *args], env=env, capture_output=True, text=True, check=False)
    if res.returncode:
        sys.exit(f"{what or ' '.join(args)} failed:\n{res.stderr[-3000:]}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def scan(sizes: list[int], seconds: float, repeats: int, out: Path) -> None:
    """Latency - c at each N (K = 2, stamps off) beside the floor of one host's hand-over of a tick's copies.

    Per N and repeat, interleaved: one realtime run (``--one``), then ``floor`` for one host's share (N / 2
    robots, the run's deliveries per robot) in its own process. A host receives its tick's copies within a
    few milliseconds (every robot broadcasts at the start of its step), so the time to hand them over in one
    go, measured without Zenoh, is what the latest of them waits at the least.
    """
    env = dict(os.environ, SWARMACTORS_RT_STAMPS="0")
    rows: dict[int, list[dict]] = {n: [] for n in sizes}
    for rep in range(repeats):
        for n in sizes:
            r = _child(["--one", str(n), "2", str(seconds), "0"], env)
            f = _child(["--floor-one", str(n // 2), str(r["deliveries_per_tick"] / n)], env)
            r["floor"] = f
            rows[n].append(r)
            print(f"[{rep}] N={n:<5d} load {r['load1']:.2f}  cores {r.get('cores_busy', 0):.2f}  call p50 "
                  f"{r['call_ms']['p50']:7.3f}  p99 {r['call_ms']['p99']:8.3f} ms   one host's hand-over "
                  f"{f['handover_ms']:.2f} ms ({f['deliveries']} copies), step {f['step_ms']:.2f} ms", flush=True)
    med = statistics.median
    summary = [{"n": n, "p50_ms": med(r["call_ms"]["p50"] for r in rs), "p99_ms": med(r["call_ms"]["p99"] for r in rs),
                "p99_range": [min(r["call_ms"]["p99"] for r in rs), max(r["call_ms"]["p99"] for r in rs)],
                "min_ms": min(r["call_ms"]["min"] for r in rs),
                "cores_busy": med(r["cores_busy"] for r in rs),
                "world_cpu_ms_per_tick": med(r["world_cpu_ms_per_tick"] for r in rs),
                "host_cpu_ms_per_tick": med(sum(r["host_cpu_ms_per_tick"]) / 2 for r in rs),
                "handover_floor_ms": med(r["floor"]["handover_ms"] for r in rs),
                "step_floor_ms": med(r["floor"]["step_ms"] for r in rs),
                "copies_per_host": rs[0]["floor"]["deliveries"]} for n, rs in rows.items()]
    for s in summary:
        print(f"N={s['n']:<5d} p50 {s['p50_ms']:.3f}  p99 {s['p99_ms']:.3f} {s['p99_range']}"
              f"  cores {s['cores_busy']:.2f}  one host's hand-over {s['handover_floor_ms']:.2f} ms"
              f"  step {s['step_floor_ms']:.2f} ms")
    path = out.with_name("realtime_scan.json")
    path.write_text(json.dumps({"seconds": seconds, "repeats": repeats, "c_ms": 10.0, "k": 2, "summary": summary,
                                "runs": {str(n): rs for n, rs in rows.items()}}, indent=2) + "\n")
    plot_scan(summary, ROOT / "docs" / "img" / "realtime_scan.png")
    print(f"wrote {path}")


def plot_scan(summary: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = [s["n"] for s in summary]
    fig, ax = plt.subplots(figsize=(7, 4.2))
    lo = [s["p99_ms"] - s["p99_range"][0] for s in summary]
    hi = [s["p99_range"][1] - s["p99_ms"] for s in summary]
    ax.errorbar(n, [s["p99_ms"] for s in summary], yerr=[lo, hi], fmt="o-", capsize=3, label="latency - c, p99")
    ax.plot(n, [s["p50_ms"] for s in summary], "s-", label="latency - c, p50")
    ax.plot(n, [s["handover_floor_ms"] for s in summary], "k--", label="one host's hand-over of a tick (no Zenoh)")
    ax.axhline(5.0, color="r", lw=0.8, ls=":", label="target at N = 1000: p99 < 5 ms")
    ax.set_yscale("log")
    ax.set_xlabel("robots N (K = 2 host processes)")
    ax.set_ylabel("ms")
    ax.set_title("Realtime latency - c (c = 10 ms, dt = 50 ms) against the hand-over floor", fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def parse_config(text: str) -> tuple[int, int, float]:
    """``N x K[@spread]`` (e.g. ``1000x2@1``) as (N, K, spread); a clear error for anything else."""
    try:
        nk, _, spread = text.partition("@")
        n, k = (int(x) for x in nk.split("x"))
        s = float(spread) if spread else 0.0
    except ValueError:
        sys.exit(f"--only: {text!r} is not N x K[@spread] (e.g. 1000x2 or 1000x2@1)")
    if n < 1 or k < 0 or not 0.0 <= s <= 1.0:
        sys.exit(f"--only: {text!r}: N must be >= 1, K >= 0 and the spread in [0, 1]")
    return n, k, s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=6.0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--big", action="store_true", help="also N = 1000, K = 2")
    ap.add_argument("--only", default="", help="configurations N x K[@spread], e.g. '100x2,1000x2,1000x2@1' "
                    "(default: 100x0,100x2); spread: the probe's broadcast phases spread over that fraction of a tick")
    ap.add_argument("--tree", action="append", default=[], help="NAME=PATH: a source tree to compare (A/B)")
    ap.add_argument("--env", action="append", default=[], help="NAME:VAR=VALUE: an environment setting per tree")
    ap.add_argument("--out", default=str(HERE / "results" / "realtime_latency.json"))
    ap.add_argument("--floor", action="store_true", help="only the host's CPU cost per tick (no Zenoh)")
    ap.add_argument("--scan", default="", help="N values (K = 2), e.g. '200,400,600,800,1000': latency against "
                    "the floor of one host's hand-over, results/realtime_scan.json and docs/img/realtime_scan.png")
    ap.add_argument("--floor-one", nargs=2, type=float, metavar=("ROBOTS", "PER_ROBOT"), help=argparse.SUPPRESS)
    ap.add_argument("--one", nargs=4, type=float, metavar=("N", "K", "SECONDS", "SPREAD"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        print(json.dumps(one(int(args.one[0]), int(args.one[1]), args.one[2], args.one[3])))
        return
    if args.floor_one:
        print(json.dumps(floor(int(args.floor_one[0]), args.floor_one[1])))
        return
    if args.scan:
        try:
            sizes = [int(x) for x in args.scan.split(",")]
        except ValueError:
            sys.exit(f"--scan: {args.scan!r} is not a list of robot counts (e.g. 200,400,1000)")
        if min(sizes) < 2:
            sys.exit(f"--scan: {args.scan!r}: every N must be >= 2 (two hosts)")
        scan(sizes, args.seconds, args.repeats, Path(args.out))
        return
    if args.floor:
        rows = [floor(n, 7.43) for n in (50, 100, 500, 1000)]
        for r in rows:
            print(json.dumps(r))
        path = Path(args.out).with_name("realtime_floor.json")
        path.write_text(json.dumps({"load1": os.getloadavg()[0], "floor": rows}, indent=2) + "\n")
        return
    configs = [parse_config(c) for c in args.only.split(",")] if args.only else (
        [(100, 0, 0.0), (100, 2, 0.0)] + ([(1000, 2, 0.0)] if args.big else []))
    trees = [t.split("=", 1) for t in args.tree] or [["this", str(ROOT)]]
    extra: dict[str, dict[str, str]] = {}
    for e in args.env:
        name, kv = e.split(":", 1)
        var, val = kv.split("=", 1)
        extra.setdefault(name, {})[var] = val
    runs: dict[str, list[dict]] = {}
    for rep in range(args.repeats):
        for n, k, spread in configs:
            label = f"N={n} K={k}" + (f" spread={spread:g}" if spread else "")
            for name, path in trees:  # interleaved: every tree once per configuration and repeat
                env = dict(os.environ, PYTHONPATH=str(Path(path).resolve()), **extra.get(name, {}))
                r = _child(["--one", str(n), str(k), str(args.seconds), str(spread)], env, f"run {name} {label}")
                runs.setdefault(f"{name} {label}", []).append(r)
                print(f"[{rep}] {name:6s} {label:18s} load {r['load1']:.2f}  cores {r.get('cores_busy', 0):.2f}"
                      f"  call p50 "
                      f"{r['call_ms'].get('p50', 0):6.3f}  p99 {r['call_ms'].get('p99', 0):6.3f}  min "
                      f"{r['call_ms'].get('min', 0):6.3f} ms  {r['problems'] or ''}", flush=True)
    out = {"seconds": args.seconds, "repeats": args.repeats, "c_ms": 10.0, "trees": dict(trees),
           "env": extra, "cases": {}, "runs": runs}
    for name, rs in runs.items():
        case = {"samples": sum(r["samples"] for r in rs),
                "never_early": all(r["call_ms"].get("min", 0.0) >= 0.0 for r in rs),
                "min_ms": min(r["call_ms"].get("min", 0.0) for r in rs),
                "load1": [round(r["load1"], 2) for r in rs],
                "cores_busy": [round(r["cores_busy"], 2) for r in rs if r.get("cores_busy") is not None],
                "world_cpu_ms_per_tick": [round(r["world_cpu_ms_per_tick"], 2) for r in rs
                                          if r.get("world_cpu_ms_per_tick") is not None]}
        for part in ("call", "error") + PARTS:
            for q in ("p50", "p99"):
                vals = [r[f"{part}_ms"][q] for r in rs if r.get(f"{part}_ms")]
                if vals:
                    case[f"{part}_{q}_ms"] = round(statistics.median(vals), 3)
                    case[f"{part}_{q}_range"] = [round(min(vals), 3), round(max(vals), 3)]
        out["cases"][name] = case
        print(f"{name:30s} call p50 {case['call_p50_ms']:6.3f} {case['call_p50_range']}  "
              f"p99 {case['call_p99_ms']:6.3f} {case['call_p99_range']}"
              f"  min {case['min_ms']:.3f}  load {case['load1']}  cores {case['cores_busy']}")
        if "late_p50_ms" in case:
            print("    p50/p99 " + "  ".join(f"{p} {case.get(f'{p}_p50_ms', 0):.3f}/{case.get(f'{p}_p99_ms', 0):.3f}"
                                               for p in PARTS))
            tails = [r["tail_ms"] for r in rs if "tail_ms" in r]
            print("    worst 1 %, mean " + "  ".join(f"{p} {statistics.median(t[p] for t in tails):.3f}"
                                                    for p in PARTS)
                  + f"  arrived late {statistics.median(r['arrived_late_share'] for r in rs if 'stamped' in r):.4f}")
    path = Path(args.out)
    path.parent.mkdir(exist_ok=True)
    path.write_text(json.dumps(out, indent=2) + "\n")


if __name__ == "__main__":
    main()
