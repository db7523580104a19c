"""CBAA against oracles: the sequential greedy assignment, N_min * D rounds, the optimum.

The test-side oracle recomputes the scores from the world's true positions,
the greedy assignment by brute force over the score matrix, the diameter with
networkx and the optimum with scipy's linear_sum_assignment; the checks the
module registers are run too.
"""

from __future__ import annotations

import math

import networkx as nx
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.optimize import linear_sum_assignment

from protocols.cbaa.rules import KIND, LEAVE, RESET, UPDATE, decide
from swarmactors import Behavior, Context

CHECKS = [{"use": "cbaa.conflict_free"}, {"use": "cbaa.greedy"}, {"use": "cbaa.optimality"}]


def cbaa_scenario(n: int, m: int, seed: int, *, clock="lockstep", loss=0.0, ticks=None, consensus="auto",
                  density=2.5, positions=None, tasks=None, scores=None) -> dict:
    rng = np.random.default_rng([seed, 77])
    side = math.sqrt(n / density)
    if tasks is None:
        tasks = np.round(rng.random((m, 2)) * side, 3).tolist()
    beh = {"use": "cbaa", "tasks": tasks, "at": 1, "consensus": consensus}
    if scores is not None:
        beh["scores"] = scores
    group = {"behaviors": [beh]}
    if positions is None:
        group.update(count=n, placement="uniform", connected=True)
    else:
        group["positions"] = positions
    sc = {
        "run": {"name": f"cbaa{n}x{m}", "seed": seed, "clock": clock, "ticks": ticks or 60},
        "radio": {"range": 1.0, "latency": 1, "loss": loss},
        "world": {"bounds": [[0.0, 0.0], [side, side]]},
        "robots": [group],
        "checks": CHECKS + ([{"use": "cbaa.rounds"}] if clock == "lockstep" and loss == 0 else []),
    }
    if clock == "realtime":
        sc["run"]["dt"] = 0.05
        sc["radio"].update(latency_s=0.03, latency_min_s=0.002)
    return sc


def true_scores(result) -> np.ndarray:
    """c_ij = 1 / (1 + d_ij) (the default score) from the positions at the start tick."""
    tasks = np.array(result["scenario"]["robots"][0]["behaviors"][0]["tasks"], dtype=float)
    robots = result.reports("cbaa")
    rows = sorted(r for r in result.record(1)["pos"] if r[0] in robots)
    pos = np.array([r[1:] for r in rows])
    d = np.linalg.norm(pos[:, None, :] - tasks[None, :, :], axis=2)
    return 1.0 / (1.0 + d)


def brute_greedy(c: np.ndarray) -> dict[int, int]:
    """Robot -> task: take the largest remaining score (ties: lower robot, then lower task) until none is left."""
    c = c.astype(float).copy()
    out: dict[int, int] = {}
    while c.size and np.max(c) > 0:
        best = np.max(c)
        i, j = min(zip(*np.nonzero(c == best), strict=True))
        out[int(i)] = int(j)
        c[i, :] = 0.0
        c[:, j] = 0.0
    return out


def assert_greedy(result, c: np.ndarray | None = None) -> None:
    reports = result.reports("cbaa")
    c = true_scores(result) if c is None else c
    want = brute_greedy(c)
    got = {rid: rep["task"] for rid, rep in reports.items() if rep["task"] is not None}
    assert got == want
    held = [rep["task"] for rep in reports.values() if rep["task"] is not None]
    assert len(held) == len(set(held))  # conflict-free: one robot per task, one task per robot
    winners = [None] * c.shape[1]
    for i, j in want.items():
        winners[j] = i
    assert all(rep["winners"] == winners for rep in reports.values())  # everyone agrees
    total = sum(c[i, j] for i, j in want.items())
    rows, cols = linear_sum_assignment(c, maximize=True)
    assert total >= 0.5 * c[rows, cols].sum() - 1e-12


def assert_rounds(result) -> None:
    reports = result.reports("cbaa")
    g = result.graph_at(1)
    bound = min(len(reports), len(result["scenario"]["robots"][0]["behaviors"][0]["tasks"])) * nx.diameter(g)
    last = max(rep["changed_at"] for rep in reports.values())
    assert last - 1 <= bound, (last - 1, bound)


# ------------------------------------------------------------------ lockstep, static, no loss
@pytest.mark.slow
@pytest.mark.parametrize("n,m,seed", [(1, 3, 1), (6, 3, 2), (10, 10, 3), (20, 35, 4), (40, 12, 5), (80, 80, 6)])
def test_lockstep_equals_sequential_greedy_within_nmin_d_rounds(run, n, m, seed):
    result = run(cbaa_scenario(n, m, seed))
    assert_greedy(result)
    assert_rounds(result)
    assert result.passed, result.checks


