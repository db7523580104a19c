"""Pinned trace hashes: the shipped lockstep scenarios and the conformance suites' lockstep cases.

A trace hash is a digest of everything that happened in a run (positions, deliveries, drops with their
cause, status changes, events). These literals are the hashes of today's model. A refactor or a speed-up
must leave every one unchanged, with one host process or several. A pin changes only in a commit whose
message names the issue and the reason (a change of the model, e.g. a new radio semantics) - never silently.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from swarmactors.runs.conformance import families
from swarmactors.runs.launcher import run

pytestmark = pytest.mark.slow

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"

# scenarios/<file>: trace hash (lockstep, the file's own seed)
SCENARIO_PINS = {
    "beacon.toml": "0c424080df0c7d8d034b58b658f4e01e",
    "biconnected-add-remove.toml": "7999bf42ad0d477e9c9492cc70f731c9",
    "biconnected-removal.toml": "454381525010a7b6644fea7a3a7ee462",
    "biconnectivity-check.toml": "336f63f143200f834e4fab2102420c15",
    "cbaa.toml": "da5540292cc58ef9571fac36f37345e6",
    "flooding.toml": "e69653011254db0fc4f743d59fa56068",  # issue 23: overheard copies
    "flooding-channel.toml": "27825d412a426fe5848a77e09a12f546",  # issue 38: a new scenario (the shared channel)
    "lambda2.toml": "a4c95f6c6a3b3fce0b233ecc21cb8ea8",  # issue 17
    "leader-follower-experiment.toml": "e703cfb26febea7a2012d5627700558e",  # issue 20
    "leader-follower.toml": "424c80217845bb0ce2d9e48db7d91b29",  # issue 20
    "leader-follower-prior.toml": "4d9a73aa5c15d1035943ac02c7c4da29",  # issue 20
    "ground-and-flying.toml": "1a475b9f3bfbd6a2db826bd055a835b2",  # issue 14
    "maze-flood.toml": "2a002ae316fc01b8af45e4682c3fbf56",  # issue 14; issue 23: overheard copies
    "roles-aat.toml": "84e75f28cd9855bc0ecee67eb2b85352",
    "roles-patrol.toml": "10ae36cee290b5991a0c819848bc70f8",  # issue 23: overheard copies
    "relays.toml": "b72128f085b5b93cae47a72661ef14a3",  # issue 43: a new scenario
    "secs-prominence.toml": "0bc067f2ad73d4a08a215790ef056a8f",  # issue 18
    "stigmergy.toml": "df9a3f0a12473e58a660537ee6ade53e",
    "biconnectivity-channel.toml": "3570cfa5486e26709c9d66ee21e6f1c3",  # issue 38: a new scenario (the shared channel)
}

# quick-suite lockstep cases of every conformance family, built-in behaviour: trace hash
CASE_PINS = {
    "biconnectivity/ring-6": "9c4d9a355ad4aeca1a5a22ab246b3e17",
    "biconnectivity/ladder-8": "f07aa491eb61f1aa579a0554b3771db7",
    "biconnectivity/comb-7": "dbd74b2bee00716bbffc3fd9823c2ce1",
    "biconnectivity/bowtie-5": "5cfb6e3c5b0c12f0811981e8180a4e34",
    "biconnectivity/two-components": "8d1be579af871e3239247ba736cb2137",
    "cbaa/line-6-tied-tasks-5": "5773f113c73226dd56f17687e6202421",
    "cbaa/line-6-tasks-4": "f9543980b59f75af9d5afed32d7f4b9d",
    "cbaa/ring-8-tasks-10": "d7b65fb83f4956c866916a7fc85d2692",
    "cbaa/rgg-15-s1-tasks-8": "a8ad0711e4580e23ed9612faf999bf7f",
    "flooding/ring-8": "2ff14385e930fb3dd40e949709064776",  # issue 23: overheard copies
    "flooding/comb-9": "532bdd3c4ca75c32959e016601df2c06",  # issue 23: overheard copies
    "flooding/rgg-20-s1": "c06a320c757b7a55d21ad5a49f9a7a87",  # issue 23: overheard copies
    "flooding/rgg-20-s1-loss-0.2": "f6c65ea77a7b26a578c0c597d924a217",  # issue 23: overheard copies
    "flooding/line-8-killed-relay": "e4647bc3132dd20e49215c474df2cbfb",  # issue 23: overheard copies
    "lambda2/ring-8": "6e73e6fb91cf5980235635b58ad834e9",  # issue 17
    "lambda2/rgg-10-s1": "0aad851e2878c9d0f98a0412066df846",  # issue 17
    "lambda2/two-rings-6": "2477edfa3dd826279e67bd4f85cf15be",  # issue 17
    "lambda2/rgg-10-s2-loss-0.1": "b271c1c74ea8329aeea0672351dcba69",  # issue 17
    "leader_follower/random-4-s1": "d1463a6987c7c1a1493ac465754a2106",  # issue 20
    "leader_follower/random-6-s6-noise-0.005": "8e6a5c2216126395948eaa3657f4aee2",  # issue 20
    "roles/patrol-10-s1": "da3bfff1040dd8dc00c8beda159ee585",  # issue 23: overheard copies
    "roles/patrol-20-s3": "8e01bb6fae88d532507e9a8cddc3f9e9",  # H6 child side: a repeater holds towards its child
    "roles/patrol-10-s2-loss-0.1": "59225d516179dde3b3b0a161e761373f",  # issue 23: overheard copies
    "secs/n5-d240-3r2": "0bc067f2ad73d4a08a215790ef056a8f",  # issue 18
    "secs/n5-d240-3r2-loss-0.1": "941c4678eace6a873d8afc4677579aa1",  # issue 18
    "stigmergy/ring-10": "e47282caa9d1d1db51f657b644fdc888",
    "stigmergy/rgg-20-s1": "7c94528d4b213934d8c10eda0f209eb7",
    "stigmergy/two-components": "70cfb08999bd23fc94d4d7f95eec164c",
    "stigmergy/rgg-20-s2-loss-0.2-anti-entropy": "3ea523cc308013f80b91cb73892e1206",
    "relays/open-10": "32f24c5853fd22b24c5078b60643ef87",  # issue 16: RVO (Eq. 8), recruiting per Sec. IV
    "relays/open-12-kill-3": "a275783d244d1cb7449503cf712cc343",  # R5: a jostled worker keeps ok (slot at 355, not 353)
}


def test_every_shipped_lockstep_scenario_is_pinned():
    lockstep = {p.name for p in SCENARIOS.glob("*.toml")
                if tomllib.loads(p.read_text()).get("run", {}).get("clock", "lockstep") == "lockstep"}
    assert lockstep == set(SCENARIO_PINS)


def test_every_quick_lockstep_case_is_pinned():
    cases = {c.name for fam in families().values() for c in fam.suite("quick")
             if c.scenario.get("run", {}).get("clock", "lockstep") == "lockstep"}
    assert cases == set(CASE_PINS)


@pytest.mark.parametrize("processes", [0, 2])
@pytest.mark.parametrize("name", sorted(SCENARIO_PINS))
def test_shipped_scenario_trace_hash_is_pinned(name, processes, shipped_run):
    """The run to the end (tests/conftest.py's ``shipped_run``: other tests judge the same run's checks)."""
    assert shipped_run(name, processes)["trace_hash"] == SCENARIO_PINS[name]


@pytest.mark.parametrize("name", sorted(SCENARIO_PINS))
def test_shipped_scenario_in_process_has_the_same_pinned_hash(name, shipped_inprocess):
    """The Simulation and two robot runtimes in one loop, no Zenoh (swarmactors/runs/inprocess.py): the same hash."""
    assert shipped_inprocess(name, 2)["trace_hash"] == SCENARIO_PINS[name]


@pytest.mark.parametrize("case_name", sorted(CASE_PINS))
def test_conformance_case_trace_hash_is_pinned(case_name, builtin_case_run):
    """The same run as the conformance fixture's (tests/conftest.py's ``builtin_case_run``), computed once."""
    family = families()[case_name.split("/")[0]]
    (case,) = [c for c in family.suite("quick") if c.name == case_name]
    result = builtin_case_run(family, case)  # K=0, then K=2 must give the same hash
    determinism = [o for o in result.outcomes if o["name"] == "determinism"]
    assert determinism and determinism[0]["passed"], determinism
    assert result.trace_hash == CASE_PINS[case_name]


# Before issue 23 excluded robots were no receivers at all; ``radio.exclude = "filter"`` keeps that rule exactly.
FILTER_PINS = {
    "flooding.toml": "0e3ad8f9bd65636fa622d3e3bbc9e90f",
    "roles-patrol.toml": "40afe03e2c9d87a774380ebf7517d834",
}


@pytest.mark.parametrize("name", sorted(FILTER_PINS))
def test_the_older_exclude_rule_gives_the_older_hashes(name, tmp_path):
    result = run(SCENARIOS / name, out=tmp_path, overrides=['radio.exclude="filter"'])
    assert result["trace_hash"] == FILTER_PINS[name]
