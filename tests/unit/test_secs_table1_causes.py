"""The measured reasons why Table I's cells differ from the paper (docs/protocols/secs.md, "Verdict per Table I cell").

Each test fails if the mechanism a verdict names stops holding. The formation tests step the default SECS
controller in process (swarmactors.runs.inprocess: the Simulation and the robots' runtimes, no Zenoh), seed 1,
for the shortest time after which the formation is frozen; the speed test is rule-level, over the scenario's
speed limit and the saved Table I rows (protocols/secs/experiments/results/table1.json).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from protocols.secs.behavior import SECS
from protocols.secs.experiments.table1 import COLUMNS, PAPER, TOL
from protocols.secs.scenarios import cluster, secs_scenario
from swarmactors.runs.inprocess import InProcessRun
from swarmactors.runs.scenario import resolve

RANGE = 3.0  # the master's radio range (m): the core is the backbone within it
LEASH = 2.5  # the spiral's `far` = min(1.2δ, 2.5 m) at δ = 240
RESULTS = Path(__file__).resolve().parents[2] / "protocols" / "secs" / "experiments" / "results"
RAY = np.array([math.cos(math.pi / 4), math.sin(math.pi / 4)])  # the task's 45° ray


def _formation(n: int, delta: float, seconds: float) -> tuple[int, float]:
    """(core, reach along the ray) of the default controller's backbone after ``seconds``, seed 1."""
    spec = resolve(secs_scenario(n, COLUMNS[delta][-1], delta=delta, seconds=seconds, seed=1, checks=[]), "<t>")
    run = InProcessRun(spec)
    rec: dict = {}
    while not run.done:
        rec = run.sync_step()
    back = np.array([r[1:3] for r in rec["pos"] if r[0] != 0], dtype=float)  # robot 0 is the master, at (0, 0)
    return int(np.sum(np.linalg.norm(back, axis=1) <= RANGE)), float(np.max(back @ RAY))


def test_delta240_n5_a_core_stays_in_the_masters_range_and_one_file_at_delta_lies_beyond():
    # Frozen from ≈ 30 s (the saved 300 s runs end with the same core of 4 and reach 5.0 m).
    core, reach = _formation(5, 240.0, 32.0)
    assert core >= 3, core  # the 5° cone and the 2.5 m leash keep most robots in the master's range
    assert core < 5  # and one robot at least erupted
    assert reach == pytest.approx(LEASH + (5 - core) * 2.4, abs=0.3), (core, reach)


def test_delta120_n5_the_whole_swarm_stays_in_the_core():
    # At δ = 120 the arm never leaves the master's range: no single file, reach below the range.
    core, reach = _formation(5, 120.0, 15.0)
    assert core >= 4, core  # most of the swarm (all 5 in the saved runs)
    assert reach < RANGE, reach


def test_the_arena_corner_bounds_the_delta240_n15_n20_reach_whatever_the_measured_cores():
    # reach ≈ 2.5 + (N − core)·2.4 passes the corner (21.21 m on the ray) for any core of at most 7 (the
    # baseline's measured δ = 240 cores are 4–5): the saved 21.21 m is the wall, not the prominence's end.
    (x0, y0), (x1, y1) = secs_scenario(1, 1.0)["world"]["bounds"]
    corner = math.hypot(x1, y1)
    assert corner == pytest.approx(21.21, abs=0.01) and (x0, y0) == (-x1, -y1)
    for n in (15, 20):
        assert all(LEASH + (n - core) * 2.4 > corner for core in range(1, 8))
    rows = json.loads((RESULTS / "table1.json").read_text())["table"]
    assert rows["240/15"]["reach_min"] == rows["240/20"]["reach_min"] == pytest.approx(corner, abs=0.01)


def test_latencies_hug_the_holonomic_speed_floor_while_the_papers_are_far_above_it():
    # Our bodies are holonomic (no turn rate unless the `turn_rate` variant is asked for) and move at the
    # scenario's 0.15 m/s in any direction from the first tick, so a latency cannot be below the straight-line
    # floor (distance from the nearest start point, less the 0.5 m tolerance, at full speed) and ours stays
    # within 1.5× of it where an arm erupts; the paper's differential-drive foot-bots took 1.9–6× that floor.
    assert SECS().turn_rate is None
    speed = secs_scenario(1, 1.0)["robots"][1]["speed"]
    assert speed == 0.15
    rows = json.loads((RESULTS / "table1.json").read_text())["table"]
    for delta, per_n in PAPER.items():
        for n, (paper, _) in per_n.items():
            starts = np.array(cluster(n))
            for c, d in enumerate(COLUMNS[delta]):
                floor = (float(np.min(np.linalg.norm(starts - d * RAY, axis=1))) - TOL) / speed
                ours = rows[f"{delta:g}/{n}"]["latency"][c]["mean"]
                if ours is not None:
                    assert ours >= floor * 0.99, (delta, n, d, ours, floor)
                if paper[c] is not None:
                    assert paper[c] > 1.8 * floor, (delta, n, d, paper[c], floor)
                if delta == 240.0 and ours is not None and n >= 5:
                    assert ours < 1.5 * floor, (delta, n, d, ours, floor)
