"""Peak memory after a run: everything that reads a large trace back (pictures, checks, replay, export).

Usage: ``python benchmarks/post_run_memory.py OUT_DIR [--code DIR]`` (a run's output directory with
result.json and its trace, e.g. from ``swarmactors run big.toml --no-plots --out OUT_DIR`` with N = 300 and
5,000 ticks). ``--code DIR`` runs every step against another checkout of swarmactors (its directory goes first
on the children's PYTHONPATH), so one script measures before and after a change on the same trace.

Each step runs in a fresh process and prints its peak resident set size (``ru_maxrss``) and wall time:

* ``baseline``: the imports and ``Result.load`` only;
* ``whole trace``: ``Result.trace`` (every tick record as Python objects, the earlier readers' way);
* the pictures as ``swarmactors run`` draws them (``swarm.png``, charts, ``trajectories.png``);
* ``checks``: the scenario's own ``[[checks]]`` (``launcher.judge``, as ``swarmactors run`` does), and
  ``secs.connected`` (a radio graph at every tick, from the trace alone);
* ``replay``: ``Replay`` opened (read and verified), the scene at the last tick and at the middle one (the
  viewer's slider), and an animation of 21 frames (``render``);
* ``export``: csv, parquet and mcap (``swarmactors export``; mcap needs the ``[foxglove]`` extra).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

STEPS = {
    "baseline": "pass",
    "whole trace (Result.trace)": "r.trace",
    "swarm.png": "plot_run(r, tmp / 'swarm.png')",
    "charts": "write_charts(r, tmp)",
    "trajectories.png": "plot_result_trajectories(r, tmp / 'trajectories.png')",
    "checks (the scenario's)": "judge(r, r['scenario']['checks'])",
    "secs.connected (a graph per tick)": "connected(r)",
    "replay: open, last and middle tick":
        "p = Replay(r.trace_path); p.scene_at(p.last); p.scene_at((p.first + p.last) // 2)",
    "replay: GIF of 21 frames": "render(r.trace_path, tmp / 'a.gif', every=max(1, r['ticks'] // 20))",
    "export csv": "export(r, tmp / 'csv', 'csv')",
    "export parquet": "export(r, tmp / 'pq', 'parquet')",
    "export mcap": "export(r, tmp / 'mcap', 'mcap')",
}

CHILD = """
import json, resource, sys, time
from pathlib import Path
from swarmactors.oracle.result import Result
from swarmactors.tools.plots import plot_run
from swarmactors.tools.charts import write_charts
from swarmactors.tools.trajectories import plot_result_trajectories
from swarmactors.runs.launcher import judge
from swarmactors.tools.replay import Replay, render
from swarmactors.tools.export import export
from protocols.secs.oracle import connected
out, tmp = Path(sys.argv[1]), Path(sys.argv[2])
r = Result.load(out / "result.json")
t0 = time.perf_counter()
{step}
print(json.dumps({{"wall_s": time.perf_counter() - t0,
                   "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}}))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", help="a run's output directory (result.json and trace.msgpack)")
    ap.add_argument("--code", help="a checkout of swarmactors to measure instead of the installed one")
    ap.add_argument("--only", nargs="*", help="names (or prefixes) of the steps to run")
    args = ap.parse_args()
    args.out = str(Path(args.out).resolve())
    trace = Path(args.out) / "trace.msgpack"
    env = dict(os.environ)
    if args.code:
        env["PYTHONPATH"] = os.pathsep.join([str(Path(args.code).resolve()), env.get("PYTHONPATH", "")])
    print(f"trace {trace}: {trace.stat().st_size / 1e6:.1f} MB; code {args.code or 'installed'}")
    for name, step in STEPS.items():
        if args.only and not any(name.startswith(o) for o in args.only):
            continue
        with tempfile.TemporaryDirectory() as tmp:
            done = subprocess.run([sys.executable, "-c", CHILD.format(step=step), args.out, tmp],
                                  capture_output=True, text=True, env=env, cwd=tmp)
        if done.returncode:
            print(f"{name}: failed: {(done.stderr.strip().splitlines() or ['?'])[-1]}")
            continue
        got = json.loads(done.stdout.strip().splitlines()[-1])
        print(f"{name:38s} peak {got['peak_mb']:8.0f} MB   {got['wall_s']:6.1f} s", flush=True)


if __name__ == "__main__":
    main()
