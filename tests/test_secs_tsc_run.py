"""One slot of the TSC-driven SECS sequence end to end (seed 003 §III-C), with the opt-in task hold.

Real world and Zenoh hosts, lockstep: 4 robots flock 0.75 m to Θ, erupt a prominence to a task 1.5 m beyond
it, hold it, and gather again. The audit of protocols/secs/experiments/sequence.py (networkx over the true
positions) finds the swarm connected to the master at every tick and the task covered unbroken for its δ.
"""

from __future__ import annotations

import math

import pytest

import swarmactors
from protocols.secs.experiments import sequence as sq
from protocols.secs.scenarios import sequence_scenario

pytestmark = pytest.mark.slow
SEQ = {"start": [0.0, 0.0], "robots": 4, "gamma": 1.0,
       "slots": [{"deployment": [0.5, 0.0], "duration": 0.5, "tasks": [{"id": "a", "position": [1.5, 0.0]}]}]}


def test_one_slot_flock_erupt_hold_gather(tmp_path):
    seq = sq.with_margin(SEQ, 1.0)  # eruption (0.5 + 1.0) × 10 s; the task needs 5 s of it
    sc = sequence_scenario(seq, scale=1.5, time_unit=10.0, flock_speed=0.15, seconds=32.0, hold_tasks=True)
    result = swarmactors.run(sc, out=tmp_path / "run")
    rep = sq.audit(result, {"a": 5.0})
    assert rep["disconnected"] == 0, rep
    assert [r["slot"] for r in rep["phases"]] == [1] and rep["phases"][0]["secs"] == pytest.approx(15.0), rep
    assert rep["phases"][0]["rendezvous"] > 0  # the master called the rendez-vous after the eruption
    task = rep["tasks"][0]
    assert task["on_time"] and task["hold"] >= 5.0, task
    at = {int(r[0]): r[1:3] for r in result.last_record()["pos"]}
    assert math.dist(at[0], [0.75, 0.0]) < 0.15, at  # the master led the flock to Θ and stayed
