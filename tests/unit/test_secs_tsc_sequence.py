"""The TSC-driven SECS sequence's phase logic and its oracle, below Zenoh (protocols/secs/experiments/sequence.py).

Seed 003 §III-C: flock → erupt → rendez-vous per slot; the eruption lasts the slot's Δ plus a latency margin; a
task is covered on time when a backbone robot stays within 0.5 m of it for δ_t unbroken; the swarm stays
connected to the master at every tick.
"""

from __future__ import annotations

import math

import msgspec
import pytest

from protocols.secs import rules
from protocols.secs.experiments import sequence as sq

SEQ = {"start": [0.0, 0.0], "robots": 4, "gamma": 1.0,
       "slots": [{"deployment": [1.0, 0.0], "duration": 1.0, "tasks": [{"id": "a", "position": [2.0, 0.0]}]},
                 {"deployment": [1.0, 1.0], "duration": 2.0, "tasks": [{"id": "b", "position": [1.0, 2.0]}]}]}


def test_margin_lengthens_every_eruption_and_keeps_the_plan():
    got = sq.with_margin(SEQ, 2.0)
    assert [s["duration"] for s in got["slots"]] == [3.0, 4.0]
    assert [s["planned"] for s in got["slots"]] == [1.0, 2.0]
    assert SEQ["slots"][0]["duration"] == 1.0 and "planned" not in SEQ["slots"][0]  # the input is untouched
    for bad in (-1.0, math.nan, math.inf, "2"):
        with pytest.raises(ValueError, match="margin"):
            sq.with_margin(SEQ, bad)


@pytest.mark.parametrize(("covered", "want"), [
    ([], (0, None)), ([False, False], (0, None)), ([True], (1, 0)),
    ([True, True, False, True, True, True, False], (3, 3)), ([False, True, True, False, True], (2, 1))])
def test_longest_unbroken_cover(covered, want):
    assert sq.longest_run(covered) == want


def test_phase_times_from_the_master_log():
    stages = [[0, 1, "flocking"], [50, 1, "secs"], [350, 1, "rendezvous"], [400, 2, "flocking"], [600, 2, "secs"]]
    rows = sq.phase_times(stages, 0.1, 1000)
    assert rows[0] == {"slot": 1, "flocking": 5.0, "secs": 30.0, "rendezvous": 5.0, "erupt_start": 5.0,
                       "erupt_end": 35.0}
    assert rows[1]["flocking"] == 20.0 and rows[1]["secs"] == 40.0 and rows[1]["erupt_end"] is None  # still open
    with pytest.raises(ValueError, match="unknown stage 'dance'"):
        sq.phase_times([[0, 1, "dance"]], 0.1, 10)


def test_makespan_split_counts_flights_gathers_and_margins():
    rows = sq.phase_times([[0, 1, "flocking"], [100, 1, "secs"], [400, 1, "rendezvous"], [500, 2, "flocking"],
                           [700, 2, "secs"], [1300, 2, "rendezvous"]], 0.1, 1400)
    got = sq.makespan_split(rows, planned=60.0, margin=15.0)
    assert got["makespan"] == 130.0 and got["ratio"] == round(130 / 60, 3)
    assert got["flights"] == 30.0 and got["rendezvous"] == 10.0 and got["margins"] == 30.0  # last gather not counted
    assert sq.makespan_split(rows[:1] + [dict(rows[1], erupt_end=None)], 60.0, 15.0)["makespan"] is None


def test_the_bmu_holds_each_eruption_for_duration_plus_margin():
    """rules.bmu_next driven tick by tick with a with_margin sequence: eruption lengths are (Δ + margin) × unit."""
    seq, unit, dt = sq.with_margin(SEQ, 2.0), 10.0, 0.1
    stage, slot, since, log = "flocking", 0, 0.0, [[0, 1, "flocking"]]
    for tick in range(1, 2000):
        now = tick * dt
        gathered = stage == "flocking" and now - since > 3.0 or stage == "rendezvous" and now - since > 2.0
        nxt = rules.bmu_next(stage, slot, now - since, last=slot == 1,
                             duration=seq["slots"][slot]["duration"] * unit,
                             waited=now - since if stage == "flocking" else None, gathered=gathered, settle_max=60)
        if nxt != (stage, slot):
            (stage, slot), since = nxt, now
            log.append([tick, slot + 1, stage])
    rows = sq.phase_times(log, dt, 2000)
    assert rows[0]["secs"] == pytest.approx(30.0) and rows[1]["erupt_end"] - rows[1]["erupt_start"] == pytest.approx(40)
    assert [st for _, _, st in log] == ["flocking", "secs", "rendezvous", "flocking", "secs", "rendezvous"]


