"""The BMU of seed 003 §III-C end to end: the TSC's schedule drives the SECS navigation controller.

`swarmactors schedule --secs` writes the task subsets of a small instance (5 robots, tasks "a" and "b" in
slot 1, "c" after "a" in slot 2, too far to reach from the first deployment point); the master robot alone is
given them and leads flock → eruption → rendez-vous per slot, by messages only. Real world and Zenoh hosts,
lockstep. Each task is reached in its own slot, the swarm regroups between slots, stays connected at every
tick, and no 10 cm bodies collide. About 30 s.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import swarmactors
from protocols.secs import oracle
from protocols.secs.scenarios import read_sequence, sequence_scenario
from swarmactors.cli import main

pytestmark = pytest.mark.slow
TASKS = Path(__file__).parent / "data" / "secs_two_slots.toml"


def test_schedule_drives_flock_eruption_and_rendezvous(tmp_path):
    seq = tmp_path / "seq.toml"
    assert main(["schedule", str(TASKS), "--out", str(tmp_path / "tsc"), "--secs", str(seq), "--no-plot",
                 "--time-limit", "20"]) == 0
    slots = read_sequence(seq)["slots"]
    assert [[t["id"] for t in s["tasks"]] for s in slots] == [["a", "b"], ["c"]]
    assert math.dist(slots[0]["deployment"], slots[1]["deployment"]) > 3.0  # the swarm must move between slots

    sc = sequence_scenario(seq, scale=1.5, time_unit=60.0, flock_speed=0.1)
    assert "schedule" not in sc["robots"][1]["behaviors"][0]  # only the master knows it
    result = swarmactors.run(sc, out=tmp_path / "run")
    got = {c["name"]: c for c in result.checks}
    assert got["secs.connected"]["passed"], got["secs.connected"]
    assert got["world.no_collisions"]["passed"], got["world.no_collisions"]
    assert got["secs.slots"]["passed"], got["secs.slots"]

    stages = result.reports("secs")[0]["stages"]
    assert [(s, st) for _, s, st in stages] == [(1, "flocking"), (1, "secs"), (1, "rendezvous"),
                                                (2, "flocking"), (2, "secs"), (2, "rendezvous")]
    rows = oracle.slot_times(result)
    for row in rows:
        assert all(v is not None and v < 60.0 for v in row["reached"].values()), row
        assert row["spread"] < 3.0, row  # regrouped: the whole swarm within the master's range
    # the swarm did travel to the second deployment point, and every robot followed the master's phases
    ids, pos = oracle._pos(result.record(stages[4][0]))
    assert math.dist(pos[ids.index(0)], sc["robots"][0]["behaviors"][0]["schedule"]["slots"][1]["deployment"]) < 0.1
    assert {r["ph"] for r in result.reports("secs").values()} == {5}

