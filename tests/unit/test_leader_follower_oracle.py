"""Leader-follower oracle (protocols/leader_follower/oracle.py) on hand-made traces: each check can fail."""

from __future__ import annotations

from protocols.leader_follower import oracle


class Made:
    """A result as the checks read it: the resolved scenario and the tick records."""

    def __init__(self, groups: list[dict], trace: list[dict], trace_commands: bool = True):
        self.data = {"scenario": {"run": {"trace_commands": trace_commands}, "robots": groups}}
        self.trace = trace

    def __getitem__(self, key):
        return self.data[key]

    def records(self):  # the checks stream the records, as Result.records() does
        return iter(self.trace)

    def ticks(self):
        return [rec["t"] for rec in self.trace]


def _groups(n: int = 2) -> list[dict]:
    lead = {"positions": [[0.0, 0.0]], "body_radius": 0.1,
            "behaviors": [{"use": "lf_leader", "as": "leader_follower", "U": 0.2}]}
    fol = [{"positions": [[0.0, 0.0]], "body_radius": 0.1, "sensing": 2.0,
            "behaviors": [{"use": "leader_follower", "as": "leader_follower", "rho1": 1.5, "rho2": 0.5,
                           "rho3": 0.2, "U": 0.3}]} for _ in range(n)]
    return [lead] + fol


def _rec(t: int, pos: dict, status: dict | None = None, cmd: list | None = None) -> dict:
    rec = {"t": t, "pos": [[i, x, y] for i, (x, y) in sorted(pos.items())]}
    if status:
        rec["status"] = status
    if cmd:
        rec["cmd"] = cmd
    return rec


START = {0: (0.0, 0.0), 1: (-1.0, 0.0), 2: (-2.0, 0.0)}  # gaps 0.9: in (ρ″, ρ′) for both followers


def test_a_chain_to_the_leader_passes_and_a_cycle_fails():
    good = Made(_groups(), [_rec(0, START, {1: {"target": 0, "mode": "track"}, 2: {"target": 1, "mode": "track"}}),
                            _rec(1, START)])
    assert oracle.spanning_tree(good).passed and oracle.assumptions(good).passed
    cyc = Made(_groups(), [_rec(0, START, {1: {"target": 2}, 2: {"target": 1}})])
    out = oracle.spanning_tree(cyc)
    assert not out.passed and "does not reach the leader" in out.detail


def test_a_pointer_beyond_the_sensing_range_is_not_an_edge():
    far = {**START, 2: (-5.0, 0.0)}
    res = Made(_groups(), [_rec(0, START, {1: {"target": 0}, 2: {"target": 1}}), _rec(1, far)])
    out = oracle.spanning_tree(res)
    assert not out.passed and "beyond rho" in out.detail and out.first_tick == 1


def test_target_distance_within_rho3_fails():
    close = {**START, 1: (-0.25, 0.0)}  # gap 0.15 < ρ‴ = 0.2
    res = Made(_groups(), [_rec(0, START, {1: {"target": 0}, 2: {"target": 1}}), _rec(1, close)])
    assert not oracle.target_distance(res).passed


def test_speed_reads_commands_and_needs_them():
    res = Made(_groups(), [_rec(0, START, {1: {"target": 0}, 2: {"target": 1}}, cmd=[[1, 0.3, 0.1]])])
    out = oracle.speed(res)
    assert not out.passed and "commanded" in out.detail
    ok = Made(_groups(), [_rec(0, START, cmd=[[1, 0.2, 0.1], [0, 0.2, 0.0]])])
    assert oracle.speed(ok).passed
    none = Made(_groups(), [_rec(0, START)], trace_commands=False)
    assert not oracle.speed(none).passed and "trace_commands" in oracle.speed(none).detail


def test_sigma_out_of_range():
    res = Made(_groups(), [_rec(0, START, {1: {"sigma": 1.2}})])
    assert not oracle.sigma(res).passed


def test_assumption_1_and_3_violations_are_found():
    crowded = {**START, 2: (-1.4, 0.0)}  # follower 2 has follower 1 within ρ″ at t = 0
    assert "Assumption 1" in oracle.assumptions(Made(_groups(), [_rec(0, crowded)])).detail
    recs = [_rec(0, START, {1: {"target": 0, "mode": "track"}, 2: {"target": 1, "mode": "track"}}),
            _rec(1, START, {1: {"target": 2, "mode": "switch"}})]  # 2 is 1's descendant
    out = oracle.assumptions(Made(_groups(), recs))
    assert not out.passed and "descendant" in out.detail and out.first_tick == 1
    both = [_rec(0, START, {1: {"target": 0, "mode": "track"}, 2: {"target": 0, "mode": "track"}}),
            _rec(1, START, {1: {"target": 2, "mode": "switch"}, 2: {"target": 1, "mode": "switch"}})]
    assert "at once" in oracle.assumptions(Made(_groups(), both)).detail


def test_guarantees_are_asserted_only_up_to_the_first_violation():
    close = {**START, 2: (-1.25, 0.0)}  # 2 is 0.15 from 1's body: inside ρ‴ of its target
    recs = [_rec(0, START, {1: {"target": 0, "mode": "track"}, 2: {"target": 1, "mode": "track"}}),
            _rec(1, START, {1: {"target": 2, "mode": "switch"}}), _rec(2, close)]
    res = Made(_groups(), recs)
    assert oracle.target_distance(res).passed and "asserted up to tick 0" in oracle.target_distance(res).detail
    assert not oracle.target_distance(res, where_assumed=False).passed
