#!/usr/bin/env python
"""The world's tick: CPU per delivery of the world process, this tree against a baseline commit, and scale.

    python benchmarks/world_tick.py ab [--base e83c6c9] [--new COMMIT] [--n 1000] [--k 2] [--repeats 5] [--out FILE]
    python benchmarks/world_tick.py scale [--n 1000 10000] [--ticks 20] [--k 2] [--repeats 3] [--out FILE]
    python benchmarks/world_tick.py stages [--n 1000] [--ticks 30] [--base COMMIT --repeats 3]
    python benchmarks/world_tick.py inproc [--base COMMIT] [--n 1000] [--k 2] [--ticks 30] [--repeats 5] [--profile]

``ab``: the lockstep beacon (every robot broadcasts one small frame per tick; grid spacing 1, range 1.5, so about
8 neighbours each) with K = 2 host processes, so the world is alone in the measuring process. Each version runs
``--short`` and ``--long`` ticks and the difference is taken, so start-up cancels out: world CPU per delivery =
Δ(CPU time of the world process, all its threads) / Δ(deliveries). Versions run interleaved (A B B A …) and
their trace hashes must agree. The baseline is unpacked from git (``git archive``) under the temporary
directory and shadows the installed package through PYTHONPATH.

``scale``: robot-ticks per second (N × ticks / the tick loop's wall time) of the same beacon at each N.

``stages``: CPU time (of the world's thread) of the world's stages inside one K = 2 run (begin, the radio,
deliveries, inputs, the trace record and hash), from wrappers installed in the world process.

``inproc``: the same lockstep beacon with the world's ``Simulation`` and K ``RobotRuntime``s in one process and
no Zenoh, handing each other the bytes the real run sends (sealed and decoded the same way), so CPU time splits
exactly between the world's Python work (its tick, encoding the inputs, decoding the uplinks) and the hosts'
(decoding, stepping, encoding). Each run is a fresh process on this tree or the baseline's (which must have
``world.Simulation``), interleaved;
the trace hash must be the same as the real run's. ``--profile``
prints a cProfile of this tree's world part.

Nothing is asserted: numbers go to stdout and the JSON file, and by hand to docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MEASURE = r"""
import json, os, sys, time
from swarmactors.runs.launcher import run
def main():
    n, ticks, k, out, stages, trace = (int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), sys.argv[4],
                                       sys.argv[5] == "1", sys.argv[6])
    sc = {"run": {"name": "wt", "seed": 1, "ticks": ticks, "trace": trace == "full"},
          "radio": {"range": 1.5},
          "robots": [{"count": n, "placement": "grid", "spacing": 1.0,
                      "behaviors": [{"use": "protocols.beacon.behavior:Beacon", "every": 1}]}]}
    if trace not in ("full", "off", "none"):
        sc["run"]["trace"] = trace
    spent = {}
    if stages:
        from world import Simulation
        from swarmactors.oracle import trace as tr
        def wrap(cls, name):
            f = getattr(cls, name)
            def g(*a, **kw):
                t = time.thread_time()
                try:
                    return f(*a, **kw)
                finally:
                    spent[name] = spent.get(name, 0.0) + time.thread_time() - t
            setattr(cls, name, g)
        for name in ("begin", "inputs", "take", "transmit", "deliver", "end"):
            wrap(Simulation, name)
        wrap(tr.TraceWriter, "record")
    t0, p0 = os.times(), time.process_time()
    r = run(sc, out=out, processes=k)
    t1, p1 = os.times(), time.process_time()
    print(json.dumps({"world_cpu": (t1.user - t0.user) + (t1.system - t0.system),
                      "deliveries": r["world"]["deliveries"], "ticks": r["ticks"], "hash": r["trace_hash"],
                      "wall_s": r["wall_s"], "stages": spent, "process_cpu": p1 - p0}))
if __name__ == "__main__":
    main()