@pytest.mark.slow
def test_long_line_many_rounds(run):
    """A line has a large diameter: the N_min * D bound is exercised with many hops."""
    n = 15
    positions = [[0.9 * i, 0.0] for i in range(n)]
    tasks = [[0.9 * (n - 1) + 0.3, 0.2], [0.1, 0.5], [6.0, 1.0], [2.0, -0.5], [12.5, 0.0], [3.0, 0.0]]
    result = run(cbaa_scenario(n, len(tasks), 3, positions=positions, tasks=tasks))
    assert_greedy(result)
    assert_rounds(result)
    assert result.passed, result.checks


@pytest.mark.slow
@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(n=st.integers(1, 25), m=st.integers(1, 25), seed=st.integers(0, 10_000))
def test_lockstep_property(run, n, m, seed):
    result = run(cbaa_scenario(n, m, seed, ticks=40))
    assert_greedy(result)
    assert_rounds(result)
    assert result.passed, result.checks


@pytest.mark.slow
def test_table_consensus_in_lockstep_also_reaches_greedy(run):
    result = run(cbaa_scenario(30, 20, 7, consensus="table"))
    assert {rep["mode"] for rep in result.reports("cbaa").values()} == {"table"}
    assert_greedy(result)
    assert result.passed, result.checks


@pytest.mark.slow
def test_equal_bids_go_to_the_lower_robot_id(run):
    positions = [[0.0, 0.0], [0.5, 0.0], [1.0, 0.0], [1.5, 0.0]]
    scores = [[1.0, 2.0, 0.5], [2.0, 2.0, 0.5], [2.0, 1.0, 0.0], [0.0, 0.0, 0.4]]
    result = run(cbaa_scenario(4, 3, 1, positions=positions, tasks=[[0, 0], [1, 1], [2, 2]], scores=scores))
    tasks = {rid: rep["task"] for rid, rep in result.reports("cbaa").items()}
    # greedy: 2.0 ties at (0,1), (1,0), (1,1), (2,0) -> robot 0 takes task 1 (its best), robot 1 task 0,
    # then robot 3 gets task 2 (0.4 is all it has; robot 2's 0.0 is no bid)
    assert tasks == {0: 1, 1: 0, 2: None, 3: 2}
    assert_greedy(result, np.array(scores))
    assert result.check("cbaa.greedy")["passed"]


@pytest.mark.slow
def test_disconnected_components_allocate_independently(run):
    left = [[0.8 * i, 0.0] for i in range(4)]
    right = [[20.0 + 0.8 * i, 0.0] for i in range(3)]
    tasks = [[1.0, 0.5], [21.0, 0.5], [10.0, 0.0]]
    result = run(cbaa_scenario(7, 3, 1, positions=left + right, tasks=tasks))
    reports = result.reports("cbaa")
    left_tasks = sorted(reports[r]["task"] for r in range(4) if reports[r]["task"] is not None)
    right_tasks = sorted(reports[r]["task"] for r in range(4, 7) if reports[r]["task"] is not None)
    assert left_tasks == [0, 1, 2] and right_tasks == [0, 1, 2]  # each component covers every task
    assert result.passed, result.checks


# ------------------------------------------------------------------ loss and realtime
@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2])
def test_lockstep_with_loss_still_reaches_greedy(run, seed):
    result = run(cbaa_scenario(30, 15, seed, loss=0.1))
    assert result["world"]["dropped"]["loss"] > 0
    assert_greedy(result)
    assert result.passed, result.checks


@pytest.mark.slow
@pytest.mark.parametrize("seed,m", [(1, 10), (2, 25)])
def test_realtime_with_jitter_and_loss_reaches_greedy(run, seed, m):
    """Stated time: settled within 2 s (40 ticks of 50 ms; measured 0.3-0.8 s), frames every tick, loss 0.1."""
    result = run(cbaa_scenario(20, m, seed, clock="realtime", loss=0.1))
    reports = result.reports("cbaa")
    assert {rep["mode"] for rep in reports.values()} == {"table"}
    assert result["world"]["dropped"]["loss"] > 0
    assert_greedy(result)
    assert max(rep["changed_time"] for rep in reports.values()) < 2.0
    assert result.passed, result.checks


