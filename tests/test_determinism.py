"""Lockstep determinism: the same scenario and seed give the same trace hash whatever K."""

from __future__ import annotations

import pytest

from swarmactors.oracle.trace import verify

pytestmark = pytest.mark.slow  # every test runs scenarios over Zenoh


def lossy_flood(seed: int = 3) -> dict:
    return {
        "run": {"name": "det", "seed": seed, "ticks": 14},
        "radio": {"range": 1.0, "latency": 1, "loss": 0.2},
        "world": {"bounds": [[0.0, 0.0], [3.0, 3.0]]},
        "robots": [{"count": 24, "placement": "uniform",
                    "behaviors": [{"use": "flooding", "origin": 0, "at": 1, "expiry": 8},
                                  {"use": "beacon", "every": 3}]}],
        "events": [{"at": 6, "kill": [5]}],
    }


def test_same_hash_with_0_1_and_3_host_processes(run):
    hashes = {k: run(lossy_flood(), processes=k)["trace_hash"] for k in (0, 1, 3)}
    assert len(set(hashes.values())) == 1, hashes


def test_trace_file_rehashes_to_the_result_hash(run):
    result = run(lossy_flood())
    assert verify(result.trace_path) == result["trace_hash"]


def test_different_seed_gives_different_hash(run):
    assert run(lossy_flood(3))["trace_hash"] != run(lossy_flood(4))["trace_hash"]


def test_killing_one_robot_one_tick_earlier_changes_the_hash(run):
    a = lossy_flood()
    b = lossy_flood()
    b["events"] = [{"at": 5, "kill": [5]}]
    assert run(a)["trace_hash"] != run(b)["trace_hash"]


def test_moving_robots_with_speed_limits_are_deterministic_across_processes(run):
    sc = {
        "run": {"name": "move", "seed": 1, "ticks": 15, "dt": 0.5},
        "radio": {"range": 1.0},
        "robots": [{"count": 9, "placement": "grid", "speed": 0.2, "turn_rate": 0.5,
                    "behaviors": [{"use": "tests_support:RandomWalk"}]}],
    }
    a, b = run(sc, processes=0), run(sc, processes=2)
    assert a["trace_hash"] == b["trace_hash"]
    first, last = a.record(0)["pos"], a.record(14)["pos"]
    assert first != last  # the robots did move
    for r0, r1 in zip(first, last, strict=True):
        assert ((r1[1] - r0[1]) ** 2 + (r1[2] - r0[2]) ** 2) ** 0.5 <= 0.2 * 0.5 * 14 + 1e-6