"""

INPROC = r"""
import asyncio, cProfile, json, pstats, sys, time
from swarmactors.robot.hosting import quiet_gc
from swarmactors.robot import RobotRuntime
from swarmactors.runs.scenario import resolve
from swarmactors.oracle.trace import TraceWriter
from transport import seal, unseal
from transport.messages import Downlink, RunInfo, Uplink, decode, encode
from world import Simulation

KEY = bytes(32)

def main():
    n, ticks, k, profile = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), sys.argv[4] == "1"
    raw = {"run": {"name": "wt", "seed": 1, "ticks": ticks, "trace": False}, "radio": {"range": 1.5},
           "robots": [{"count": n, "placement": "grid", "spacing": 1.0,
                       "behaviors": [{"use": "protocols.beacon.behavior:Beacon", "every": 1}]}]}
    trace = TraceWriter(None, {}, mode="off")
    sim = Simulation(resolve(raw, "<bench>"))
    run = RunInfo("lockstep", sim.dt, sim.seed, ticks, 10.0, 0)
    hosts = {}
    per = -(-n // k)
    for i in range(k):
        runtime = RobotRuntime(run, (), f"h{i}")
        runtime.adopt(sim.claim(f"h{i}", min(per, n - i * per)))
        hosts[f"h{i}"] = runtime
    spent = {"host": 0.0}

    async def host_step(name, data):  # what a host session does with a downlink, around its runtime's step
        t = time.process_time()
        msg = decode(unseal(KEY, data, what="downlink"), Downlink, what="downlink")
        out = await hosts[name].step(msg)
        up = seal(KEY, encode(Uplink(name, msg.tick, out)))
        spent["host"] += time.process_time() - t
        return up

    async def loop():  # the world session's lockstep tick, with the bytes the real run sends
        for tick in range(ticks):
            sim.begin(tick, float(tick))
            ups = {h: await host_step(h, seal(KEY, encode(sim.inputs(h)))) for h in sorted(hosts)}
            for h, up in ups.items():
                sim.take(h, decode(unseal(KEY, up, what="uplink"), Uplink, what="uplink"))
            sim.transmit()
            trace.record(sim.end())

    prof = cProfile.Profile() if profile else None
    with quiet_gc():  # as the world's and the hosts' processes do
        t0 = time.process_time()
        if prof:
            prof.enable()
        asyncio.run(loop())
        if prof:
            prof.disable()
        total = time.process_time() - t0
    res = {"world_cpu": total - spent["host"], "host_cpu": spent["host"], "deliveries": sim.counters.delivered,
           "ticks": ticks, "hash": trace.trace_hash}
    if prof:
        st = pstats.Stats(prof, stream=sys.stderr)
        st.sort_stats("tottime").print_stats(35)
    print(json.dumps(res))

if __name__ == "__main__":
    main()
"""


def unpack(commit: str) -> Path:
    """The tree of ``commit``, unpacked once under the temporary directory."""
    path = Path(tempfile.gettempdir()) / f"swarmactors-tree-{commit[:12]}"
    if not path.exists():
        path.mkdir()
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", commit], check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(path)], input=archive, check=True)
    return path


def measure(tree: Path, n: int, ticks: int, k: int = 2, stages: bool = False, trace: str = "off") -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree), "PYTHONHASHSEED": "0"}
    with tempfile.TemporaryDirectory() as out:
        p = subprocess.run([sys.executable, "-c", MEASURE, str(n), str(ticks), str(k), out, "1" if stages else "0",
                            trace], cwd=tree, env=env, capture_output=True, text=True, timeout=1800)
    if p.returncode != 0:
        raise RuntimeError(f"{tree}: {p.stderr[-2000:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def marginal(tree: Path, n: int, short: int, long: int, k: int = 2) -> dict:
    a, b = measure(tree, n, short, k), measure(tree, n, long, k)
    d = b["deliveries"] - a["deliveries"]
    return {"world_us": 1e6 * (b["world_cpu"] - a["world_cpu"]) / d, "deliveries": d, "hash": b["hash"],
            "robot_ticks_s": n * b["ticks"] / b["wall_s"]}


def loadavg() -> float:
    return round(os.getloadavg()[0], 2)


def ab(args) -> dict:
    trees = {"base": unpack(args.base), "new": unpack(args.new) if args.new else ROOT}
    runs: dict[str, list[dict]] = {"base": [], "new": []}
    for i in range(args.repeats):
        for name in (("base", "new") if i % 2 == 0 else ("new", "base")):
            r = marginal(trees[name], args.n, args.short, args.long, args.k)
            r["load"] = loadavg()
            runs[name].append(r)
            print(f"{i} {name:4s} world {r['world_us']:.2f} us/delivery  {r['robot_ticks_s']:,.0f} robot-ticks/s"
                  f"  load {r['load']}", flush=True)
    med = {name: {k: statistics.median(r[k] for r in rs) for k in ("world_us", "robot_ticks_s")}
           for name, rs in runs.items()}
    return {"base": args.base, "new": args.new or "working tree", "n": args.n, "k": args.k,
            "ticks": [args.short, args.long],
            "repeats": args.repeats,
            "median": med, "ratio_new_over_base": med["new"]["world_us"] / med["base"]["world_us"],
            "same_trace_hash": len({r["hash"] for rs in runs.values() for r in rs}) == 1, "runs": runs}


def scale(args) -> dict:
    runs: dict[str, list[dict]] = {}
    for i in range(args.repeats):
        for n in args.n:
            r = measure(ROOT, n, args.ticks, args.k, trace=args.trace)
            r["robot_ticks_s"] = n * r["ticks"] / r["wall_s"]
            r["load"] = loadavg()
            runs.setdefault(str(n), []).append(r)
            print(f"{i} N={n} K={args.k} {r['robot_ticks_s']:,.0f} robot-ticks/s  wall {r['wall_s']:.2f} s  "
                  f"world CPU {r['world_cpu']:.1f} s  load {r['load']}", flush=True)
    return {"k": args.k, "ticks": args.ticks, "trace": args.trace, "runs": runs,
            "median_robot_ticks_s": {n: statistics.median(r["robot_ticks_s"] for r in rs) for n, rs in runs.items()}}


def inproc_run(tree: Path, n: int, ticks: int, k: int, profile: bool = False) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree), "PYTHONHASHSEED": "0"}
    p = subprocess.run([sys.executable, "-c", INPROC, str(n), str(ticks), str(k), "1" if profile else "0"], cwd=tree,
                       env=env, capture_output=True, text=True, timeout=1800)
    if p.returncode != 0:
        raise RuntimeError(f"{tree}: {p.stderr[-2000:]}")
    if profile:
        print(p.stderr)
    return json.loads(p.stdout.strip().splitlines()[-1])


def inproc(args) -> dict:
    n = args.n[0]
    if args.profile:
        return inproc_run(ROOT, n, args.ticks, args.k, profile=True)
    trees = {"base": unpack(args.base), "new": ROOT}
    runs: dict[str, list[dict]] = {"base": [], "new": []}
    for i in range(args.repeats):
        for name in (("base", "new") if i % 2 == 0 else ("new", "base")):
            r = inproc_run(trees[name], n, args.ticks, args.k)
            r["world_us"] = 1e6 * r["world_cpu"] / r["deliveries"]
            r["host_us_per_robot_tick"] = 1e6 * r["host_cpu"] / (n * r["ticks"])
            r["load"] = loadavg()
            runs[name].append(r)
            print(f"{i} {name:4s} world {r['world_us']:.2f} us/delivery  hosts {r['host_us_per_robot_tick']:.2f} "
                  f"us/robot-tick  load {r['load']}", flush=True)
    med = {name: {key: statistics.median(r[key] for r in rs) for key in ("world_us", "host_us_per_robot_tick")}
           for name, rs in runs.items()}
    return {"base": args.base, "n": n, "k": args.k, "ticks": args.ticks, "repeats": args.repeats, "median": med,
            "world_new_over_base": med["new"]["world_us"] / med["base"]["world_us"],
            "hosts_new_over_base": med["new"]["host_us_per_robot_tick"] / med["base"]["host_us_per_robot_tick"],
            "same_trace_hash": len({r["hash"] for rs in runs.values() for r in rs}) == 1, "runs": runs}


def stages(args) -> dict:
    if not args.base:
        r = measure(ROOT, args.n[0], args.ticks, 2, stages=True)
        d = r["deliveries"]
        for name, s in sorted(r["stages"].items(), key=lambda kv: -kv[1]):
            print(f"{name:14s} {s:7.3f} s  {1e6 * s / d:6.2f} us/delivery")
        print(f"world CPU {r['world_cpu']:.2f} s ({r['process_cpu']:.2f}) for {d} deliveries (whole run, start-up "
              "included)")
        return r
    # --base: both trees, interleaved, --repeats runs each; the median of each stage (µs per delivery)
    trees = {"base": unpack(args.base), "new": ROOT}
    runs: dict[str, list[dict]] = {"base": [], "new": []}
    for i in range(args.repeats):
        for name in (("base", "new") if i % 2 == 0 else ("new", "base")):
            r = measure(trees[name], args.n[0], args.ticks, 2, stages=True)
            r["load"] = loadavg()
            runs[name].append(r)
    med = {name: {st: statistics.median(1e6 * r["stages"].get(st, 0.0) / r["deliveries"] for r in rs)
                  for st in sorted({st for r in rs for st in r["stages"]})} for name, rs in runs.items()}
    for st in sorted(set(med["base"]) | set(med["new"]), key=lambda st: -med["base"].get(st, 0.0)):
        print(f"{st:14s} {med['base'].get(st, 0.0):6.2f} -> {med['new'].get(st, 0.0):6.2f} us/delivery")
    loads = [r["load"] for rs in runs.values() for r in rs]
    print(f"load {min(loads)}-{max(loads)}; same hash: {len({r['hash'] for rs in runs.values() for r in rs}) == 1}")
    return {"base": args.base, "n": args.n[0], "ticks": args.ticks, "median_us_per_delivery": med, "runs": runs}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="what", required=True)
    a = sub.add_parser("ab")
    a.add_argument("--base", default="e83c6c9")
    a.add_argument("--new", default=None, help="commit to compare (default: this working tree)")
    a.add_argument("--n", type=int, default=1000)
    a.add_argument("--short", type=int, default=10)
    a.add_argument("--long", type=int, default=50)
    a.add_argument("--repeats", type=int, default=5)
    a.add_argument("--k", type=int, default=2, help="host processes (0: robots in the world's process)")
    s = sub.add_parser("scale")
    s.add_argument("--n", type=int, nargs="+", default=[1000, 10000])
    s.add_argument("--ticks", type=int, default=20)
    s.add_argument("--k", type=int, default=2)
    s.add_argument("--repeats", type=int, default=3)
    s.add_argument("--trace", default="off", help="run.trace: off, summary or full")
    g = sub.add_parser("stages")
    g.add_argument("--n", type=int, nargs=1, default=[1000])
    g.add_argument("--ticks", type=int, default=30)
    g.add_argument("--base", default=None, help="also run this commit's tree, interleaved, and compare")
    g.add_argument("--repeats", type=int, default=3)
    i = sub.add_parser("inproc")
    i.add_argument("--base", default="0fcb11d", help="a commit with world.Simulation (Core v3 or later)")
    i.add_argument("--n", type=int, nargs=1, default=[1000])
    i.add_argument("--k", type=int, default=2)
    i.add_argument("--ticks", type=int, default=30)
    i.add_argument("--repeats", type=int, default=5)
    i.add_argument("--profile", action="store_true", help="a cProfile of this tree's run (world and hosts)")
    for p in (a, s, g, i):
        p.add_argument("--out", type=Path, default=None, help="JSON results")
    args = ap.parse_args(argv)
    result = {"ab": ab, "scale": scale, "stages": stages, "inproc": inproc}[args.what](args)
    result["cpus"] = os.cpu_count()
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(result, indent=2))
    if (args.what != "stages" or args.base) and not getattr(args, "profile", False):
        print(json.dumps({k: v for k, v in result.items() if k != "runs"}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
