"""Peak memory after a run: the pictures drawn from a large trace, streamed or from the whole trace in memory.

Usage: ``python benchmarks/post_run_memory.py OUT_DIR`` (a run's output directory with result.json and its
trace, e.g. from ``swarmactors run big.toml --no-plots --out OUT_DIR`` with N = 300 and 5,000 ticks).

Each measurement runs in a fresh process and prints its peak resident set size (``ru_maxrss``) and wall time:

* ``whole trace``: ``Result.trace`` (every tick record as Python objects, as every picture read it before
  issue 28), then ``swarm.png``;
* ``swarm.png``, ``charts``, ``trajectories``: each as ``swarmactors run`` draws it now (streamed);
* ``baseline``: the same imports and ``Result.load`` only.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

STEPS = {
    "baseline": "pass",
    "whole trace + swarm.png": "r.trace; plot_run(r, out / 'swarm-whole.png')",
    "swarm.png (streamed)": "plot_run(r, out / 'swarm.png')",
    "charts (streamed)": "write_charts(r, out)",
    "trajectories (thinned)": "plot_result_trajectories(r, out / 'trajectories.png')",
}

CHILD = """
import json, resource, sys, time
from pathlib import Path
from swarmactors.result import Result
from swarmactors.plots import plot_run
from swarmactors.charts import write_charts
from swarmactors.trajectories import plot_result_trajectories
out = Path(sys.argv[1])
r = Result.load(out / "result.json")
t0 = time.perf_counter()
{step}
print(json.dumps({{"wall_s": time.perf_counter() - t0,
                   "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}}))
"""


def main(out: str) -> None:
    trace = Path(out) / "trace.msgpack"
    print(f"trace {trace}: {trace.stat().st_size / 1e6:.1f} MB")
    for name, step in STEPS.items():
        done = subprocess.run([sys.executable, "-c", CHILD.format(step=step), out], capture_output=True, text=True)
        if done.returncode:
            print(f"{name}: failed: {done.stderr.strip().splitlines()[-1]}")
            continue
        got = json.loads(done.stdout.strip().splitlines()[-1])
        print(f"{name:28s} peak {got['peak_mb']:8.0f} MB   {got['wall_s']:6.1f} s")


if __name__ == "__main__":
    main(sys.argv[1])
