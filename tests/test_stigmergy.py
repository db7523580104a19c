"""Virtual stigmergy and the lowest-bid election against oracles.

The oracle of a table is computed here from the write logs, independently of
``protocols.stigmergy``'s checks: for each key, among the writes by robots of
a connected component of the world's true graph, the highest timestamp, then
the conflict rule. The checks registered by the module are run as well.
"""

from __future__ import annotations

import math
import re

import networkx as nx
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from protocols.stigmergy.table import DIGEST, PUT, QUERY, Entry, Stigmergy, higher_id, lower_value
from swarmactors import Behavior, Context, Frame


# ------------------------------------------------------------------ helpers
def vs_scenario(n: int, seed: int, writes: list, *, loss: float = 0.0, clock: str = "lockstep", ticks: int = 40,
                anti_entropy: int = 0, conflict: str = "higher_id", tombstones: bool = True, positions=None,
                reads: list | None = None, connected: bool = True) -> dict:
    side = math.sqrt(n / 2.5)
    beh = {"use": "stigmergy", "writes": writes, "anti_entropy": anti_entropy, "conflict": conflict,
           "tombstones": tombstones}
    if reads:
        beh["reads"] = reads
    group = {"behaviors": [beh]}
    if positions is None:
        group.update(count=n, placement="uniform", connected=connected)
    else:
        group["positions"] = positions
    sc = {
        "run": {"name": f"vs{n}", "seed": seed, "clock": clock, "ticks": ticks},
        "radio": {"range": 1.0, "latency": 1, "loss": loss},
        "world": {"bounds": [[0.0, 0.0], [side, side]]},
        "robots": [group],
        "checks": [{"use": "stigmergy.consistent"}],
    }
    if clock == "realtime":
        sc["run"]["dt"] = 0.05
        sc["radio"].update(latency_s=0.03, latency_min_s=0.005)
    return sc


def random_writes(rng: np.random.Generator, n: int, count: int, keys: int = 4, last: int = 8) -> list[dict]:
    out = []
    for _ in range(count):
        w = {"at": int(rng.integers(1, last + 1)), "robot": int(rng.integers(0, n)), "key": f"k{rng.integers(keys)}"}
        if rng.random() < 0.2:
            w["delete"] = True
        else:
            w["value"] = int(rng.integers(0, 1000))
        out.append(w)
    return out


def expected_tables(result, rule=higher_id) -> dict[int, dict]:
    """Test-side oracle: per component of the final true graph, the winning entry of every key."""
    reports = result.reports("stigmergy")
    g = result.graph_at(result.trace[-1]["t"])
    out = {}
    for comp in nx.connected_components(g):
        writes = sorted((ts, rid, key, value) for rid in comp for _t, key, value, ts in reports[rid]["writes"])
        best: dict[str, Entry] = {}
        for ts, rid, key, value in writes:
            e, cur = Entry(value, ts, rid), best.get(str(key))
            if cur is None or ts > cur.ts:
                best[str(key)] = e
            elif ts == cur.ts:
                best[str(key)] = rule(key, cur, e)
        for rid in comp:
            out[rid] = {k: [e.value, e.ts, e.writer] for k, e in best.items()}
    return out


def assert_script_logged(result, writes: list[dict]) -> None:
    """Every scripted write that changes something appears in its robot's write log, at its tick."""
    reports = result.reports("stigmergy")
    for w in writes:
        logged = [x for x in reports[w["robot"]]["writes"] if x[0] == w["at"] and str(x[1]) == w["key"]]
        if "value" in w:
            assert any(x[2] == w["value"] for x in logged), (w, reports[w["robot"]]["writes"])


def assert_tables(result, rule=higher_id) -> None:
    want = expected_tables(result, rule)
    got = result.reports("stigmergy")
    wrong = {r: (got[r]["table"], want[r]) for r in got if got[r]["table"] != want[r]}
    assert not wrong, list(wrong.items())[:3]


