"""Message-expiration flooding against the oracle (networkx BFS on the world's true graph)."""

from __future__ import annotations

import math

import networkx as nx
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytestmark = pytest.mark.slow  # every test runs scenarios over Zenoh


def flood_scenario(n: int, seed: int, expiry=4, hops=None, loss=0.0, clock="lockstep", ticks=None) -> dict:
    side = math.sqrt(n / 2.5)  # about 3-4 neighbours in range 1 on average: sparse, multi-hop graphs
    beh = {"use": "flooding", "origin": 0, "at": 1, "expiry": expiry}
    if hops is not None:
        beh["hops"] = hops
    return {
        "run": {"name": f"flood{n}", "seed": seed, "clock": clock, "ticks": ticks or (expiry or 6) + 4},
        "radio": {"range": 1.0, "latency": 1, "loss": loss},
        "world": {"bounds": [[0.0, 0.0], [side, side]]},
        "robots": [{"count": n, "placement": "uniform", "behaviors": [beh]}],
        "checks": [{"use": "flooding.reach"}, {"use": "flooding.forwarding"}] if loss == 0 and clock == "lockstep"
        else [{"use": "flooding.delivered"}, {"use": "flooding.forwarding"}],
    }


def receivers(result) -> dict[int, dict]:
    return {rid: next(iter(r["received"].values())) for rid, r in result.reports("flooding").items() if r["received"]}


def assert_exact_flood(result, expiry: int) -> None:
    """Every robot within `expiry` hops receives once with hop = BFS distance; nobody farther."""
    g = result.graph_at(1)  # robots are static: the graph at origination is the graph
    dist = nx.single_source_shortest_path_length(g, 0, cutoff=expiry)
    got = receivers(result)
    assert set(got) == set(dist)
    for rid, entry in got.items():
        assert entry["hop"] == dist[rid], rid
        assert entry["tick"] == 1 + dist[rid], rid
    reports = result.reports("flooding")
    for rid in got:
        assert reports[rid]["forwarded"] == 1, rid  # forwarded exactly once
        assert reports[rid]["duplicates"] >= 0
    assert all(c["passed"] for c in result.checks), result.checks


@pytest.mark.parametrize("n,seed", [(5, 1), (5, 2), (20, 3), (20, 4), (60, 5), (60, 6), (200, 7), (200, 8)])
def test_lockstep_lossless_reaches_exactly_the_bfs_ball(run, n, seed):
    result = run(flood_scenario(n, seed, expiry=4))
    assert_exact_flood(result, 4)


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(n=st.integers(2, 40), seed=st.integers(0, 10_000), expiry=st.integers(0, 6))
def test_lockstep_lossless_property(run, n, seed, expiry):
    result = run(flood_scenario(n, seed, expiry=expiry))
    assert_exact_flood(result, expiry)


def test_forward_excludes_the_sender(run):
    result = run(flood_scenario(40, 11, expiry=6))
    got = receivers(result)
    sent = {(row[0], row[1]): rec["t"] for rec in result.trace for row in rec.get("sent", []) if row[2] == "FLOOD"}
    for rec in result.trace:
        for src, seq, dst, _ in rec.get("del", []):
            if (src, seq) in sent and src in got and got[src]["from"] is not None:
                assert dst != got[src]["from"], (src, dst)
    assert result.check("flooding.not_to_sender")["passed"]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_lockstep_with_loss_receivers_match_recorded_deliveries(run, seed):
    expiry = 5
    result = run(flood_scenario(60, seed, expiry=expiry, loss=0.3))
    assert result["world"]["dropped"]["loss"] > 0
    # Oracle: BFS over the FLOOD deliveries recorded in the trace, arriving by the deadline.
    kinds = {(row[0], row[1]): row[2] for rec in result.trace for row in rec.get("sent", [])}
    dg = nx.DiGraph()
    dg.add_node(0)
    for rec in result.trace:
        if rec["t"] > 1 + expiry:
            continue
        for src, seq, dst, _ in rec.get("del", []):
            if kinds[(src, seq)] == "FLOOD":
                dg.add_edge(src, dst)
    reachable = set(nx.descendants(dg, 0)) | {0}
    assert set(receivers(result)) == reachable
    # and a lossless run of the same placement reaches at least as many
    lossless = run(flood_scenario(60, seed, expiry=expiry))
    assert reachable <= set(receivers(lossless))
    assert result.passed, result.checks


def test_hop_limit(run):
    result = run(flood_scenario(80, 21, expiry=None, hops=2, ticks=10))
    g = result.graph_at(1)
    dist = nx.single_source_shortest_path_length(g, 0, cutoff=2)
    got = receivers(result)
    assert set(got) == set(dist)
    assert all(got[r]["hop"] == dist[r] for r in got)
    reports = result.reports("flooding")
    assert all(reports[r]["forwarded"] == (1 if dist[r] < 2 else 0) for r in got)


@pytest.mark.parametrize("seed", [1, 2])
def test_realtime_reaches_the_component(run, seed):
    sc = flood_scenario(25, seed, expiry=3.0, clock="realtime", ticks=30)
    sc["run"]["dt"] = 0.05
    sc["radio"].update({"latency_s": 0.02, "latency_min_s": 0.01})
    sc["checks"] = [{"use": "flooding.component"}]
    result = run(sc)
    g = result.graph_at(min(rec["t"] for rec in result.trace if rec["t"] >= 1))
    dist = nx.single_source_shortest_path_length(g, 0)
    got = receivers(result)
    assert set(got) == set(dist)
    assert all(got[r]["hop"] >= dist[r] for r in got)
    assert all(r["duplicates"] >= 0 for r in result.reports("flooding").values())
    assert result.check("flooding.component")["passed"]


@pytest.mark.parametrize("seed", [1, 2])
def test_remaining_lifetime_reaches_exactly_the_bfs_ball_whatever_the_clocks(run, seed):
    """F1r: with robots' clocks off by up to 8 s and 10 % drift, the receivers are still the ⌊expiry⌋-hop ball."""
    sc = flood_scenario(20, seed)
    sc["robots"][0]["behaviors"][0]["lifetime"] = "remaining"
    sc["robots"][0].update(clock_offset=[-8.0, 8.0], clock_drift=[-1e5, 1e5])
    result = run(sc)
    assert result.passed, result.checks
