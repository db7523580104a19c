"""SECS navigation controller end to end (issue 18): real runs of the world, Zenoh hosts where K ≥ 1.

A prominence of N = 10 robots (δ = 240) reaches a task at 5√2 m, connected at every tick and without a
collision of the 10 cm bodies, with ∠T exact against the truth; the trace hash is the same with 1 and 3
host processes; rendez-vous and flocking keep the swarm together; bad angle messages are refused and counted.
"""

from __future__ import annotations

import math

import pytest

import swarmactors
from protocols.secs import oracle
from protocols.secs.scenarios import secs_scenario
from swarmactors import Behavior

pytestmark = pytest.mark.slow


def _outcomes(result) -> dict:
    return {c["name"]: c for c in result.checks}


def test_one_prominence_reaches_a_task_at_5_root_2(tmp_path):
    sc = secs_scenario(10, 5 * math.sqrt(2), delta=240.0, seconds=60, checks=[
        {"use": "secs.connected"}, {"use": "secs.reach"}, {"use": "world.no_collisions"},
        {"use": "secs.angle", "bound": 1e-3}])
    result = swarmactors.run(sc, out=tmp_path)
    got = _outcomes(result)
    assert got["secs.connected"]["passed"], got["secs.connected"]
    assert got["secs.reach"]["passed"], got["secs.reach"]
    assert got["world.no_collisions"]["passed"], got["world.no_collisions"]
    assert got["secs.angle"]["passed"], got["secs.angle"]
    assert result["metrics"]["secs"]["refused"] == 0
    # robots really did align and follow the arm: the one nearest the task was informed along a chain
    reports = result.reports("secs")
    assert all(r["first_aligned"] is not None for rid, r in reports.items() if rid != 0)


def test_same_trace_hash_with_one_and_three_hosts(tmp_path):
    sc = secs_scenario(6, 3 * math.sqrt(2), delta=240.0, seconds=8, checks=[{"use": "secs.connected"}])
    hashes = {k: swarmactors.run(sc, out=tmp_path / f"k{k}", processes=k)["trace_hash"] for k in (1, 3)}
    assert hashes[1] == hashes[3]


def test_rendezvous_gathers_the_swarm(tmp_path):
    """The master floods δ = 90: every robot moves by Lennard-Jones alone and the swarm stays compact."""
    sc = secs_scenario(8, 4.0, delta=240.0, seconds=20, rendezvous_at=0.0, delta_rv=90.0,
                       checks=[{"use": "secs.connected"}, {"use": "world.no_collisions"}])
    result = swarmactors.run(sc, out=tmp_path)
    assert result.passed, result.checks
    reports = result.reports("secs")
    assert {r["mode"] for r in reports.values()} == {"rendezvous"}
    ids, pos = oracle._pos(result.trace[-1])
    spread = max(math.dist(p, pos[ids.index(0)]) for p in pos)
    assert spread < 2.4  # far inside what δ = 240 would spread to


def test_flocking_moves_the_swarm_with_its_master(tmp_path):
    sc = secs_scenario(8, 4.0, seconds=25, flock_at=0.0, flock_to=[4.0, 0.0], flock_speed=0.1,
                       checks=[{"use": "secs.connected"}, {"use": "world.no_collisions"}])
    result = swarmactors.run(sc, out=tmp_path)
    assert result.passed, result.checks
    ids0, pos0 = oracle._pos(result.trace[0])
    ids, pos = oracle._pos(result.trace[-1])
    shift = pos[1:].mean(axis=0) - pos0[1:].mean(axis=0)
    assert shift[0] > 1.0 and abs(shift[1]) < 0.5, shift


class Rogue(Behavior):
    """Broadcasts SECS messages with a NaN angle, an angle of 7 rad and a bad ∠M, every tick."""

    name = "rogue"
    kinds = ("NONE",)

    def on_tick(self, ctx, sensed) -> None:
        ctx.broadcast("SECS_T", {"a": 0, "T": float("nan"), "al": True, "d": 0.5})
        ctx.broadcast("SECS_T", {"a": 0, "T": 7.0, "al": True, "d": 0.5})
        ctx.broadcast("SECS_M", {"M": [[s.id, -1.0] for s in sensed]})


def test_bad_angle_messages_are_refused_and_counted(tmp_path):
    sc = secs_scenario(4, 3.0, seconds=3, checks=[{"use": "secs.connected"}])
    sc["robots"].append({"positions": [[-0.5, -0.5]], "range": 3.0, "body_radius": 0.05,
                         "behaviors": [{"use": "test_secs_navigation:Rogue"}]})
    result = swarmactors.run(sc, out=tmp_path)
    reports = result.reports("secs")
    ticks = result["ticks"]
    for rid in range(1, 5):
        refused = reports[rid]["refused"]
        assert refused.get("angle", 0) >= 2 * (ticks - 2), (rid, refused)  # 3 bad frames per tick from tick 1
    assert result["metrics"]["secs"]["refused"] > 0
