"""Swarm Relays' collision avoidance: Eq. 8 by sampling RVO (protocols/relays/motion.py), below Zenoh."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from protocols.relays import motion
from protocols.relays.behavior import Relays

DS, RCOL, DT, VMAX = 1.4, 0.25, 0.2, 0.5


def test_tvo_is_the_time_to_contact_of_two_discs_on_known_geometry():
    # head-on, 1 m apart, closing at 1 m/s, combined radius 0.25: contact after 0.75 s
    assert motion.tvo(np.array([1.0, 0.0]), np.array([1.0, 0.0]), 0.25) == pytest.approx(0.75)
    # offset 0.2 m across, closing at 2 m/s: (1 - 2t)^2 + 0.2^2 = 0.25^2, so 1 - 2t = 0.15
    assert motion.tvo(np.array([1.0, 0.2]), np.array([2.0, 0.0]), 0.25) == pytest.approx(0.425)
    assert motion.tvo(np.array([1.0, 0.3]), np.array([1.0, 0.0]), 0.25) == math.inf  # passes 0.3 > 0.25 apart
    assert motion.tvo(np.array([1.0, 0.0]), np.array([-1.0, 0.0]), 0.25) == math.inf  # moving apart
    assert motion.tvo(np.array([1.0, 0.0]), np.array([0.0, 0.0]), 0.25) == math.inf  # no relative motion
    assert motion.tvo(np.array([0.1, 0.0]), np.array([1.0, 0.0]), 0.25) == 0.0  # overlapping and closing
    assert motion.tvo(np.array([0.1, 0.0]), np.array([-1.0, 0.0]), 0.25) == math.inf  # overlapping, separating
    # 3-D: the same contact along a diagonal
    d = np.array([1.0, 1.0, 1.0]) / math.sqrt(3)
    assert motion.tvo(2.0 * d, 0.5 * d, 0.25) == pytest.approx((2.0 - 0.25) / 0.5)
    # broadcast over candidates x neighbours
    t = motion.tvo(np.array([[[1.0, 0.0], [0.0, 1.0]]]), np.array([[[1.0, 0.0]], [[0.0, 1.0]]]), 0.25)
    assert t.shape == (2, 2) and t[0, 0] == pytest.approx(0.75) and t[1, 1] == pytest.approx(0.75)
    assert t[0, 1] == math.inf and t[1, 0] == math.inf


def test_the_cost_is_eq8_with_the_reciprocal_relative_velocity():
    x, y = np.array([0.0, 0.0]), np.array([1.0, 0.0])
    u_pref = np.array([0.5, 0.0])
    cand = np.array([[0.5, 0.0], [0.0, 0.0], [0.25, 0.0]])
    # i moves at 0.5 towards j, j at 0.5 towards i: for u' = u_pref the test velocity is 2u' - u_i - u_j = 1 m/s
    c = motion.rvo_cost(cand, u_pref, x, [y], RCOL, VMAX, u_self=np.array([0.5, 0.0]), v_others=[np.array([-0.5, 0.0])])
    assert c[0] == pytest.approx(1 / 0.75)  # alpha / tvo, no deviation
    assert c[1] == pytest.approx(0.5)  # stopping: 2*0 - 0.5 + 0.5 = 0, no collision; deviation 0.5
    assert c[2] == pytest.approx(0.25)  # 2*0.25 - 0.5 + 0.5 = 0.5 m/s: tvo 1.5 s, beyond the 1 s horizon
    long = motion.rvo_cost(cand, u_pref, x, [y], RCOL, VMAX, u_self=np.array([0.5, 0.0]),
                           v_others=[np.array([-0.5, 0.0])], horizon=2.0)
    assert long[2] == pytest.approx(0.25 + 1 / 1.5)  # within a 2 s horizon it counts
    # j's velocity unknown: taken as 0 (for u' = u_pref the test velocity is 1 - 0.5 = 0.5 m/s, tvo 1.5 s)
    unknown = motion.rvo_cost(cand, u_pref, x, [y], RCOL, VMAX, u_self=np.array([0.5, 0.0]), v_others=[None],
                              horizon=2.0)
    assert unknown[0] == pytest.approx(1 / 1.5)
    c2 = motion.rvo_cost(cand, u_pref, x, [y], RCOL, VMAX, u_self=np.array([0.5, 0.0]),
                         v_others=[np.array([-0.5, 0.0])], alpha=2.0)
    assert c2[0] == pytest.approx(2 / 0.75)


def test_n_close_holds_the_robots_some_candidate_could_meet_within_the_horizon():
    x = np.array([0.0, 0.0])
    reach = RCOL + 4 * VMAX * 1.0
    others = [np.array([reach - 0.01, 0.0]), np.array([0.0, reach + 0.01]), np.array([0.3, 0.0])]
    assert motion.close_set(x, others, RCOL, VMAX, 1.0) == [0, 2]


def test_argmin_is_u_pref_when_no_one_is_close_or_on_a_collision_course():
    u_pref = np.array([0.3, -0.2])
    x = np.array([1.0, 1.0])
    assert motion.constrain(u_pref, x, [], [], RCOL, DT, VMAX).tolist() == u_pref.tolist()
    far = [np.array([5.0, 1.0]), np.array([1.0, -3.0])]
    assert motion.constrain(u_pref, x, [], far, RCOL, DT, VMAX).tolist() == u_pref.tolist()
    # a robot beside, moving the same way: no collision ahead, u_pref kept
    beside = x + np.array([0.2, 0.3]) * 2
    u = motion.constrain(u_pref, x, [], [beside], RCOL, DT, VMAX, u_self=u_pref, v_others=[u_pref])
    assert u.tolist() == u_pref.tolist()
    # a robot straight ahead, still: the robot turns (or slows), it does not keep u_pref
    ahead = x + u_pref / np.linalg.norm(u_pref) * 0.5
    u = motion.constrain(u_pref, x, [], [ahead], RCOL, DT, VMAX, u_self=u_pref, v_others=[np.zeros(2)])
    assert u.tolist() != u_pref.tolist()
    assert motion.tvo(ahead - x, 2 * u - u_pref, RCOL) > 1.0  # no collision within the horizon any more


def _admissible(u, x, links, others, margin=0.02):
    for y, limit in links:
        d = float(np.linalg.norm(x - y))
        if float(u @ (x - y)) / d > max(0.0, (limit - d) / (2 * DT)) + 1e-9:
            return False
    for y in others:
        d = float(np.linalg.norm(y - x))
        if float(u @ (y - x)) / d > max(0.0, (d - RCOL - margin) / (2 * DT)) + 1e-9:
            return False
    return True


@pytest.mark.parametrize("dim", [2, 3])
def test_the_choice_is_always_in_the_admissible_set(dim):
    """Eq. 8's links (our reading) and the safety guard hold for every draw, and the speed stays within v_max."""
    rng = np.random.default_rng(7)
    for _ in range(300):
        x = rng.uniform(-1, 1, dim)
        if dim == 3 and rng.random() < 0.5:
            x[2] = 0.0
        links = [(x + rng.normal(size=dim) * 0.9, DS) for _ in range(rng.integers(0, 3))]
        others = [x + rng.normal(size=dim) * 0.6 for _ in range(rng.integers(0, 6))]
        others = [y for y in others if np.linalg.norm(y - x) > RCOL + 0.02]
        u_pref = rng.normal(size=dim)
        u_pref *= rng.uniform(0, VMAX) / np.linalg.norm(u_pref)
        vel = [rng.normal(size=dim) * 0.2 if rng.random() < 0.7 else None for _ in others]
        u = motion.constrain(u_pref, x, links, others, RCOL, DT, VMAX, u_self=rng.normal(size=dim) * 0.2,
                             v_others=vel, vertical=dim == 3, rng=rng if rng.random() < 0.5 else None)
        assert u.shape == (dim,)
        assert _admissible(u, x, links, others)
        assert np.linalg.norm(u) <= VMAX + 1e-9


