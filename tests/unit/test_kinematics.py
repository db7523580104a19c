"""Motion rules of ``world/kinematics.py`` (``integrate``), without Zenoh.

Each expected step is computed here from the rules as docs/architecture.md states them:

* holonomic robots (no ``turn_rate``): a robot moves v dt, with |v| clipped to its ``speed`` (direction kept;
  no limit when the speed is infinite); its heading becomes the direction of the step; a zero velocity
  moves nothing and keeps the heading; dead robots never move; in 3-D the cap applies to the 3-D speed
  and the heading follows the horizontal part of the step;
* unicycles (finite ``turn_rate``): the heading turns towards the commanded direction by at most
  turn_rate dt, then the robot advances along its new heading by |v| dt max(0, cos e), e the heading error
  left after turning (|v| clipped to the speed first) - so it never drives away from the commanded direction
  and never exceeds its speed; Kobayashi et al.'s 0.03 units / 0.15 rad per step;
* holonomic robots, unicycles and dead robots mixed in one call each follow their own rule;
* bounds: positions end inside ``world.bounds``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from world.kinematics import integrate

TOL = 1e-9


def wrap(a: float) -> float:
    """An angle in (-pi, pi]."""
    return math.atan2(math.sin(a), math.cos(a))


def expected(pos, heading, vel, speed, turn_rate, alive, dt):
    """One robot's next (position, heading) from the written-out rules, 2-D or 3-D."""
    norm = math.sqrt(sum(c * c for c in vel))
    if not alive or norm == 0.0:
        return list(pos), heading
    k = min(1.0, speed / norm)
    step = [c * k * dt for c in vel]
    if math.isinf(turn_rate):
        if step[0] or step[1]:
            heading = math.atan2(step[1], step[0])
        return [p + s for p, s in zip(pos, step, strict=True)], heading
    want = math.atan2(step[1], step[0])
    err = wrap(want - heading)
    turn = max(-turn_rate * dt, min(turn_rate * dt, err))
    new_heading = wrap(heading + turn)
    length = math.sqrt(sum(s * s for s in step)) * max(0.0, math.cos(err - turn))
    return [pos[0] + length * math.cos(new_heading), pos[1] + length * math.sin(new_heading), *pos[2:]], new_heading


def run(robots, dt, bounds=None):
    """One tick for ``robots`` (dicts: pos, heading, vel, speed, turn_rate, alive); (positions, headings) after it."""
    pos = np.array([r["pos"] for r in robots], dtype=float)
    heading = np.array([r["heading"] for r in robots], dtype=float)
    integrate(
        pos, heading,
        np.array([r["vel"] for r in robots], dtype=float),
        np.array([r["speed"] for r in robots], dtype=float),
        np.array([r["turn_rate"] for r in robots], dtype=float),
        np.array([r["alive"] for r in robots], dtype=bool),
        dt,
        None if bounds is None else np.array(bounds, dtype=float),
    )
    return pos, heading


def close(a, b) -> bool:
    return all(math.isclose(x, y, rel_tol=TOL, abs_tol=TOL) for x, y in zip(a, b, strict=True))


def same_angle(a, b) -> bool:
    return abs(wrap(a - b)) <= TOL


COORD = st.integers(min_value=-300, max_value=300).map(lambda k: k / 100)
VEL = st.integers(min_value=-500, max_value=500).map(lambda k: k / 100)
SPEED = st.sampled_from([math.inf]) | st.integers(min_value=1, max_value=300).map(lambda k: k / 100)
TURN = st.integers(min_value=1, max_value=400).map(lambda k: k / 100)
HEADING = st.floats(min_value=-math.pi, max_value=math.pi)
DT = st.sampled_from([0.1, 0.5, 1.0, 2.0])


@st.composite
def robot(draw, kind=None):
    kind = kind or draw(st.sampled_from(["holonomic", "unicycle", "dead"]))
    r = {
        "pos": [draw(COORD), draw(COORD)],
        "heading": draw(HEADING),
        "vel": [draw(VEL), draw(VEL)] if draw(st.integers(0, 9)) else [0.0, 0.0],
        "speed": draw(SPEED),
        "turn_rate": math.inf if kind == "holonomic" else draw(TURN),
        "alive": kind != "dead",
    }
    return r