# ------------------------------------------------------------------ bad input
class ForgeBids(Behavior):
    """Broadcasts malformed BID frames every tick from 2 to 5 (``test_cbaa:ForgeBids``)."""

    name = "forge_bids"
    kinds = ("NOTHING",)

    def __init__(self, m: int = 3):
        self.m = m

    def on_tick(self, ctx: Context, sensed) -> None:
        if 2 <= ctx.tick <= 5:
            big = [9.0] * self.m
            me = [ctx.id] * self.m
            ctx.broadcast(KIND, {"t": self.m + 4, "y": big, "z": me})  # a bid for a task that does not exist
            ctx.broadcast(KIND, {"t": None, "y": big + [9.0], "z": me + [ctx.id]})  # a table too long
            ctx.broadcast(KIND, {"t": None, "y": big[:-1], "z": me[:-1]})  # a table too short
            ctx.broadcast(KIND, {"t": 0, "y": [-1.0] * self.m, "z": me})  # negative bids
            ctx.broadcast(KIND, [1, 2, 3])  # not a bid at all


@pytest.mark.slow
def test_malformed_bids_are_dropped_and_counted(run):
    positions = [[0.0, 0.0], [0.6, 0.0], [1.2, 0.0]]
    tasks = [[0.0, 0.5], [1.2, 0.5], [3.0, 0.0]]
    sc = cbaa_scenario(3, 3, 1, positions=positions, tasks=tasks, ticks=20)
    sc["robots"].append({"positions": [[0.6, 0.4]], "behaviors": [{"use": "test_cbaa:ForgeBids", "m": 3}]})
    result = run(sc)
    reports = result.reports("cbaa")
    for rep in reports.values():
        assert rep["dropped"] == {"unknown_task": 4, "wrong_length": 8, "bad_field": 4, "not_a_map": 4}, rep["dropped"]
        assert 3 not in rep["winners"]  # the forger never became a winner
    assert result.passed, result.checks  # the greedy assignment of the three real robots


# ------------------------------------------------------------------ the T1 table
def test_table_rules():
    s_i, s_k = {5: 1.0, 6: 3.0}, {5: 2.0, 6: 1.0}  # k newer on 5, i newer on 6
    i, k = 0, 1
    assert decide(i, k, 3.0, k, 2.0, i, s_i, s_k) == UPDATE  # k wins with a higher bid
    assert decide(i, k, 1.0, k, 2.0, i, s_i, s_k) == LEAVE
    assert decide(i, k, 1.0, k, 2.0, 6, s_i, s_k) == LEAVE  # i is newer on 6 and 6 bids higher
    assert decide(i, k, 1.0, k, 2.0, 5, s_i, s_k) == UPDATE  # k is newer on 5
    assert decide(i, k, 2.0, i, 2.0, k, s_i, s_k) == RESET  # each thinks the other wins
    assert decide(i, k, 2.0, i, 2.0, 5, s_i, s_k) == RESET
    assert decide(i, k, 2.0, i, 2.0, 6, s_i, s_k) == LEAVE
    assert decide(i, k, 2.0, 5, 1.0, k, s_i, s_k) == UPDATE
    assert decide(i, k, 2.0, 6, 1.0, k, s_i, s_k) == RESET
    assert decide(i, k, 3.0, 5, 2.0, i, s_i, s_k) == UPDATE  # newer on 5 and higher
    assert decide(i, k, 3.0, 6, 2.0, i, s_i, s_k) == LEAVE  # higher, but stale on 6
    assert decide(i, k, 2.0, 5, 3.0, 6, s_i, s_k) == LEAVE  # newer on 5, lower, stale on 6
    assert decide(i, k, 2.0, 6, 3.0, 5, s_i, s_k) == RESET  # newer on 5 (i's winner), stale on 6
    assert decide(i, k, 0.0, None, 2.0, 5, s_i, s_k) == UPDATE
    assert decide(i, k, 0.0, None, 2.0, 6, s_i, s_k) == LEAVE
    assert decide(i, k, 0.0, None, 2.0, k, s_i, s_k) == UPDATE
    assert decide(i, k, 0.0, None, 2.0, i, s_i, s_k) == LEAVE


@pytest.mark.parametrize("beh,needle", [
    ({"use": "cbaa", "tasks": []}, "tasks"),
    ({"use": "cbaa", "tasks": [[0, 0]], "scores": [[1, 2]]}, "scores"),
    ({"use": "cbaa", "tasks": [[0, 0]], "consensus": "x"}, "consensus"),
    ({"use": "cbaa", "tasks": [[0, 0]], "score": "far"}, "score"),
    ({"use": "cbaa"}, "tasks"),
])
def test_bad_parameters_are_scenario_errors(beh, needle):
    from swarmactors.runs.scenario import ScenarioError, resolve_scenario

    with pytest.raises(ScenarioError, match=needle):
        resolve_scenario({"run": {"ticks": 3}, "robots": [{"count": 2, "behaviors": [beh]}]}, "t.toml")