class _Result:
    """The parts of swarmactors' Result the audit reads: scenario, the master's stage log, the trace."""

    def __init__(self, schedule, stages, positions):
        self.data = {"scenario": {"run": {"dt": 0.1}, "robots": [
            {"behaviors": [{"as": "secs", "use": "secs", "schedule": schedule}]}]}}
        self.stages, self.positions = stages, positions

    def __getitem__(self, key):
        return self.data[key]

    def reports(self, name):
        return {0: {"stages": self.stages}}

    def last_tick(self):
        return len(self.positions) - 1

    def records(self):
        for t, pos in enumerate(self.positions):
            yield {"t": t, "pos": [[i, x, y] for i, (x, y) in enumerate(pos)]}


def test_audit_finds_a_cut_and_judges_the_cover_from_true_positions():
    schedule = {"robots": 3, "slots": [{"deployment": [0, 0], "duration": 1.0,
                                        "tasks": [{"id": "a", "position": [4.0, 0.0]}]}]}
    # master at 0; robot 1 relays at 2.5 m; robot 2 reaches the task (4 m) at tick 3, leaves at tick 6;
    # at tick 8 robot 1 steps out of both ranges: cut
    far = [[0, 0], [2.5, 0], [2.0, 0]]
    on = [[0, 0], [2.5, 0], [4.2, 0]]
    cut = [[0, 0], [3.5, 3.5], [2.0, 0]]
    positions = [far, far, far, on, on, on, far, on, cut, on]
    res = _Result(schedule, [[0, 1, "flocking"], [1, 1, "secs"]], positions)
    got = sq.audit(res, {"a": 0.3})
    assert (got["disconnected"], got["first_disconnected"], got["ticks"]) == (1, 8, 10)  # robot 1 cut off at tick 8
    row = got["tasks"][0]
    assert row["first_reach"] == 0.2 and row["hold"] == 0.3 and row["hold_from"] == 0.3 and row["on_time"]
    assert row["covered"] == 0.5  # ticks 3-5, 7 and 9
    assert not sq.audit(res, {"a": 0.4})["tasks"][0]["on_time"]


def test_hold_velocity_stops_at_the_task_and_walks_back_past_it():
    """rules.hold_velocity (opt-in hold_tasks): short → Lennard-Jones, within the band → still, past → to parent."""
    lj, parent = (0.1, 0.05), (2.0, math.pi)  # the parent 2 m away, behind (towards −x)
    assert rules.hold_velocity(3.0, 5.0, 0.25, parent, lj, 0.15) == lj
    assert rules.hold_velocity(4.8, 5.0, 0.25, parent, lj, 0.15) == (0.0, 0.0)
    assert rules.hold_velocity(5.25, 5.0, 0.25, parent, lj, 0.15) == (0.0, 0.0)
    vx, vy = rules.hold_velocity(5.3, 5.0, 0.25, parent, lj, 0.5)  # 0.3 m past: back at 0.3 m/s
    assert vx == pytest.approx(-0.3) and vy == pytest.approx(0.0, abs=1e-12)
    vx, _ = rules.hold_velocity(5.3, 5.0, 0.25, parent, lj, 0.15)  # capped at v_max
    assert vx == pytest.approx(-0.15)
    assert rules.hold_velocity(9.0, 5.0, 0.25, None, lj, 0.15) == (0.0, 0.0)  # no parent known: hold


def test_hold_tasks_is_opt_in_and_its_field_only_on_the_wire_when_set():
    from protocols.secs.behavior import SECS
    from protocols.secs.messages import Target

    assert SECS().hold_tasks is False
    assert SECS.validate({"hold_tasks": "yes"}) == "hold_tasks must be true or false, got 'yes'"
    assert SECS.validate({"hold_tasks": True}) is None
    plain = Target.of({"a": 1, "T": 0.5, "al": True, "d": 2.0})
    assert "r" not in msgspec.json.decode(msgspec.json.encode(plain))  # default runs: frames unchanged
    held = msgspec.json.decode(msgspec.json.encode(Target.of({"a": -1, "T": [0.5], "al": True, "d": 0.0,
                                                              "ph": 1, "p": [1.0], "r": [3.2]})))
    assert held["r"] == [3.2]
