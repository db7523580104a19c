"""Core v2 end to end.

Robots share nothing, objects are known as declared, the context reads the scenario, ``on_batch`` runs after
a batch of frames, and realtime timers fire at their due time.
"""

from __future__ import annotations

import pytest

pytestmark = pytest.mark.slow


def _nest(processes_robots: int = 4, known_by="all") -> dict:
    return {
        "run": {"name": "nest", "seed": 1, "ticks": 4},
        "radio": {"range": 5.0},
        "world": {"objects": [{"name": "target", "pos": [0.5, 0.0], "known_by": known_by}]},
        "robots": [{"count": processes_robots, "placement": "line", "spacing": 1.0, "sensing": 1.0,
                    "behaviors": [{"use": "behaviors_for_tests:Mutator", "mutator": 1}]}],
    }


@pytest.mark.parametrize("processes", [0, 1])
def test_a_receiver_that_mutates_a_frame_body_changes_nobody_elses(run, processes):
    result = run(_nest(), processes=processes)
    bodies = {rid: r["mutator"]["body"] for rid, r in result.robots.items()}
    sent = {"list": [0, [1]], "map": {"a": {"b": 1}}, "n": 7}
    assert bodies[1] == {"list": [0, [1, 1], 1], "map": {"a": {"b": 1}, "new": True}, "n": 7}  # its own copy
    for rid in (2, 3):  # on the same host as robot 1
        assert bodies[rid] == sent, (rid, bodies[rid])


def test_each_robot_has_its_own_objects(run):
    result = run(_nest())
    objects = {rid: r["mutator"]["objects"] for rid, r in result.robots.items()}
    assert objects[1]["target"][-1] == 99.0 and "mine" in objects[1]
    for rid in (0, 2, 3):
        assert objects[rid] == {"target": [0.5, 0.0]}, (rid, objects[rid])


def test_objects_known_by_sensing_reach_only_the_robots_that_sense_them(run):
    # robots at x = 0, 1, 2, 3 with sensing 1.0; the target at x = 0.5 is within reach of robots 0 and 1 only
    result = run(_nest(known_by="sensing"))
    objects = {rid: r["mutator"]["objects"] for rid, r in result.robots.items()}
    assert objects[0] == {"target": [0.5, 0.0]}
    assert set(objects[1]) == {"target", "mine"}
    assert objects[2] == {} and objects[3] == {}


def test_objects_known_by_a_list_of_robots(run):
    result = run(_nest(known_by=[3]))
    objects = {rid: r["mutator"]["objects"] for rid, r in result.robots.items()}
    assert objects[3] == {"target": [0.5, 0.0]}
    assert objects[0] == {} and objects[2] == {}


@pytest.mark.parametrize("clock", ["lockstep", "realtime"])
def test_context_reads_the_scenario_and_time_is_read_only(run, clock):
    sc = {"run": {"name": "ctx", "seed": 1, "ticks": 3, "dt": 0.05, "clock": clock},
          "radio": {"range": 2.0},
          "robots": [{"count": 2, "placement": "line", "spacing": 1.0, "range": 1.5, "sensing": 0.7,
                      "behaviors": [{"use": "behaviors_for_tests:ReadsContext"}]}]}
    result = run(sc)
    for r in result.robots.values():
        seen = r["reads_context"]["seen"]
        assert seen["dt"] == 0.05 and seen["range"] == 1.5 and seen["sensing"] == 0.7 and seen["clock"] == clock
        assert sorted(seen["read_only"]) == ["clock", "dt", "now", "range", "sensing", "tick"]


def test_lockstep_hook_order_frames_batch_timers_tick(run):
    sc = {"run": {"name": "order", "seed": 1, "ticks": 5},
          "robots": [{"count": 2, "placement": "line", "spacing": 0.5,
                      "behaviors": [{"use": "behaviors_for_tests:BatchAndTimers", "delay": 2}]}]}
    result = run(sc)
    order = result.robots[1]["batch_timers"]["order"]
    # robot 0's PING of tick t arrives at t + 1: frame, then batch, then (at tick 2) the timer, then tick
    assert order[:7] == [[0, "tick"], [1, "frame"], [1, "batch"], [1, "tick"], [2, "frame"], [2, "batch"],
                         [2, "timer"]], order
    assert order[7] == [2, "tick"]
    assert result.robots[0]["batch_timers"]["batches"] == 0  # it receives nothing: no batch


def test_realtime_timer_fires_at_its_due_time_not_at_the_next_tick(run):
    dt, delay = 0.25, 0.05
    sc = {"run": {"name": "timers", "seed": 1, "ticks": 4, "dt": dt, "clock": "realtime"},
          "radio": {"latency_s": 0.01},
          "robots": [{"count": 2, "placement": "line", "spacing": 0.5,
                      "behaviors": [{"use": "behaviors_for_tests:BatchAndTimers", "delay": delay}]}]}
    result = run(sc)
    for r in result.robots.values():
        due, fired = r["batch_timers"]["timer"]
        assert fired >= due - 1e-3  # never early (ctx.now is wall time since the start)
        assert fired - due < dt / 2, (due, fired)  # not held to the next tick boundary (dt later)
    # robot 1 got robot 0's PINGs in batches, each followed by on_batch
    assert result.robots[1]["batch_timers"]["batches"] >= 2
