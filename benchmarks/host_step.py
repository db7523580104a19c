#!/usr/bin/env python
"""A robot host's lockstep step alone, this tree against a baseline commit: decode the inputs, step, encode.

    python benchmarks/host_step.py [--base COMMIT] [--n 1000] [--ticks 30] [--repeats 7] [--profile]

One host runs N beacon robots on a grid (spacing 0.5, range 0.75: up to 8 neighbours, as scenarios/beacon.toml).
The tick inputs are built once, the way the world builds them (``transport.messages.Inputs``: a frame table
with each frame once, every robot's inbox as indices into it, its sensed neighbours), and encoded; what is
timed is what a host does with them: ``decode`` of the downlink, ``RobotRuntime.step`` (hook dispatch,
the beacon's own hooks, frame bodies) and the uplink's ``encode`` — no Zenoh, no world. The baseline commit's
tree is unpacked from git (``git archive``) and each run is a fresh process running that tree's own copy of
this script in ``--one`` mode on that tree (``PYTHONPATH``), so each side builds and decodes its own wire format
and steps its host through its own API; the baseline's copy must have ``--one`` (commits from 30ba8fc on);
runs are interleaved (A B B A …), ``--repeats`` times each, with the product's GC setting
(``swarmactors.robot.hosting.quiet_gc``). The robots' reports must agree. ``--profile`` prints a cProfile of this
tree's step instead. Nothing is asserted; the numbers go to docs/benchmarks.md and benchmarks/log/ ("A robot
host's lockstep step").
"""

from __future__ import annotations

import argparse
import asyncio
import cProfile
import hashlib
import json
import os
import pstats
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from swarmactors.robot import RobotRuntime
from swarmactors.robot.hosting import quiet_gc
from transport.codec import pack
from transport.messages import Downlink as DownlinkType
from transport.messages import FrameIn, Inputs, RobotDescr, RobotIn, RunInfo, Uplink, decode, encode

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT / "benchmarks") not in sys.path:  # idle_behavior
    sys.path.insert(0, str(ROOT / "benchmarks"))

from world_tick import unpack  # noqa: E402  (a commit's tree, unpacked once)


