"""``benchmarks/bench.py --quick`` still runs end to end: a broken benchmark cannot land (issue 21).

Nothing about the numbers is asserted (speed lives in benchmarks, docs/benchmarks.md), only that the run
completes, prints its tables, writes its JSON and its chart, and that the same tables render as Markdown.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
BENCH = ROOT / "benchmarks" / "bench.py"


@pytest.mark.slow
def test_bench_quick_completes_and_prints_its_tables(tmp_path):
    out = tmp_path / "results.json"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, str(BENCH), "--quick", "--out", str(out)], capture_output=True,
                          text=True, timeout=180, env=env, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    for title in ("Lockstep beacon throughput", "The floor", "Cost per robot-tick", "Deliveries per second",
                  "Realtime latency error", "Targets"):
        assert title in done.stdout, f"no {title!r} table in:\n{done.stdout[-3000:]}"
    res = json.loads(out.read_text())
    cases = {(c["behavior"], c["n"], c["k"]) for c in res["lockstep"]}
    assert {("beacon", 1000, k) for k in (0, 1, 2)} <= cases and ("idle", 1000, 0) in cases
    assert all(not run["problems"] for c in res["lockstep"] if c["behavior"] == "beacon" for run in c["runs"])
    assert out.with_suffix(".png").stat().st_size > 10_000  # the chart of robot-ticks/s against N
    md = subprocess.run([sys.executable, str(BENCH), "--markdown", str(out)], capture_output=True, text=True,
                        timeout=60, env=env)
    assert md.returncode == 0 and "#### Lockstep beacon throughput" in md.stdout and "|---:|" in md.stdout
