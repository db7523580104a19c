"""Faults: killed robots go silent, added robots take part, a dead host's robots fail."""

from __future__ import annotations

import asyncio
import time

import pytest

from swarmactors.runs.launcher import new_run_id, run_world, spawn_hosts
from swarmactors.runs.scenario import resolve_scenario
from transport import Endpoints

pytestmark = pytest.mark.slow  # every test runs a world over Zenoh


def beacons(n=16, ticks=12, events=(), clock="lockstep") -> dict:
    return {
        "run": {"name": "faults", "seed": 2, "ticks": ticks, "clock": clock},
        "radio": {"range": 1.0},
        "robots": [{"count": n, "placement": "grid", "spacing": 0.6, "behaviors": [{"use": "beacon"}]}],
        "events": list(events),
    }


def test_killed_robot_stops_sending_and_receiving_at_that_tick(run):
    result = run(beacons(events=[{"at": 5, "kill": [3]}]))
    for rec in result.trace:
        senders = {row[0] for row in rec.get("sent", [])}
        receivers = {row[2] for row in rec.get("del", [])}
        assert (3 in senders) == (rec["t"] < 5), rec["t"]
        if rec["t"] >= 5:
            assert 3 not in receivers
    assert any(3 in {row[2] for row in rec.get("del", [])} for rec in result.trace if rec["t"] < 5)
    dropped_dead = [row for rec in result.trace for row in rec.get("drop", []) if row[2] == 3]
    assert dropped_dead and all(row[3] == "dead" for row in dropped_dead)  # frames in the air when it died
    failed = result.robots[3]["failed"]
    assert failed == {"tick": 5, "cause": "killed", "error": None}
    assert result.robots[3]["alive"] is False


def test_added_robot_joins_and_takes_part(run):
    add = {"positions": [[0.3, 0.3]], "behaviors": [{"use": "beacon"}]}
    result = run(beacons(events=[{"at": 4, "add": add}]), processes=2)
    new_id = 16
    assert result.robots[new_id]["joined_at"] == 4
    sent_by_new = [rec["t"] for rec in result.trace for row in rec.get("sent", []) if row[0] == new_id]
    heard_by_new = [rec["t"] for rec in result.trace for row in rec.get("del", []) if row[2] == new_id]
    assert sent_by_new and min(sent_by_new) == 4
    assert heard_by_new and min(heard_by_new) >= 5
    assert result.reports("beacon")[new_id]["heard"] > 0
    assert result.robots[new_id]["host"] in ("h0", "h1")


def test_killing_a_host_process_fails_its_robots_and_the_run_finishes(tmp_path):
    sc = resolve_scenario(beacons(n=12, ticks=60), "<test>")
    sc["run"]["dt"] = 0.05
    run_id = new_run_id("hostkill")
    procs = []
    killed_at = {}

    def on_open(world, link):
        procs.extend(spawn_hosts(link.locators()[0], run_id, [6, 6]))

    def on_tick(world):
        if world.tick == 10 and not killed_at:
            victim = procs[0]
            victim.kill()
            killed_at["tick"] = world.tick
            killed_at["time"] = time.monotonic()

    async def main():
        return await run_world(sc, tmp_path, Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]), run_id,
                               processes=0, local_host=False, on_tick=on_tick, on_open=on_open)

    result = asyncio.run(main())
    for p in procs:
        p.join(5)
    assert result["ticks"] == 60  # the run went on to the end
    failed = {rid: r["failed"] for rid, r in result.robots.items() if r["failed"]}
    assert len(failed) == 6
    assert all(f["cause"] == "host-lost" for f in failed.values())
    assert all(f["tick"] >= killed_at["tick"] for f in failed.values())
    survivors = [rid for rid, r in result.robots.items() if r["alive"]]
    assert len(survivors) == 6
    assert all("beacon" in result.robots[r] for r in survivors)  # the survivors' reports came back
    lost_events = [e for rec in result.trace for e in rec.get("ev", []) if "host_lost" in e]
    assert len(lost_events) == 1