def test_a_ground_robot_in_3d_gets_no_vertical_velocity_a_flying_one_may():
    x, above = np.array([0.0, 0.0, 0.0]), np.array([0.6, 0.0, 0.0])
    u_pref = np.array([0.5, 0.0, 0.0])
    ground = motion.constrain(u_pref, x, [], [above], RCOL, DT, VMAX, u_self=u_pref, v_others=[np.zeros(3)])
    assert ground[2] == 0.0 and not np.allclose(ground, u_pref)
    assert len(motion.candidates(u_pref, VMAX, vertical=True)) > len(motion.candidates(u_pref, VMAX))


def _simulate(starts, goals, steps=60, seeded=True):
    """Robots that each apply Eq. 8 every step, with velocities estimated from the previous step's positions.

    ``seeded``: each robot draws its random candidates from its own generator (as from ``ctx.rng``).
    """
    rngs = [np.random.default_rng([1, i]) if seeded else None for i in range(len(starts))]
    pos = [np.array(p, dtype=float) for p in starts]
    prev = [p.copy() for p in pos]
    dmin, track = math.inf, [[p.copy() for p in pos]]
    for _ in range(steps):
        vel = [(p - q) / DT for p, q in zip(pos, prev, strict=True)]
        step = []
        for i, x in enumerate(pos):
            to = np.array(goals[i]) - x
            d = float(np.linalg.norm(to))
            u_pref = np.zeros(2) if d < 1e-9 else to / d * min(VMAX, d / DT)
            others = [pos[j] for j in range(len(pos)) if j != i]
            vo = [vel[j] for j in range(len(pos)) if j != i]
            step.append(motion.constrain(u_pref, x, [], others, RCOL, DT, VMAX, u_self=vel[i], v_others=vo,
                                         rng=rngs[i]))
        prev = [p.copy() for p in pos]
        pos = [p + u * DT for p, u in zip(pos, step, strict=True)]
        track.append([p.copy() for p in pos])
        dmin = min(dmin, min(float(np.linalg.norm(pos[i] - pos[j]))
                             for i in range(len(pos)) for j in range(i + 1, len(pos))))
    return pos, dmin, track


