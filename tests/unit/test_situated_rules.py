"""Situated sensing (world/situated.py), without Zenoh.

Rules tested, against numpy computed here and statistics:

* range and bearing: for a local-sensing robot, each neighbour's (range, bearing) equals the numpy distance
  and atan2 of the world vector minus the observer's true heading, on random poses (2-D and 3-D, elevation);
* noise: with range_noise and bearing_noise > 0 the errors have mean 0 and the given standard deviation
  (99.9 % bands), uncorrelated, and are keyed on (seed, tick, observer, observed);
* heading offsets: drawn per robot in the given range (default [-pi, pi]) from the seed only; a fixed value is
  taken as is; the odometry pose starts at (0, 0) with heading true + offset, and a velocity commanded in the
  robot's own frame moves it in the world along the same bearing;
* closest point (Sano et al., Eqs. 4-5) on hand-made configurations, and who is sensed with
  sensing_to = "surface";
* frame range and bearing: noted only for receivers that want it, equal to numpy's, taken once.
"""

from __future__ import annotations

import math

import msgspec
import numpy as np
import pytest
from scipy import stats

from transport.scenario import RobotSpec
from world.sensing import within
from world.situated import Situated, closest_point

ALPHA = 1e-3


def spec(pos, **kw) -> RobotSpec:
    return RobotSpec(pos=list(pos), **kw)


def situated(specs, seed=7, rab=False) -> Situated:
    s = Situated(seed, rab)
    s.sync(specs)
    return s


def sensed_rows(s: Situated, pos, heading, sensing, tick=0, noise=None):
    pos = np.asarray(pos, dtype=float)
    alive = np.arange(len(pos))
    sensing = np.full(len(pos), float(sensing))
    nb = within(pos, alive, sensing)
    base = {i: [ids.tolist(), pos[ids].ravel().tolist()] for i, ids in nb.items()}
    noise = np.zeros(len(pos)) if noise is None else noise
    return s.sense(pos, np.asarray(heading, dtype=float), alive, sensing, noise, nb, base, tick, 9)


@pytest.mark.parametrize("dims", [2, 3])
def test_range_and_bearing_match_numpy_on_random_poses(dims):
    g = np.random.default_rng(1)
    for _ in range(20):
        n = 12
        pos = g.uniform(0, 3, (n, dims))
        heading = g.uniform(-math.pi, math.pi, n)
        s = situated([spec(p, sensing_frame="local") for p in pos])
        rows = sensed_rows(s, pos, heading, 1.5)
        for i, (ids, flat) in rows.items():
            got = np.array(flat).reshape(len(ids), dims)
            d = pos[ids] - pos[i]
            want_r = np.sqrt((d**2).sum(axis=1))
            want_b = np.angle(np.exp(1j * (np.arctan2(d[:, 1], d[:, 0]) - heading[i])))
            np.testing.assert_allclose(got[:, 0], want_r, atol=1e-8)
            np.testing.assert_allclose(np.angle(np.exp(1j * (got[:, 1] - want_b))), 0, atol=1e-8)
            if dims == 3:
                np.testing.assert_allclose(got[:, 2], np.arcsin(d[:, 2] / want_r), atol=1e-8)


def test_global_robots_keep_the_global_rows():
    pos = [[0, 0], [0.5, 0], [1.0, 0.2]]
    s = situated([spec(pos[0]), spec(pos[1], sensing_frame="local"), spec(pos[2])])
    rows = sensed_rows(s, pos, [0.3, 0.3, 0.3], 2.0)
    assert rows[0] == [[1, 2], [0.5, 0.0, 1.0, 0.2]]
    assert rows[1][0] == [0, 2] and rows[1][1] != [0.0, 0.0, 1.0, 0.2]


def test_noise_statistics_of_range_and_bearing():
    sr, sb = 0.05, 0.1
    pos = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, -0.7]])
    heading = np.array([0.4, 0.0, 0.0])
    s = situated([spec(p, sensing_frame="local", range_noise=sr, bearing_noise=sb) for p in pos])
    clean = situated([spec(p, sensing_frame="local") for p in pos])
    truth = np.array(sensed_rows(clean, pos, heading, 2.0)[0][1]).reshape(-1, 2)
    errs = []
    for tick in range(800):
        got = np.array(sensed_rows(s, pos, heading, 2.0, tick)[0][1]).reshape(-1, 2)
        errs.append(np.column_stack([got[:, 0] - truth[:, 0], np.angle(np.exp(1j * (got[:, 1] - truth[:, 1])))]))
    e = np.concatenate(errs)
    n = len(e)
    z = stats.norm.ppf(1 - ALPHA / 2)
    for col, sigma in ((0, sr), (1, sb)):
        assert abs(e[:, col].mean()) < z * sigma / math.sqrt(n)
        lo, hi = stats.chi2.ppf([ALPHA / 2, 1 - ALPHA / 2], n)
        assert lo / n * sigma**2 < e[:, col].var() < hi / n * sigma**2
    assert abs(np.corrcoef(e[:, 0], e[:, 1])[0, 1]) < z / math.sqrt(n)
    # keyed on (seed, tick, observer, observed): the same tick gives the same reading
    assert sensed_rows(s, pos, heading, 2.0, 5) == sensed_rows(s, pos, heading, 2.0, 5)
    assert sensed_rows(s, pos, heading, 2.0, 5) != sensed_rows(s, pos, heading, 2.0, 6)