# ------------------------------------------------------------------ lossless
@pytest.mark.slow
@pytest.mark.parametrize("n,seed", [(2, 1), (12, 2), (40, 3), (120, 4)])
def test_lockstep_lossless_every_robot_holds_the_oracle_entry_within_hops(run, n, seed):
    rng = np.random.default_rng(seed)
    writes = random_writes(rng, n, count=3 + n // 8)
    sc = vs_scenario(n, seed, writes)
    sc["checks"].append({"use": "stigmergy.latency"})
    result = run(sc)
    assert_script_logged(result, writes)
    assert_tables(result)
    # stated bound: the final entry of a key reaches robot r by t_write + c * hops(writer, r)
    g = result.graph_at(1)
    reports = result.reports("stigmergy")
    want = expected_tables(result)
    for rid, rep in reports.items():
        for key, (_value, ts, writer) in want[rid].items():
            t_write = next(x[0] for x in reports[writer]["writes"] if str(x[1]) == key and x[3] == ts)
            assert rep["changed_at"][key] <= t_write + nx.shortest_path_length(g, writer, rid), (rid, key)
    assert result.passed, result.checks


@pytest.mark.slow
@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(n=st.integers(2, 25), seed=st.integers(0, 10_000), count=st.integers(1, 10))
def test_lockstep_lossless_property(run, n, seed, count):
    writes = random_writes(np.random.default_rng(seed), n, count)
    result = run(vs_scenario(n, seed, writes, connected=False))  # several components as well
    assert_tables(result)
    assert result.passed, result.checks


@pytest.mark.slow
def test_realtime_lossless_converges(run):
    n, seed = 25, 5
    writes = random_writes(np.random.default_rng(seed), n, 8, last=6)
    sc = vs_scenario(n, seed, writes, clock="realtime", ticks=40)  # 2 s of 50 ms ticks; writes end by tick 6
    sc["checks"] = [{"use": "stigmergy.consistent", "within": 20}]  # stated: settled 20 ticks after the last write
    result = run(sc)
    assert_tables(result)
    assert result.passed, result.checks


# ------------------------------------------------------------------ conflicts
@pytest.mark.slow
@pytest.mark.parametrize("conflict,rule", [("higher_id", higher_id), ("lower_value", lower_value)])
def test_concurrent_equal_timestamp_writes_resolve_to_one_winner(run, conflict, rule):
    n = 30
    writers = [3, 11, 17, 26]
    writes = [{"at": 2, "robot": r, "key": "x", "value": 100 - r} for r in writers]
    result = run(vs_scenario(n, 8, writes, conflict=conflict))
    reports = result.reports("stigmergy")
    winner = 26 if conflict == "higher_id" else 26  # highest id; and lowest value (100 - 26)
    tables = {rid: rep["table"]["x"] for rid, rep in reports.items()}
    assert all(t == [100 - winner, 1, winner] for t in tables.values()), tables
    assert_tables(result, rule)
    # the losers were told their own write lost (on_conflict_lost); the winner was not
    for r in writers:
        lost = reports[r]["lost"]
        assert (lost != []) == (r != winner), (r, lost)
    assert result.passed, result.checks


@pytest.mark.slow
def test_lower_value_rule_keeps_the_lowest_value(run):
    writes = [{"at": 2, "robot": r, "key": "x", "value": v} for r, v in [(2, 5.5), (9, 1.25), (14, 9.0)]]
    result = run(vs_scenario(20, 9, writes, conflict="lower_value"))
    assert {tuple(rep["table"]["x"]) for rep in result.reports("stigmergy").values()} == {(1.25, 1, 9)}
    assert result.passed, result.checks


# ------------------------------------------------------------------ deletes
LINE = [[0.9 * i, 0.0] for i in range(8)]


@pytest.mark.slow
def test_delete_stays_deleted_with_tombstones(run):
    """The relay of the older PUT reaches the deleting robot after its delete and is ignored."""
    writes = [{"at": 1, "robot": 0, "key": "d", "value": 7}, {"at": 2, "robot": 0, "key": "d", "delete": True}]
    result = run(vs_scenario(8, 1, writes, positions=LINE, ticks=20))
    reports = result.reports("stigmergy")
    assert all(rep["table"] == {"d": [None, 2, 0]} for rep in reports.values())
    assert reports[0]["changed_at"]["d"] == 2  # never came back, not even for a tick
    assert result.passed, result.checks
    buzz = run(vs_scenario(8, 1, writes, positions=LINE, ticks=20, tombstones=False)).reports("stigmergy")
    assert buzz[0]["changed_at"]["d"] == 4  # Buzz: revived at 3 by the relay of the older PUT, nil again at 4


@pytest.mark.slow
def test_buzz_deletion_loses_a_write_after_delete(run):
    """Buzz drops a deleted entry: the next put restarts from the revived older entry and collides with the nil."""
    writes = [{"at": 1, "robot": 0, "key": "d", "value": 7}, {"at": 2, "robot": 0, "key": "d", "delete": True},
              {"at": 3, "robot": 0, "key": "d", "value": 9}]
    buzz = run(vs_scenario(8, 1, writes, positions=LINE, ticks=20, tombstones=False))
    tables = {rid: rep["table"] for rid, rep in buzz.reports("stigmergy").items()}
    assert tables[0] == {"d": [9, 2, 0]}  # same (timestamp, writer) as the nil...
    assert all(tables[r] == {"d": [None, 2, 0]} for r in range(1, 8))  # ...so the others never take it
    ours = run(vs_scenario(8, 1, writes, positions=LINE, ticks=20))
    assert all(rep["table"] == {"d": [9, 3, 0]} for rep in ours.reports("stigmergy").values())
    assert ours.passed, ours.checks


@pytest.mark.slow
def test_write_after_delete_supersedes_the_tombstone(run):
    writes = [{"at": 1, "robot": 0, "key": "d", "value": 1}, {"at": 3, "robot": 2, "key": "d", "delete": True},
              {"at": 12, "robot": 7, "key": "d", "value": 3}]
    result = run(vs_scenario(8, 1, writes, positions=LINE, ticks=30))
    assert {tuple(r["table"]["d"]) for r in result.reports("stigmergy").values()} == {(3, 3, 7)}
    assert result.passed, result.checks


# ------------------------------------------------------------------ components
@pytest.mark.slow
def test_a_robot_in_another_component_never_sees_the_writes(run):
    left = [[0.8 * i, 0.0] for i in range(5)]
    right = [[20.0 + 0.8 * i, 0.0] for i in range(5)]
    writes = [{"at": 1, "robot": 0, "key": "a", "value": "left"}, {"at": 2, "robot": 4, "key": "b", "value": 2},
              {"at": 1, "robot": 7, "key": "a", "value": "right"}]
    result = run(vs_scenario(10, 2, writes, positions=left + right, ticks=20))
    reports = result.reports("stigmergy")
    for r in range(5):
        assert reports[r]["table"] == {"a": ["left", 1, 0], "b": [2, 1, 4]}
    for r in range(5, 10):
        assert reports[r]["table"] == {"a": ["right", 1, 7]}
    assert result.passed, result.checks


# ------------------------------------------------------------------ loss and anti-entropy
@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_loss_with_anti_entropy_converges(run, seed):
    n = 40
    writes = random_writes(np.random.default_rng(seed), n, 8)
    sc = vs_scenario(n, seed, writes, loss=0.3, anti_entropy=5, ticks=60)
    sc["checks"] = [{"use": "stigmergy.consistent", "within": 50}]  # stated: within 50 ticks of the last write
    result = run(sc)
    assert result["world"]["dropped"]["loss"] > 0
    assert_tables(result)
    assert result.passed, result.checks
    digests = sum(r["sent"].get(DIGEST, 0) for r in result.reports("stigmergy").values())
    assert digests > 0


@pytest.mark.slow
def test_loss_without_anti_entropy_can_leave_robots_behind_and_anti_entropy_fixes_it(run):
    n, seed = 40, 2
    writes = random_writes(np.random.default_rng(seed), n, 8)
    plain = run(vs_scenario(n, seed, writes, loss=0.3, ticks=60))
    repaired = run(vs_scenario(n, seed, writes, loss=0.3, ticks=60, anti_entropy=5))
    assert not plain.passed  # Buzz recovers a lost PUT only at the next get/put of that key
    assert repaired.passed, repaired.checks


@pytest.mark.slow
def test_realtime_loss_with_anti_entropy_converges(run):
    n, seed = 25, 6
    writes = random_writes(np.random.default_rng(seed), n, 6, last=6)
    sc = vs_scenario(n, seed, writes, clock="realtime", loss=0.3, anti_entropy=4, ticks=50)
    sc["checks"] = [{"use": "stigmergy.consistent", "within": 40}]
    result = run(sc)
    assert_tables(result)
    assert result.passed, result.checks


# ------------------------------------------------------------------ queries
@pytest.mark.slow
def test_get_of_an_unknown_key_is_relayed_once_per_robot(run):
    n = 30
    result = run(vs_scenario(n, 4, [], reads=[{"at": 2, "robot": 5, "key": "nobody"}], ticks=30))
    reports = result.reports("stigmergy")
    assert sum(r["sent"].get(QUERY, 0) for r in reports.values()) == n  # the asker, then each other robot once
    assert all(r["table"] == {} for r in reports.values())
    assert reports[5]["reads"] == [[2, "nobody", None]]


@pytest.mark.slow
def test_get_pulls_an_entry_the_asker_missed(run):
    """A robot that joined the conversation late (all its PUTs lost) gets the key back through a query."""
    writes = [{"at": 1, "robot": 0, "key": "k", "value": 42}]
    reads = [{"at": 15, "robot": 7, "key": "k"}]
    sc = vs_scenario(8, 1, writes, positions=LINE, ticks=30, reads=reads)
    sc["events"] = [{"at": 0, "cut": [[6, 7]]}, {"at": 10, "restore": [[6, 7]]}]
    result = run(sc)
    reports = result.reports("stigmergy")
    assert reports[7]["reads"] == [[15, "k", None]]  # get answers from the local table at once
    assert reports[7]["table"] == {"k": [42, 1, 0]}  # and its query brought the entry back
    assert reports[7]["changed_at"]["k"] == 17  # query at 15 -> robot 6 answers at 16 -> stored at 17


# ------------------------------------------------------------------ bad input
class ForgeVS(Behavior):
    """Broadcasts malformed VS frames at tick 2 (used as ``test_stigmergy:ForgeVS``)."""

    name = "forge_vs"
    kinds = ("NOTHING",)

    BAD = [
        [0, "k", 1, -1, 3],  # negative timestamp
        [0, "k", 1, 1.5, 3],  # non-integer timestamp
        [0, "k", 1, True, 3],  # a boolean is not a timestamp
        [0, "k", 1, "2", 3],  # a string is not a timestamp
        [0, ["k"], 1, 2, 3],  # a list is not a key
        [0, "k", 1, 2, -4],  # negative writer
        [0, "k", 1],  # too short
        {"sid": 0},  # not a list
    ]

    def on_tick(self, ctx: Context, sensed) -> None:
        if ctx.tick == 2:
            for body in self.BAD:
                ctx.broadcast(PUT, body)
            ctx.broadcast(QUERY, [0, "k", 5, 0, 3, 0])  # a timestamp-0 query must carry nil
            ctx.broadcast(DIGEST, [0, [["k", -1, 2]]])  # a bad digest item


@pytest.mark.slow
def test_malformed_frames_are_dropped_and_counted(run):
    positions = [[0.0, 0.0], [0.5, 0.0], [1.0, 0.0]]
    sc = vs_scenario(3, 1, [{"at": 5, "robot": 0, "key": "good", "value": 1}], positions=positions, ticks=12)
    sc["robots"].append({"positions": [[0.5, 0.5]], "behaviors": [{"use": "test_stigmergy:ForgeVS"}]})
    result = run(sc)
    reports = result.reports("stigmergy")
    for rid in range(3):
        bad = reports[rid]["malformed"]
        assert sum(bad.values()) == len(ForgeVS.BAD) + 2, bad
        # the timestamp of a PUT below 1 and of a query with a value; 1.5, True, "2", ["k"], -4 and the digest item
        assert bad == {"timestamp": 2, "bad_field": 6, "bad_length": 1, "not_an_array": 1}, bad
        assert reports[rid]["table"] == {"good": [1, 1, 0]}  # nothing else got in
    assert result.passed, result.checks


# ------------------------------------------------------------------ the API, without a world
class FakeCtx:
    def __init__(self, rid: int):
        self.id, self.tick, self.now, self.clock = rid, 0, 0.0, "lockstep"
        self.out: list = []

    def broadcast(self, kind, body, exclude=()):
        self.out.append((None, kind, body))

    def send(self, dst, kind, body):
        self.out.append((dst, kind, body))


def _node(rid: int, **kw) -> tuple[Stigmergy, FakeCtx]:
    node, ctx = Stigmergy(**kw), FakeCtx(rid)
    node.attach(ctx)
    return node, ctx


def test_put_get_timestamps_and_one_message_per_key_per_tick():
    node, ctx = _node(4)
    t = node.create(0)
    t.put("a", 1)
    t.put("a", 2)  # timestamp 2, replaces the queued PUT of timestamp 1
    assert t.entry("a") == Entry(2, 2, 4)
    assert t.get("a") == 2  # a QUERY of the same age does not replace the PUT
    assert t.get("missing") is None
    node.flush(ctx)
    assert ctx.out == [(None, PUT, [0, "a", 2, 2, 4]), (None, QUERY, [0, "missing", None, 0, 4, 1])]
    t.put("a", None)
    assert t.entry("a") == Entry(None, 3, 4) and t.size() == 0


def test_put_and_query_rules():
    node, ctx = _node(1)
    t = node.create(0)
    t.put("k", "mine")  # (mine, 1, 1)
    node.flush(ctx)
    ctx.out.clear()

    def recv(kind, body, src=9):
        node.on_frame(ctx, Frame(src, kind, body, 1, 0))

    recv(PUT, [0, "k", "old", 1, 0])  # P2: conflict, higher writer keeps ours
    assert t.entry("k") == Entry("mine", 1, 1)
    recv(PUT, [0, "k", "theirs", 1, 5])  # P2: conflict, 5 wins and our own write lost
    assert t.entry("k") == Entry("theirs", 1, 5) and node.conflicts_lost == 1
    recv(PUT, [0, "k", "stale", 1, 5])  # P3: identical (ts, writer): ignored
    recv(PUT, [0, "k", "new", 3, 2])  # P1: newer
    assert t.entry("k") == Entry("new", 3, 2)
    node.flush(ctx)
    assert ctx.out == [(None, PUT, [0, "k", "new", 3, 2])]  # one message for the key, the newest
    ctx.out.clear()
    recv(QUERY, [0, "k", "older", 2, 7, 0])  # Q4: we are newer: answer
    recv(QUERY, [0, "other", None, 0, 7, 3])  # Q1: unknown key: relay once
    recv(QUERY, [0, "other", None, 0, 7, 3])  # ... and not twice
    recv(PUT, [5, "k", 1, 1, 1])  # a table this robot does not hold
    node.flush(ctx)
    assert ctx.out == [(None, PUT, [0, "k", "new", 3, 2]), (None, QUERY, [0, "other", None, 0, 7, 3])]
    assert node.foreign == 1


def test_anti_entropy_digest_rules():
    node, ctx = _node(1, anti_entropy=3)
    t = node.create(0)
    t.put("mine", 1)
    node.flush(ctx)
    ctx.out.clear()
    node.on_frame(ctx, Frame(6, DIGEST, [0, [["theirs", 2, 6], ["mine", 1, 1]]], 1, 0))
    node.flush(ctx)  # tick 0, phase 1: no digest of our own yet
    assert ctx.out == [(6, QUERY, [0, "theirs", None, 0, 1, 1])]
    ctx.out.clear()
    node.on_frame(ctx, Frame(6, DIGEST, [0, []], 2, 0))  # the sender lacks "mine": offer it
    ctx.tick = 2
    node.flush(ctx)
    assert (None, DIGEST, [0, [["mine", 1, 1]]]) in ctx.out
    assert (None, PUT, [0, "mine", 1, 1, 1]) in ctx.out


# ------------------------------------------------------------------ elections
def election_scenario(n: int, seed: int, *, clock="lockstep", loss=0.0, anti_entropy=0, ticks=80) -> dict:
    side = math.sqrt(n / 2.5)
    sc = {
        "run": {"name": "elect", "seed": seed, "clock": clock, "ticks": ticks},
        "radio": {"range": 1.0, "latency": 1, "loss": loss},
        "world": {"bounds": [[0.0, 0.0], [side, side]]},
        "robots": [{"count": n, "placement": "uniform", "connected": True, "behaviors": [
            {"use": "election", "start": 2, "duration": 20, "anti_entropy": anti_entropy, "elections": [
                {"key": "root", "target": [0.0, 0.0]},
                {"key": "worker0", "target": [side, side]},
                {"key": "worker1", "target": [0.0, side]}]}]}],
        "checks": [{"use": "stigmergy.election"}],
    }
    if clock == "realtime":
        sc["run"]["dt"] = 0.05
        sc["radio"].update(latency_s=0.03, latency_min_s=0.005)
    return sc


def expected_winners(result) -> dict[str, int]:
    """Test-side oracle: lowest (distance to target, id), one election after the other, winners excluded."""
    pos = {row[0]: np.array(row[1:]) for row in result.record(2)["pos"]}
    targets = {e["key"]: np.array(e["target"]) for e in result["scenario"]["robots"][0]["behaviors"][0]["elections"]}
    taken, out = set(), {}
    for key, target in targets.items():
        rid = min((float(np.linalg.norm(p - target)), r) for r, p in pos.items() if r not in taken)[1]
        out[key] = rid
        taken.add(rid)
    return out


@pytest.mark.slow
@pytest.mark.parametrize("n,seed", [(5, 1), (40, 2), (100, 3)])
def test_election_lowest_bid_wins_everywhere(run, n, seed):
    result = run(election_scenario(n, seed))
    want = expected_winners(result)
    reports = result.reports("election")
    assert all(rep["elected"] == want for rep in reports.values()), want
    assert all(rep["elected_at"] == {"root": 22, "worker0": 42, "worker1": 62} for rep in reports.values())
    roles = {rep["role"] for rep in reports.values()} - {"free"}
    assert roles == set(want)  # three distinct robots
    assert result.passed, result.checks


@pytest.mark.slow
def test_election_with_loss_and_anti_entropy(run):
    result = run(election_scenario(40, 4, loss=0.3, anti_entropy=3))
    assert all(rep["elected"] == expected_winners(result) for rep in result.reports("election").values())
    assert result.passed, result.checks


@pytest.mark.slow
def test_election_realtime(run):
    result = run(election_scenario(30, 5, clock="realtime"))
    assert all(rep["elected"] == expected_winners(result) for rep in result.reports("election").values())
    assert result.passed, result.checks


# ------------------------------------------------------------------ scenario errors
@pytest.mark.parametrize("beh,needle", [
    ({"use": "stigmergy", "writes": [{"at": 1, "robot": 0, "key": "a"}]}, "exactly one of value or delete"),
    ({"use": "stigmergy", "writes": [{"at": -1, "robot": 0, "key": "a", "value": 1}]}, "writes[0].at"),
    ({"use": "stigmergy", "writes": [{"at": 1, "robot": 0, "key": [1], "value": 1}]}, "writes[0].key"),
    ({"use": "stigmergy", "conflict": "nope"}, "conflict"),
    ({"use": "stigmergy", "anti_entropy": -2}, "anti_entropy"),
    ({"use": "election", "elections": []}, "elections"),
    ({"use": "election", "elections": [{"key": "r", "target": [0, "x"]}]}, "elections[0].target"),
])
def test_bad_parameters_are_scenario_errors(beh, needle):
    from swarmactors.runs.scenario import ScenarioError, resolve_scenario

    with pytest.raises(ScenarioError, match=re.escape(needle)):
        resolve_scenario({"run": {"ticks": 3}, "robots": [{"count": 2, "behaviors": [beh]}]}, "t.toml")
