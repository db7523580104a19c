"""Situated sensing, robot clocks and bursty loss, end to end (issue 15).

* a local-sensing robot follows and aligns with a neighbour using only ``frame.rab`` and sensed bearings,
  although its heading offset is unknown to it: its own frame is not the world's;
* flooding with skewed clocks: ``flooding.component`` holds while the receivers' clock offset stays below the
  expiry margin and fails beyond it, losing exactly the robot whose local arrival time passes the deadline;
* the same trace hash with 1 and 3 host processes under each new key (local sensing with noise, surface
  sensing and frame.rab; clock offset and drift; Gilbert-Elliott bursts);
* bad input (negative noise, drift beyond 1e5 ppm, p_gb outside [0, 1], a behaviour that does not support
  local sensing): ``swarmactors run`` exits 2 naming the key or the behaviour, before anything starts.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import run_scenario

GAP = 0.3


def align_scenario(offset=None) -> dict:
    follower = {"positions": [[1.0, -0.5]], "sensing_frame": "local", "range_noise": 0.01, "bearing_noise": 0.02,
                "behaviors": [{"use": "situated_behaviors:Align", "gap": GAP}]}
    if offset is not None:
        follower["heading_offset"] = offset
    return {"run": {"name": "align", "seed": 3, "ticks": 60}, "radio": {"range": 2.0},
            "robots": [{"positions": [[0.0, 0.0]], "behaviors": [{"use": "situated_behaviors:Lead"}]}, follower]}


@pytest.mark.slow
@pytest.mark.parametrize("offset", [None, 2.5])
def test_local_sensing_aligns_with_a_neighbour(tmp_path, offset):
    result = run_scenario(align_scenario(offset), tmp_path)
    lead, follower = result["robots"]["0"]["pose"], result["robots"]["1"]["pose"]
    rep = result.reports("align")[1]
    # it aligned: same heading as the lead, at about the gap behind it (P control lags by v / gain)
    assert abs(math.remainder(follower[2] - lead[2], 2 * math.pi)) < 0.1, (lead, follower)
    dist = math.dist(lead[:2], follower[:2])
    assert GAP < dist < GAP + 0.2
    # its pose is its odometry: it starts at its own origin
    assert rep["first_pose"][:2] == [0.0, 0.0]
    # what it sensed is the truth of that tick (range) and of the send tick (frame.rab), within the noise
    pos = {rec["t"]: {row[0]: row[1:] for row in rec["pos"]} for rec in result.trace}
    assert len(rep["log"]) > 50
    for tick, r_sensed, _, r_frame, _ in rep["log"]:
        assert abs(r_sensed - math.dist(pos[tick][0], pos[tick][1])) < 5 * 0.01
        assert abs(r_frame - math.dist(pos[tick - 1][0], pos[tick - 1][1])) < 5 * 0.01
    # once aligned, it sees the lead straight ahead
    late = np.array([row[2] for row in rep["log"][-20:]])
    assert np.abs(late).max() < 5 * 0.02 + 0.05


def flood_with_skew(offset: float) -> dict:
    """A flood on a line of 6 robots whose receivers' clocks run ``offset`` seconds ahead of the originator's.

    Hops 1..5, flood at tick 1 with expiry 7: the last arrival (tick 6) is 2 ticks before the deadline (tick 8
    of the originator's clock), so the expiry margin is 2 ticks (dt = 1 s); the drift is small (+-1000 ppm).
    """
    flood = [{"use": "flooding", "origin": 0, "at": 1, "expiry": 7}]
    return {"run": {"name": "skew", "seed": 1, "ticks": 10},
            "robots": [{"positions": [[0.0, 0.0]], "behaviors": flood},
                       {"count": 5, "placement": "line", "spacing": 0.9, "area": [[0.9, 0.0], [5.0, 0.0]],
                        "clock_offset": offset, "clock_drift": [-1000.0, 1000.0], "behaviors": flood}],
            "checks": [{"use": "flooding.component"}]}


@pytest.mark.slow
def test_flooding_component_holds_below_the_expiry_margin_and_fails_beyond(tmp_path):
    below = run_scenario(flood_with_skew(1.5), tmp_path / "below")
    (check,) = below.checks
    assert check["name"] == "flooding.component" and check["passed"], check
    beyond = run_scenario(flood_with_skew(2.5), tmp_path / "beyond")
    (check,) = beyond.checks
    assert not check["passed"] and "missing [5]" in check["detail"], check
    assert beyond.reports("flooding")[5]["expired"] >= 1


HASH_CASES = {
    "local-sensing": ({"sensing_frame": "local", "range_noise": 0.02, "bearing_noise": 0.05,
                       "sensing_to": "surface", "body_radius": 0.05}, {}),
    "clock-skew": ({"clock_offset": [-2.0, 2.0], "clock_drift": [-5e4, 5e4]}, {"rab": True}),
    "bursts": ({}, {"loss_model": "gilbert", "p_gb": 0.2, "p_bg": 0.3, "loss_good": 0.05, "loss_bad": 0.9}),
}


@pytest.mark.slow
@pytest.mark.parametrize("case", sorted(HASH_CASES))
def test_same_trace_hash_with_1_and_3_host_processes(tmp_path, case):
    group, radio = HASH_CASES[case]
    raw = {"run": {"name": case, "seed": 5, "ticks": 25}, "radio": {"range": 1.2, **radio},
           "robots": [{"count": 9, "placement": "grid", "spacing": 0.6, **group,
                       "behaviors": [{"use": "situated_behaviors:Wander", "every": 1.5}]}]}
    one = run_scenario(raw, tmp_path / "k1", processes=1)
    three = run_scenario(raw, tmp_path / "k3", processes=3)
    assert one["trace_hash"] == three["trace_hash"]
    reports = one.reports("wander")
    heard = [h for r in reports.values() for h in r["heard"]]
    assert heard
    if case == "local-sensing" or radio.get("rab"):
        assert all(h[2] is not None for h in heard)
    else:
        assert all(h[2] is None for h in heard)
    if case == "clock-skew":  # the robots' clocks differ from the world's tick
        assert any(abs(r["nows"][-1] - 24) > 0.5 for r in reports.values())
    if case == "bursts":
        assert one["world"]["dropped"].get("loss", 0) > 0


@pytest.mark.slow
@pytest.mark.parametrize("processes", [0, 2])
def test_realtime_frames_carry_their_range_and_bearing(tmp_path, processes):
    """Realtime with ``radio.rab``: every frame handed over carries (range, bearing) within the radio's range."""
    raw = {"run": {"name": "rt-rab", "seed": 5, "ticks": 20, "clock": "realtime", "dt": 0.05},
           "radio": {"range": 1.2, "rab": True},
           "robots": [{"count": 9, "placement": "grid", "spacing": 0.6,
                       "behaviors": [{"use": "situated_behaviors:Wander", "every": 0.1}]}]}
    result = run_scenario(raw, tmp_path / f"k{processes}", processes=processes)
    heard = [h for r in result.reports("wander").values() for h in r["heard"]]
    assert len(heard) >= 50, len(heard)
    assert all(h[2] is not None and 0.0 < h[2][0] <= 1.2 + 1e-9 and -math.pi <= h[2][1] <= math.pi for h in heard)


# ------------------------------------------------------------------------------------------------ bad input

GOOD = """\
[run]
ticks = 3

[radio]
range = 1.0

[[robots]]
positions = [[0.0, 0.0], [0.5, 0.0]]
behaviors = [{ use = "beacon" }]
"""

BAD = [
    ("negative-range-noise", "[[robots]]", "[[robots]]\nrange_noise = -0.1", "robots[0].range_noise"),
    ("negative-bearing-noise", "[[robots]]", "[[robots]]\nbearing_noise = -0.1", "robots[0].bearing_noise"),
    ("drift-beyond-1e5-ppm", "[[robots]]", "[[robots]]\nclock_drift = 2e5", "robots[0].clock_drift"),
    ("drift-range-beyond-1e5-ppm", "[[robots]]", "[[robots]]\nclock_drift = [-1.5e5, 0]", "robots[0].clock_drift"),
    ("p_gb-above-1", "range = 1.0", 'range = 1.0\nloss_model = "gilbert"\np_gb = 1.5\np_bg = 0.5', "radio.p_gb"),
    ("p_gb-below-0", "range = 1.0", 'range = 1.0\nloss_model = "gilbert"\np_gb = -0.1\np_bg = 0.5', "radio.p_gb"),
    ("behaviour-not-local", "[[robots]]", '[[robots]]\nsensing_frame = "local"', "'beacon' does not support"),
]


@pytest.mark.parametrize("old,new,named", [c[1:] for c in BAD], ids=[c[0] for c in BAD])
def test_bad_input_exits_2_naming_the_key_or_behaviour(tmp_path, monkeypatch, capsys, old, new, named):
    from swarmactors.cli import main

    (tmp_path / "s.toml").write_text(GOOD.replace(old, new, 1))
    monkeypatch.chdir(tmp_path)
    capsys.readouterr()
    code = main(["run", "s.toml"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "s.toml" in err and named in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]  # nothing started