def test_heading_offsets_are_drawn_per_robot_from_the_seed():
    specs = [spec([0, 0], sensing_frame="local") for _ in range(400)]
    a, b, c = situated(specs, seed=1), situated(specs, seed=1), situated(specs, seed=2)
    assert np.array_equal(a.offset, b.offset) and not np.array_equal(a.offset, c.offset)
    assert (a.offset >= -math.pi).all() and (a.offset <= math.pi).all()
    assert stats.kstest((a.offset + math.pi) / (2 * math.pi), "uniform").pvalue > ALPHA
    # a robot's draw does not depend on the others: robots added later keep the first ones' offsets
    grown = situated(specs[:10], seed=1)
    grown.sync(specs)
    assert np.array_equal(grown.offset, a.offset)
    ranged = situated([spec([0, 0], sensing_frame="local", heading_offset=[0.1, 0.2]) for _ in range(50)])
    assert ((ranged.offset >= 0.1) & (ranged.offset <= 0.2)).all()
    fixed = situated([spec([0, 0], sensing_frame="local", heading_offset=0.3), spec([0, 0])])
    assert fixed.offset.tolist() == [0.3, 0.0]  # global robots have no offset


def test_odometry_pose_and_own_frame_velocity():
    s = situated([spec([2.0, 1.0], sensing_frame="local", heading_offset=0.5)])
    assert s.pose(0, np.array([2.0, 1.0]), 0.2) == pytest.approx([0.0, 0.0, 0.7])
    # moved by (1, 0) in the world: in the robot's frame, turned by the offset
    assert s.pose(0, np.array([3.0, 1.0]), 0.0) == pytest.approx([math.cos(0.5), math.sin(0.5), 0.5])
    # a command along its own heading (heading + 0 bearing) moves it along its true heading
    true_heading = 1.1
    own = true_heading + 0.5
    v = s.velocity(0, np.array([math.cos(own), math.sin(own)]))
    assert v == pytest.approx([math.cos(true_heading), math.sin(true_heading)])


def test_closest_point_on_hand_made_configurations():
    rel = np.array([[2.0, 0.0], [0.0, -1.0], [0.3, 0.4], [0.0, 0.0]])
    got = closest_point(rel, np.array([0.5, 0.25, 1.0, 0.5]))
    np.testing.assert_allclose(got, [[1.5, 0.0], [0.0, -0.75], [0.0, 0.0], [0.0, 0.0]])
    # 3-D: along the vector
    np.testing.assert_allclose(closest_point(np.array([[0.0, 3.0, 4.0]]), np.array([1.0])), [[0.0, 2.4, 3.2]])


def test_surface_sensing_rows_and_neighbourhood():
    pos = [[0.0, 0.0], [1.3, 0.0], [0.0, 1.3]]
    specs = [spec(pos[0], sensing_to="surface", body_radius=0.1), spec(pos[1], body_radius=0.4),
             spec(pos[2], body_radius=0.2)]
    rows = sensed_rows(situated(specs), pos, [0.0] * 3, 1.0)
    # robot 1's surface is 0.9 away (sensed, at its closest point); robot 2's is 1.1 away (not sensed)
    assert rows[0][0] == [1] and rows[0][1] == pytest.approx([0.9, 0.0])
    local = [msgspec.structs.replace(specs[0], sensing_frame="local"), specs[1], specs[2]]
    rows = sensed_rows(situated(local), pos, [math.pi / 2, 0.0, 0.0], 1.0)
    assert rows[0][0] == [1] and rows[0][1] == pytest.approx([0.9, -math.pi / 2])


def test_frame_range_and_bearing():
    pos = np.array([[0.0, 0.0], [0.0, 2.0], [1.0, 1.0]])
    heading = np.array([0.0, math.pi, 0.25])
    s = situated([spec(p) for p in pos[:2]] + [spec(pos[2], sensing_frame="local")])
    deliveries = [(1, 0, 4, None, 3), (2, 0, 4, None, 3)]
    s.note_rab(3, deliveries, pos, heading)
    r, b = s.take_rab(0, 4, 2)  # heard by robot 2 from (0, 0): vector (-1, -1)
    assert r == pytest.approx(math.sqrt(2), abs=1e-6)
    assert b == pytest.approx(math.atan2(-1, -1) - 0.25, abs=1e-6)
    assert all(math.isnan(v) for v in s.take_rab(0, 4, 2))  # taken once
    assert all(math.isnan(v) for v in s.take_rab(0, 4, 1))  # a global robot without radio.rab: nothing noted
    every = situated([spec(p) for p in pos], rab=True)
    every.note_rab(3, deliveries, pos, heading)
    r, b = every.take_rab(0, 4, 1)  # robot 1 faces -x; the sender is straight "below" it: to its left
    assert r == pytest.approx(2.0) and b == pytest.approx(math.pi / 2)