@pytest.mark.parametrize("offset", [0.0, 0.02, -0.05])
def test_a_head_on_pair_passes_without_touching(offset):
    pos, dmin, track = _simulate([[-1.5, 0.0], [1.5, offset]], [[1.5, 0.0], [-1.5, offset]])
    assert np.linalg.norm(pos[0] - [1.5, 0.0]) < 0.05 and np.linalg.norm(pos[1] - [-1.5, offset]) < 0.05  # passed
    assert dmin >= RCOL  # bodies of radius r_col/2 never touched
    assert max(abs(p[0][1] - p[1][1]) for p in track) > RCOL  # they went round each other, not through


@pytest.mark.parametrize("seeded", [True, False])
def test_the_rvo_acts_before_the_guard_a_crossing_pair_keeps_a_gap(seeded):
    """Crossing at right angles, one robot 0.1 m ahead: the RVO alone keeps them r_col + 5 cm apart.

    (The guard binds only below r_col + 0.22 m.) With or without the random candidates.
    """
    pos, dmin, _ = _simulate([[-1.5, 0.0], [0.0, -1.4]], [[1.5, 0.0], [0.0, 1.6]], seeded=seeded)
    assert np.linalg.norm(pos[0] - [1.5, 0.0]) < 0.05 and np.linalg.norm(pos[1] - [0.0, 1.6]) < 0.05
    assert dmin >= RCOL + 0.05


@pytest.mark.parametrize("seeded", [True, False])
def test_a_mirror_symmetric_crossing_ends_without_touching(seeded):
    """In exact mirror image the choices are mirrored too (the reciprocal dance).

    The pair slides along the safety guard, never touching, until rounding breaks the symmetry; both arrive,
    later than alone (3 s).
    """
    starts, goals = [[-1.5, 0.0], [0.0, -1.5]], [[1.5, 0.0], [0.0, 1.5]]
    pos, dmin, _ = _simulate(starts, goals, steps=120, seeded=seeded)
    assert dmin >= RCOL and all(np.linalg.norm(p - np.array(g)) < 0.05 for p, g in zip(pos, goals, strict=True))


def test_four_robots_swapping_corners_all_arrive_and_never_touch():
    starts = [[-1.2, -1.2], [1.2, -1.2], [1.2, 1.2], [-1.2, 1.2]]
    goals = [starts[2], starts[3], starts[0], starts[1]]
    pos, dmin, _ = _simulate(starts, goals, steps=120)
    assert dmin >= RCOL
    assert all(np.linalg.norm(p - np.array(g)) < 0.1 for p, g in zip(pos, goals, strict=True))


def test_the_robot_estimates_velocities_from_its_own_consecutive_sensings():
    r = Relays(targets=[[5.0, 0.0]])
    ctx = SimpleNamespace(tick=10, dt=0.2, position=[0.0, 0.0])
    r.sensed = {3: np.array([1.0, 0.0]), 4: np.array([0.0, 1.0])}
    r._velocities(ctx)
    assert r.vel == {} and r.u_self is None  # one sensing: nothing known
    ctx.tick, ctx.position = 11, [0.1, 0.0]
    r.sensed = {3: np.array([0.9, 0.0]), 5: np.array([2.0, 2.0])}
    r._velocities(ctx)
    assert set(r.vel) == {3} and r.vel[3] == pytest.approx([-0.5, 0.0]) and r.u_self == pytest.approx([0.5, 0.0])
    ctx.tick = 13  # a tick missed: the estimates are dropped, not stretched over two ticks
    r._velocities(ctx)
    assert r.vel == {} and r.u_self is None
