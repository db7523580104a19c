"""The opt-in variants of the SECS controller (protocols/secs/rules.py), below Zenoh: pure functions.

Each is a parameter of the behaviour, OFF by default (docs/protocols/secs.md, "Why our arm differs from
Table I"); the pinned traces are those of the defaults.
"""

from __future__ import annotations

import math

import pytest

from protocols.secs import rules
from protocols.secs.behavior import SECS


def test_hysteresis_aligns_within_tol_and_releases_beyond_release_times_tol():
    tol = 0.087
    assert rules.still_aligned(0.08, tol, was=False)
    assert not rules.still_aligned(0.09, tol, was=False)
    assert rules.still_aligned(0.17, tol, was=True)  # default release = 2: kept up to 2 × tol
    assert not rules.still_aligned(0.18, tol, was=True)
    assert not rules.still_aligned(0.09, tol, was=True, release=1.0)  # the Buzz code's single threshold
    assert rules.still_aligned(0.34, tol, was=True, release=4.0)
    assert not rules.still_aligned(0.35, tol, was=True, release=4.0)
    assert rules.still_aligned(-0.34, tol, was=True, release=4.0)  # symmetric


def test_unicycle_turns_at_most_turn_rate_and_never_moves_sideways():
    # facing +x, asked to go +y at 0.15 m/s: turns 0.2 rad (2 rad/s × 0.1 s), drives cos(π/2 − 0.2) ahead
    h, (vx, vy) = rules.unicycle_step(0.0, (0.0, 0.15), 2.0, 0.1)
    assert h == pytest.approx(0.2)
    assert math.hypot(vx, vy) == pytest.approx(0.15 * math.cos(math.pi / 2 - 0.2))
    assert math.atan2(vy, vx) == pytest.approx(0.2)  # along the new heading only
    # asked to go backwards: turns, does not move
    h, v = rules.unicycle_step(0.0, (-0.15, 0.0), 2.0, 0.1)
    assert v == (0.0, 0.0) and abs(h) == pytest.approx(0.2)
    # facing the commanded direction: full speed, heading kept
    h, v = rules.unicycle_step(1.0, (0.15 * math.cos(1.0), 0.15 * math.sin(1.0)), 2.0, 0.1)
    assert h == pytest.approx(1.0) and math.hypot(*v) == pytest.approx(0.15)
    # zero command: heading kept, no motion
    assert rules.unicycle_step(2.5, (0.0, 0.0), 2.0, 0.1) == (2.5, (0.0, 0.0))


def test_unicycle_reaches_a_point_behind_it():
    x = y = 0.0
    h = 0.0
    for _ in range(400):
        dx, dy = -1.0 - x, 0.0 - y
        v = rules.clip((dx * 10, dy * 10), 0.15)
        h, (vx, vy) = rules.unicycle_step(h, v, 2.0, 0.1)
        x, y = x + vx * 0.1, y + vy * 0.1
    assert math.hypot(x + 1.0, y) < 0.05


def test_walk_back_starts_on_a_loss_out_of_sight_and_ends_in_sight_of_the_master():
    assert not rules.walk_back(aligned=True, was=True, walking=False, sees_master=False)
    assert rules.walk_back(aligned=False, was=True, walking=False, sees_master=False)  # just lost it
    assert rules.walk_back(aligned=False, was=False, walking=True, sees_master=False)  # keeps walking
    assert not rules.walk_back(aligned=False, was=False, walking=True, sees_master=True)  # home: spiral
    assert not rules.walk_back(aligned=False, was=False, walking=False, sees_master=False)  # never aligned
    assert not rules.walk_back(aligned=False, was=True, walking=False, sees_master=True)


def test_strip_has_a_constant_width_where_the_cone_narrows():
    tol = 0.087
    # 0.25 m beside the arm line: outside the 5° cone at 2 m (0.17 m wide half), inside a 0.3 m strip
    off = math.asin(0.25 / 2.0)
    assert not rules.still_aligned(off, tol, was=False)
    assert rules.in_strip(off, 2.0, 0.3)
    assert not rules.in_strip(math.asin(0.35 / 2.0), 2.0, 0.3)
    assert not rules.in_strip(math.pi - 0.01, 2.0, 0.3)  # behind the informer: not on the arm


@pytest.mark.parametrize("params, ok", [
    ({}, True), ({"align_release": 3.0}, True), ({"align_release": 0}, False),
    ({"turn_rate": 2.0}, True), ({"turn_rate": None}, True), ({"turn_rate": -1}, False),
    ({"walk_back": True}, True), ({"walk_back": 1}, False), ({"strip": 0.3}, True), ({"strip": "x"}, False),
])
def test_variant_parameters_are_validated(params, ok):
    assert (SECS.validate(params) is None) == ok


def test_variants_are_off_by_default():
    s = SECS()
    assert (s.align_release, s.turn_rate, s.walk_back, s.strip) == (2.0, None, False, None)
