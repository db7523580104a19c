"""The measured reasons of docs/protocols/secs.md's verdict per Table I cell, each failing if its mechanism stops.

The runs are the default SECS controller (the one Table I's rows use), stepped in this process without Zenoh
(swarmactors.runs.inprocess: the same traces as the Zenoh path), kept as short as shows the mechanism:

- δ = 240, N = 5: a core of robots stays in the master's 3 m range once the formation freezes, and the arm's
  reach is 2.5 m (the spiral's leash) plus δ = 2.4 m per robot outside the core (a single file at spacing δ);
  the first column is reached at the bodies' full speed, which is why our latencies are short of the paper's.
- δ = 240, N = 3: the core empties to one robot, and the same reach law holds.
- δ = 120, N = 5: the whole swarm stays in the master's range (the core is the swarm), so no arm erupts.
- the rules: a holonomic body moves at 0.15 m/s in any direction from its first tick; a differential drive
  turning at ≤ 2 rad/s loses at most a few seconds turning, far from the paper's latencies.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from protocols.secs import rules
from protocols.secs.experiments.table1 import COLUMNS, PAPER, TOL
from protocols.secs.scenarios import secs_scenario
from swarmactors.runs.inprocess import InProcessRun
from swarmactors.runs.scenario import resolve

RANGE = 3.0  # the master's radio range (m)
LEASH = 2.5  # the spiral's far = min(1.2δ, 2.5 m): an unaligned robot beyond it approaches its informer
SPEED = 0.15  # m/s, §IV-A's foot-bots
RAY = np.array([math.cos(math.pi / 4), math.sin(math.pi / 4)])  # the task's direction
RESULTS = Path(__file__).resolve().parents[2] / "protocols" / "secs" / "experiments" / "results"


def _run(n: int, delta: float, seconds: float, seed: int = 1) -> list[tuple[float, np.ndarray]]:
    """(time s, backbone positions relative to the master) per tick of a Table I run of the defaults."""
    sc = secs_scenario(n, COLUMNS[delta][-1], delta=delta, seconds=seconds, seed=seed, checks=[])
    run = InProcessRun(resolve(sc, "<secs-table1-reasons>"))
    out = []
    while not run.done:
        rec = run.sync_step()
        rows = {int(r[0]): np.array(r[1:3], dtype=float) for r in rec["pos"]}
        master = rows.pop(0)
        out.append(((rec["t"] + 1) * 0.1, np.array([p - master for _, p in sorted(rows.items())])))
    return out


def _core(pos: np.ndarray) -> int:
    return int(np.sum(np.linalg.norm(pos, axis=1) <= RANGE))


def _law(n: int, core: int, delta: float) -> float:
    """The reach the mechanism predicts: the leash, then one robot every δ beyond the core."""
    return LEASH + (n - core) * delta / 100.0


@pytest.fixture(scope="module")
def n5_delta240():
    return _run(5, 240.0, 45.0)


def test_delta240_n5_a_core_of_four_stays_in_the_masters_range_and_the_reach_follows_the_law(n5_delta240):
    frozen = [(t, pos) for t, pos in n5_delta240 if t >= 35.0]  # the formation is frozen from ≈ 35 s
    assert frozen
    for t, pos in frozen:
        core = _core(pos)
        assert core >= 3, (t, core)  # robots that cannot leave the master's range
        assert abs(float(np.max(pos @ RAY)) - _law(5, core, 240.0)) <= 0.3, (t, core, float(np.max(pos @ RAY)))
    # the reach, 4.9 m, is below the paper's bound < 7.78 m by more than 25 %: the core keeps 4 of 5 robots
    reach = max(float(np.max(pos @ RAY)) for _, pos in n5_delta240)
    assert reach < 0.75 * PAPER[240.0][5][1]


def test_delta240_n5_first_column_is_reached_at_full_speed(n5_delta240):
    """→ 3√2 m: latency ≈ the straight-line time at 0.15 m/s, well under 0.75 × the paper's 63.7 s."""
    point = COLUMNS[240.0][0] * RAY
    first = next(t for t, pos in n5_delta240 if np.min(np.linalg.norm(pos - point, axis=1)) <= TOL)
    start = min(float(np.linalg.norm(p - point)) for p in n5_delta240[0][1])
    straight = (start - TOL) / SPEED  # the fastest any body could be there
    assert straight <= first <= 1.25 * straight, (first, straight)
    assert first < 0.75 * PAPER[240.0][5][0][0]
    # and no body ever moved faster than 0.15 m/s
    for (_, a), (_, b) in zip(n5_delta240, n5_delta240[1:], strict=False):
        assert np.max(np.linalg.norm(b - a, axis=1)) <= SPEED * 0.1 + 1e-5  # positions are traced to 1 µm