def _ambiguous_turn(r, dt) -> bool:
    """Commanded exactly behind: which way to turn is a tie, left to floating point."""
    if math.isinf(r["turn_rate"]) or not any(r["vel"]):
        return False
    err = wrap(math.atan2(r["vel"][1], r["vel"][0]) - r["heading"])
    return abs(abs(err) - math.pi) < 1e-6


@settings(max_examples=100, deadline=None)
@given(st.lists(robot(), min_size=1, max_size=8), DT)
def test_one_tick_matches_the_written_out_rules(robots, dt):
    assume(not any(_ambiguous_turn(r, dt) for r in robots))
    pos, heading = run(robots, dt)
    for i, r in enumerate(robots):
        want_pos, want_heading = expected(r["pos"], r["heading"], r["vel"], r["speed"], r["turn_rate"], r["alive"], dt)
        assert close(pos[i], want_pos), (i, r, pos[i], want_pos)
        assert same_angle(heading[i], want_heading), (i, r, heading[i], want_heading)


@settings(max_examples=150, deadline=None)
@given(robot(kind="unicycle"), DT)
def test_unicycle_turn_cap_speed_cap_and_never_away(r, dt):
    assume(not _ambiguous_turn(r, dt))
    pos, heading = run([r], dt)
    step = pos[0] - np.array(r["pos"])
    assert abs(wrap(heading[0] - r["heading"])) <= r["turn_rate"] * dt + TOL  # turn-rate cap
    assert np.linalg.norm(step) <= min(np.linalg.norm(r["vel"]), r["speed"]) * dt + TOL  # speed cap
    assert float(np.dot(step, r["vel"])) >= -TOL  # never moves away from the commanded direction
    if np.linalg.norm(step) > TOL:  # it moves along its (new) heading
        assert same_angle(math.atan2(step[1], step[0]), heading[0])


@settings(max_examples=150, deadline=None)
@given(robot(kind="holonomic"), DT)
def test_holonomic_speed_cap_keeps_the_direction(r, dt):
    pos, heading = run([r], dt)
    step = pos[0] - np.array(r["pos"])
    v = np.array(r["vel"])
    assert np.linalg.norm(step) <= r["speed"] * dt + TOL
    assert abs(v[0] * step[1] - v[1] * step[0]) <= TOL  # parallel to v ...
    assert float(np.dot(step, v)) >= 0.0  # ... and the same way
    if np.linalg.norm(v) <= r["speed"]:
        assert close(step, v * dt)  # under the cap: exactly v dt


def test_zero_velocity_and_dead_robots_stay_put():
    robots = [
        {"pos": [1.0, 2.0], "heading": 0.7, "vel": [0.0, 0.0], "speed": 1.0, "turn_rate": math.inf, "alive": True},
        {"pos": [1.0, 2.0], "heading": 0.7, "vel": [0.0, 0.0], "speed": 1.0, "turn_rate": 0.3, "alive": True},
        {"pos": [1.0, 2.0], "heading": 0.7, "vel": [1.0, 1.0], "speed": 1.0, "turn_rate": math.inf, "alive": False},
        {"pos": [1.0, 2.0], "heading": 0.7, "vel": [1.0, 1.0], "speed": 1.0, "turn_rate": 0.3, "alive": False},
    ]
    pos, heading = run(robots, 1.0)
    assert pos.tolist() == [[1.0, 2.0]] * 4
    assert heading.tolist() == [0.7] * 4


def test_kobayashi_limits_per_time_step():
    # speed 0.03 and turn rate 0.15 rad per step (dt = 1); commanded at a right angle to the heading
    r = {"pos": [0.0, 0.0], "heading": 0.0, "vel": [0.0, 1.0], "speed": 0.03, "turn_rate": 0.15, "alive": True}
    pos, heading = run([r], 1.0)
    assert heading[0] == pytest.approx(0.15)
    length = 0.03 * math.cos(math.pi / 2 - 0.15)  # error left after turning: pi/2 - 0.15
    assert pos[0] == pytest.approx([length * math.cos(0.15), length * math.sin(0.15)])


def test_unicycle_commanded_backwards_turns_in_place():
    r = {"pos": [0.0, 0.0], "heading": 0.0, "vel": [-1.0, -0.1], "speed": 1.0, "turn_rate": 0.5, "alive": True}
    pos, heading = run([r], 1.0)
    assert pos[0].tolist() == [0.0, 0.0]  # error after turning is more than pi/2: cos < 0, no advance
    assert heading[0] == pytest.approx(-0.5)  # the short way round (the target is at -174 degrees)


