"""N = 10,000: a lockstep beacon run of 20 ticks completes (a smoke test of scale, not a timing; issue 21).

Every robot broadcasts one frame per tick on a 100 x 100 grid (spacing 0.5, range 0.75: 8 neighbours inside the
grid). The run must do all its ticks with no robot failed and no frame dropped, and deliver exactly one frame
per directed in-range pair per tick from the second tick on (latency one tick), counted here with a k-d tree.
The trace is written in ``summary`` mode: its footer's ``trace_hash`` must be the run's, and every tick record
must count its deliveries. Robot-ticks per second at this size are in docs/benchmarks.md ("Lockstep").
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from swarmactors.oracle.trace import read_trace
from swarmactors.runs.launcher import run

pytestmark = pytest.mark.slow

N, TICKS, SIDE, SPACING, RANGE = 10_000, 20, 100, 0.5, 0.75


def test_ten_thousand_beacons_for_twenty_lockstep_ticks(tmp_path):
    sc = {"run": {"name": "scale", "seed": 1, "ticks": TICKS, "trace": "summary", "join_timeout_s": 300,
                  "watchdog_s": 120},
          "radio": {"range": RANGE, "latency": 1},
          "robots": [{"count": N, "placement": "grid", "spacing": SPACING, "behaviors": [{"use": "beacon"}]}]}
    result = run(sc, out=tmp_path)
    assert result["ticks"] == TICKS and result["stop_reason"] is None
    assert not [rid for rid, r in result["robots"].items() if r["failed"]]
    world = result["world"]
    assert world["frames_sent"] == N * TICKS and world["dropped_total"] == 0
    xy = np.array([[k % SIDE, k // SIDE] for k in range(N)], dtype=float) * SPACING
    pairs = len(cKDTree(xy).query_pairs(RANGE * (1 + 1e-9)))
    assert world["deliveries"] == 2 * pairs * (TICKS - 1)
    header, records, footer = read_trace(tmp_path / "trace.msgpack")
    assert header["mode"] == "summary" and footer["trace_hash"] == result["trace_hash"]
    assert [r.get("ndel", 0) for r in records] == [0] + [2 * pairs] * (TICKS - 1)
