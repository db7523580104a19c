"""Biconnectivity options beyond the paper (issue 23): repeated fills (R13) and the structure graph (R14).

Also the removal leader's ex-neighbours, taken among the structure neighbours only (R12 with regions).

Lockstep emulator runs against the oracle (networkx on positions).
"""

from __future__ import annotations

import math

import pytest

from protocols.biconnectivity.behavior import Biconnectivity
from protocols.biconnectivity.oracle import expected_counts

S = 0.9


def ring(n: int, side: float = S) -> list[list[float]]:
    radius = side / (2 * math.sin(math.pi / n))
    return [[radius * math.cos(2 * math.pi * i / n), radius * math.sin(2 * math.pi * i / n)] for i in range(n)]


def check_scenario(positions, rng=1.0, ticks=None, **params) -> dict:
    n = max(len(positions), 3)
    beh = {"use": "biconnectivity", "N": n, "c": 1, "initiator": 0, "at": 1, "hello": 0} | params
    return {"run": {"name": "bic-opt", "seed": 1, "ticks": ticks or 6 * n + 12},
            "radio": {"range": rng, "latency": 1},
            "robots": [{"positions": positions, "behaviors": [beh]}]}


def test_validate_new_options():
    assert Biconnectivity.validate({"repeat": 0})
    assert Biconnectivity.validate({"graph": "mesh"})
    assert Biconnectivity.validate({"repeat": 2, "graph": "structure"}) is None
    assert Biconnectivity.validate({"agree": 0}) and Biconnectivity.validate({"agree": 2, "max_periods": 1})


@pytest.mark.slow
def test_repeated_fills_send_every_path_twice_and_keep_the_verdict(run):
    """With repeat = 2 each robot sends and relays twice the simple-path counts; lists and verdict unchanged."""
    import networkx as nx

    pos = ring(6)
    res1 = run(check_scenario(pos))
    res2 = run(check_scenario(pos, repeat=2))
    g = res1.graph_at(0)
    assert nx.is_biconnected(g)
    exp = expected_counts(g)
    for rid, rep in res2.reports("biconnectivity").items():
        (per,) = rep["periods"].values()
        assert per["sent"]["CR"] == 2 * exp[rid]["sent"] and per["relayed"]["DCR"] == 2 * exp[rid]["relayed"]
        assert rep["cr"] == res1.reports("biconnectivity")[rid]["cr"]
        assert rep["dcr"] == res1.reports("biconnectivity")[rid]["dcr"]
    assert res2.reports("biconnectivity")[0]["biconnected"] is True


@pytest.mark.slow
def test_structure_graph_judges_the_regions_not_the_radio(run):
    """Regions in a line, radio range 2: the radio graph is biconnected, the structure graph is a path.

    Diameter 1, centres 1 apart: each robot hears the next two, while the structure graph (centres within
    range - 2·region = 1) is a path. HELLOs (every 2 ticks) give the positions the filter needs before tick 8.
    """
    pos = [[float(i), 0.0] for i in range(4)]
    common = {"region": 0.5, "hello": 2, "silence": 50, "at": 8}
    radio = run(check_scenario(pos, rng=2.0, ticks=60, **common))
    struct = run(check_scenario(pos, rng=2.0, ticks=60, graph="structure", **common))
    assert radio.reports("biconnectivity")[0]["biconnected"] is True
    rep = struct.reports("biconnectivity")[0]
    assert rep["biconnected"] is False and rep["cr"] == [1, 2, 3] and rep["dcr"] == []
    assert rep["other_received"]["not-structure-neighbour"] > 0


@pytest.mark.slow
def test_removal_leader_and_d_from_structure_neighbours_only(run):
    """Hexagon of regions, radio range 2: the removed robot's structure neighbours lead and move, not all it heard.

    Diameter 1, centres 1 apart: every robot hears all the others. Killing robot 3: its structure neighbours
    are 2 and 4 (the radio ones are everybody), so robot 2 leads and computes d for {2, 4}, not robot 0 for
    the five survivors.
    """
    pos = ring(6, side=1.0)
    beh = {"use": "biconnectivity", "N": 6, "c": 1, "hello": 2, "silence": 6, "region": 0.5, "speed": 0.1,
           "graph": "structure"}
    sc = {"run": {"name": "bic-rm", "seed": 1, "ticks": 120}, "radio": {"range": 2.0, "latency": 1},
          "robots": [{"positions": pos, "speed": 0.2, "behaviors": [beh]}],
          "events": [{"at": 10, "kill": [3]}]}
    reps = run(sc).reports("biconnectivity")
    leaders = {rid: rep["removals"] for rid, rep in reps.items() if rep["removals"]}
    assert list(leaders) == [2]
    (lead,) = leaders[2]
    assert lead["neighbours"] == [2, 4] and lead["removed"] == 3
    # 2 and 4 sit sqrt(3) apart, 1 from robot 3's centre: an edge (<= 0.98) needs d >= 1 - 0.98/sqrt(3) = 0.434
    assert 0.43 <= lead["d"][0] <= 0.45 and lead["verdict"] is True


@pytest.mark.slow
@pytest.mark.parametrize("positions, truth", [(ring(6), True), ([[S * i, 0.0] for i in range(4)], False)])
def test_agreeing_periods_lossless_two_periods_same_verdicts_checks_pass(run, positions, truth):
    """R15 (agree = 2) without loss: every check-running robot decides after two periods, as the paper would."""
    sc = check_scenario(positions, ticks=4 * (6 * max(len(positions), 3) + 2) + 8, agree=2)
    sc["checks"] = [{"use": "biconnectivity.lists"}, {"use": "biconnectivity.verdict"},
                    {"use": "biconnectivity.paths"}]
    res = run(sc)
    assert res.passed, res.checks
    checks = [ck for rep in res.reports("biconnectivity").values() for ck in rep["checks"]]
    assert len(checks) >= 2
    for ck in checks:
        assert ck["verdict"] is truth and len(ck["rounds"]) == 2 and ck["rounds"][0][1] is truth