def test_delta240_n3_the_core_empties_to_one_and_the_file_follows_the_law():
    """N = 3 (seed 1): two robots leave the master's range; reach → 2.5 + 2 × 2.4 = 7.3 m (saved: 7.18 m)."""
    trace = _run(3, 240.0, 45.0)
    t, pos = trace[-1]
    assert _core(pos) == 1
    # the file's tip erupts at near the bodies' speed (≥ 0.10 of 0.15 m/s from 20 to 40 s), the reason our
    # latencies to the far columns are 0.3–0.7 of the paper's
    tip = {round(t, 1): float(np.max(p @ RAY)) for t, p in trace}
    assert (tip[40.0] - tip[20.0]) / 20.0 >= 0.10, (tip[20.0], tip[40.0])
    reach = float(np.max(pos @ RAY))
    assert reach > PAPER[240.0][3][1]  # beyond the paper's < 4.95 m already at 45 s
    assert reach <= _law(3, 1, 240.0) + 0.3


def test_delta120_n5_the_whole_swarm_stays_in_the_masters_range():
    """δ = 120, N = 5: the core is the swarm, so the arm never reaches 2√2 m (the paper: 81.1 s)."""
    trace = _run(5, 120.0, 20.0)
    point = COLUMNS[120.0][0] * RAY
    for t, pos in trace:
        assert _core(pos) == 5, t
        assert np.min(np.linalg.norm(pos - point, axis=1)) > TOL, t
    assert max(float(np.max(pos @ RAY)) for _, pos in trace) < LEASH


def test_a_holonomic_body_is_at_full_speed_at_once_and_a_turn_rate_costs_seconds_not_minutes():
    """The latencies' speed cause, at rule level: our bodies are holonomic at 0.15 m/s.

    From rest, facing away from the target, a holonomic body covers 3√2 − 0.5 m in (3√2 − 0.5)/0.15 ≈ 25 s;
    a differential drive turning at ≤ 2 rad/s (§IV-A's foot-bots) takes at most π/2 s more. Either is under
    0.75 × the paper's 63.7 s (δ = 240, N = 5): the paper's arms were slowed by more than the kinematics.
    """
    dt, goal = 0.1, COLUMNS[240.0][0]
    times = {}
    for name, turn in (("holonomic", None), ("diffdrive", 2.0)):
        x = y = 0.0
        h = math.pi  # facing away
        t = 0.0
        while math.hypot(goal - x, y) > TOL:
            v = rules.clip(((goal - x) * 10, -y * 10), SPEED)
            if turn is not None:
                h, v = rules.unicycle_step(h, v, turn, dt)
            assert math.hypot(*v) <= SPEED + 1e-9
            x, y, t = x + v[0] * dt, y + v[1] * dt, t + dt
        times[name] = t
    straight = (goal - TOL) / SPEED
    assert times["holonomic"] == pytest.approx(straight, abs=dt + 1e-9)
    assert times["holonomic"] < times["diffdrive"] <= straight + math.pi / 2 + 1.0
    assert times["diffdrive"] < 0.75 * PAPER[240.0][5][0][0]


def test_saved_delta240_runs_follow_the_reach_law_or_the_arenas_corner():
    """Every saved baseline run at δ = 240: reach at the end = 2.5 + (N − core)·2.4 within 0.3 m, or the corner.

    The arena's corner (15, 15) is 21.21 m from the master on the task's ray and bounds the reach of N ≥ 15.
    One run ends short of the law: N = 10, seed 3, where a core robot that had just lost its alignment stood
    at 3.4 m (outside the 3 m the core is counted in, yet not in the file): its file of four reaches 12.56 m,
    between the law with that robot in the core (12.1 m) and without it (14.5 m). The law stays an upper bound.
    """
    corner = math.hypot(15.0, 15.0)
    rows = [r for r in json.loads((RESULTS / "causes.json").read_text())["rows"]
            if r["variant"] == "baseline" and r["delta"] == 240.0]
    assert {r["n"] for r in rows} >= {3, 5, 10}
    short = set()
    for r in rows:
        law = _law(r["n"], r["core_end"], 240.0)
        if law >= corner:
            assert r["reach"] >= corner - 0.05, r
        else:
            assert r["reach_end"] <= law + 0.3, r
            if abs(r["reach_end"] - law) > 0.3:
                short.add((r["n"], r["seed"]))
    assert short <= {(10, 3)}, short


def test_saved_delta120_runs_keep_most_of_the_swarm_in_the_core():
    """Every saved baseline run at δ = 120 ends with at least half the swarm within the master's range."""
    rows = [r for r in json.loads((RESULTS / "causes.json").read_text())["rows"]
            if r["variant"] == "baseline" and r["delta"] == 120.0]
    assert {r["n"] for r in rows} >= {3, 5, 10}
    for r in rows:
        assert r["core_end"] >= r["n"] / 2, r