def test_unicycle_aligns_in_the_expected_number_of_ticks_then_drives_straight():
    r = {"pos": [0.0, 0.0], "heading": 0.0, "vel": [0.0, 2.0], "speed": 0.5, "turn_rate": 0.2, "alive": True}
    want_pos, want_heading = [0.0, 0.0], 0.0
    pos = np.array([r["pos"]])
    heading = np.array([r["heading"]])
    for tick in range(12):
        want_pos, want_heading = expected(want_pos, want_heading, r["vel"], r["speed"], r["turn_rate"], True, 1.0)
        integrate(pos, heading, np.array([r["vel"]]), np.array([r["speed"]]), np.array([r["turn_rate"]]),
                  np.array([True]), 1.0, None)
        assert close(pos[0], want_pos) and same_angle(heading[0], want_heading), tick
    assert heading[0] == pytest.approx(math.pi / 2)  # ceil((pi/2) / 0.2) = 8 ticks to align
    before = pos[0].copy()
    integrate(pos, heading, np.array([r["vel"]]), np.array([r["speed"]]), np.array([r["turn_rate"]]),
              np.array([True]), 1.0, None)
    assert pos[0] - before == pytest.approx([0.0, 0.5])  # aligned: full speed along +y


@settings(max_examples=60, deadline=None)
@given(st.lists(robot(), min_size=1, max_size=6), DT, COORD, COORD, st.integers(1, 300), st.integers(1, 300))
def test_positions_end_inside_bounds(robots, dt, x0, y0, w, h):
    lo = [x0, y0]
    hi = [x0 + w / 100, y0 + h / 100]
    for r in robots:  # start inside the box
        r["pos"] = [min(max(p, a), b) for p, a, b in zip(r["pos"], lo, hi, strict=True)]
    assume(not any(_ambiguous_turn(r, dt) for r in robots))
    pos, heading = run(robots, dt, bounds=[lo, hi])
    for i, r in enumerate(robots):
        free, want_heading = expected(r["pos"], r["heading"], r["vel"], r["speed"], r["turn_rate"], r["alive"], dt)
        assert close(pos[i], [min(max(p, a), b) for p, a, b in zip(free, lo, hi, strict=True)]), (i, r)
        assert same_angle(heading[i], want_heading)


@settings(max_examples=100, deadline=None)
@given(st.tuples(VEL, VEL, VEL), SPEED, HEADING, DT)
def test_holonomic_3d_caps_the_3d_speed(vel, speed, heading0, dt):
    r = {"pos": [0.5, -0.5, 1.0], "heading": heading0, "vel": list(vel), "speed": speed, "turn_rate": math.inf,
         "alive": True}
    pos, heading = run([r], dt)
    want_pos, want_heading = expected(r["pos"], heading0, r["vel"], speed, math.inf, True, dt)
    assert close(pos[0], want_pos)
    assert same_angle(heading[0], want_heading)  # unchanged by a purely vertical step
    assert np.linalg.norm(pos[0] - r["pos"]) <= speed * dt + TOL


@pytest.mark.parametrize("vel", [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0]])
def test_unicycle_3d_respects_the_speed_cap(vel):
    r = {"pos": [0.0, 0.0, 0.0], "heading": 0.0, "vel": vel, "speed": 1.0, "turn_rate": 0.5, "alive": True}
    pos, _ = run([r], 1.0)
    assert np.linalg.norm(pos[0]) <= 1.0 + TOL, pos[0]  # at most speed * dt


def test_a_robot_that_does_not_move_keeps_its_position_whatever_the_others_do():
    still = {"pos": [5.0, 5.0], "heading": 0.0, "vel": [0.0, 0.0], "speed": 1.0, "turn_rate": math.inf, "alive": True}
    mover = {"pos": [1.0, 1.0], "heading": 0.0, "vel": [0.1, 0.0], "speed": 1.0, "turn_rate": math.inf, "alive": True}
    bounds = [[0.0, 0.0], [4.0, 4.0]]
    alone, _ = run([still, {**mover, "vel": [0.0, 0.0]}], 1.0, bounds)
    together, _ = run([still, mover], 1.0, bounds)
    assert alone[0].tolist() == together[0].tolist(), (alone[0], together[0])