def one_run(tree: Path, args) -> dict:
    """One run of ``tree``'s own copy of this script in ``--one`` mode, in a fresh process."""
    env = {**os.environ, "PYTHONPATH": f"{tree}:{tree / 'benchmarks'}", "PYTHONHASHSEED": "0"}
    cmd = [sys.executable, str(tree / "benchmarks" / "host_step.py"), "--one", "--n", str(args.n),
           "--ticks", str(args.ticks)]
    p = subprocess.run(cmd + (["--idle"] if args.idle else []), cwd=tree, env=env, capture_output=True, text=True,
                       timeout=1800)
    if p.returncode != 0:
        raise RuntimeError(f"{tree}: {p.stderr[-2000:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def grid(n: int, spacing: float = 0.5) -> np.ndarray:
    side = int(np.ceil(np.sqrt(n)))
    return np.array([[spacing * (i % side), spacing * (i // side)] for i in range(n)])


def build_inputs(n: int, ticks: int, idle: bool = False) -> tuple[list[bytes], list[RobotDescr]]:
    """Each tick's encoded inputs for one host running all ``n`` robots (frames of tick t - 1 delivered at t).

    ``idle``: robots that do nothing (``idle_behavior:Idle``), so no frames: the host's own cost per robot.
    """
    pos = grid(n)
    plain = pos.tolist()
    d = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=2)
    nbrs = [np.flatnonzero((d[i] <= 0.75) & (np.arange(n) != i)).tolist() for i in range(n)]
    use = "idle_behavior:Idle" if idle else "beacon"
    descr = [RobotDescr(i, [*plain[i], 0.0], [{"use": use}], "ground", 0.75, 0.75, 1.0) for i in range(n)]
    out = []
    columns = hasattr(Inputs, "from_rows")  # the inputs as columns or as one RobotIn per robot
    for t in range(ticks):
        body = pack([float(t - 1), b"\x00" * 8])
        table = [FrameIn(s, "BEACON", t, body, float(t - 1)) for s in range(n)] if t and not idle else []
        rows = []
        for i in range(n):
            ids = nbrs[i]
            flat = np.round(pos[ids], 6).ravel().tolist()
            rows.append(RobotIn(i, [*plain[i], 0.0], (ids, flat), list(ids) if table else []))
        msg = Inputs.from_rows(t, float(t), rows, table, {}) if columns else Inputs(t, float(t), rows, table, {})
        out.append(encode(msg))
    return out, descr


def run_once(inputs: list[bytes], descr: list[RobotDescr]) -> tuple[float, int, dict]:
    """CPU seconds for a host's runtime to take ``inputs`` tick by tick; deliveries; the robots' reports."""
    runtime = RobotRuntime(RunInfo("lockstep", 1.0, 1, len(inputs), 10.0, 0), allow=("idle_behavior",))
    runtime.adopt(descr)
    deliveries = sum(len(r.inbox) for data in inputs for r in decode(data, DownlinkType, what="d").robots)

    async def steps() -> float:
        t0 = time.process_time()  # CPU time: the machine is shared, and this is one thread's work
        for data in inputs:
            msg = decode(data, DownlinkType, what="downlink")
            rows = await runtime.step(msg)
            encode(Uplink("h0", msg.tick, rows))
        return time.process_time() - t0

    with quiet_gc():
        wall = asyncio.run(steps())
    return wall, deliveries, runtime.reports()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", default="56fee55", help="baseline commit (default: the last before swarmactors/robot/)")
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--ticks", type=int, default=30)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--profile", action="store_true")
    ap.add_argument("--idle", action="store_true", help="robots that do nothing (no frames): the host's own cost")
    ap.add_argument("--one", action="store_true", help=argparse.SUPPRESS)  # one run of the tree on PYTHONPATH
    ap.add_argument("--out", type=Path, default=None, help="write the runs as JSON here")
    args = ap.parse_args(argv)
    if args.one or args.profile:
        inputs, descr = build_inputs(args.n, args.ticks, args.idle)
        if args.profile:
            prof = cProfile.Profile()
            prof.enable()
            run_once(inputs, descr)
            prof.disable()
            pstats.Stats(prof).sort_stats("tottime").print_stats(20)
            return 0
        cpu, deliveries, reports = run_once(inputs, descr)
        print(json.dumps({"cpu_s": cpu, "deliveries": deliveries,
                          "reports": hashlib.sha256(json.dumps(reports, sort_keys=True).encode()).hexdigest()}))
        return 0
    trees = {"base": unpack(args.base), "new": ROOT}
    times: dict[str, list[float]] = {"base": [], "new": []}
    reports = {}
    order = ["base", "new", "new", "base"]
    for i in range(args.repeats * 2):
        which = order[i % 4]
        r = one_run(trees[which], args)
        times[which].append(r["cpu_s"])
        reports[which] = r["reports"]
        deliveries = r["deliveries"]
    if reports["base"] != reports["new"]:
        print("the two hosts' robots reported differently", file=sys.stderr)
        return 1
    robot_ticks = args.n * args.ticks
    res = {"n": args.n, "ticks": args.ticks, "behavior": "idle" if args.idle else "beacon", "deliveries": deliveries,
           "base": args.base,
           "load": os.getloadavg()[0], "runs_s": times}
    for which in ("base", "new"):
        med = statistics.median(times[which])
        res[which] = {"median_s": med, "us_per_robot_tick": 1e6 * med / robot_ticks,
                      "us_per_delivery": 1e6 * med / deliveries if deliveries else None,
                      "robot_ticks_per_s": robot_ticks / med}
        print(f"{which:5s} median {med * 1e3:7.1f} ms for {args.ticks} ticks: "
              f"{res[which]['us_per_robot_tick']:5.2f} µs/robot-tick, {deliveries} deliveries "
              f"(runs: {', '.join(f'{t * 1e3:.0f}' for t in times[which])} ms)")
    print(f"new / base: {res['new']['median_s'] / res['base']['median_s']:.2f} (load {res['load']:.2f})")
    if args.out:
        args.out.write_text(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
