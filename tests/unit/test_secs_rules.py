"""Pure rules of the SECS navigation controller (protocols/secs/rules.py, behavior.py's parsers)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from protocols.secs import rules
from protocols.secs.behavior import SECS, parse_m, parse_t
from swarmactors.robot.behavior import Frame


def _own_bearing(p_from, p_to, offset):
    """The bearing of p_to seen from p_from, in a frame turned by ``offset`` from the world's."""
    return rules.wrap(math.atan2(p_to[1] - p_from[1], p_to[0] - p_from[0]) - offset)


def _chain(rng, n, noise=0.0):
    """A random chain of n robots with random frame offsets; ∠T composed hop by hop from robot 0.

    Returns (world truth of the direction, [composed ∠T_i turned back into the world frame]).
    """
    pos = rng.uniform(-10, 10, size=(n, 2))
    off = rng.uniform(-math.pi, math.pi, size=n)
    truth = rng.uniform(0, 2 * math.pi)
    t = rules.wrap(truth - off[0])  # robot 0's own-frame direction
    world = []
    for i in range(1, n):
        j = i - 1
        m_ji = rules.wrap(_own_bearing(pos[j], pos[i], off[j]) + rng.normal(0, noise))
        o_ij = rules.wrap(_own_bearing(pos[i], pos[j], off[i]) + rng.normal(0, noise))
        t = rules.compose_target(t, o_ij, m_ji)
        world.append(rules.wrap(t + off[i]))
    return truth, world


def test_composition_is_exact_without_noise():
    rng = np.random.default_rng(1)
    for _ in range(500):
        truth, world = _chain(rng, 6)
        for w in world:
            assert abs(rules.diff(w, truth)) < 1e-9


def test_printed_update_is_wrong():
    """The printed ∠T_i ← ∠M_ji − ∠O_ij + ∠T_j misses the truth for random frames (the reason for the fix)."""
    rng = np.random.default_rng(2)
    pos, off = rng.uniform(-5, 5, (2, 2)), rng.uniform(-math.pi, math.pi, 2)
    truth = 1.0
    t_j = rules.wrap(truth - off[0])
    m_ji, o_ij = _own_bearing(pos[0], pos[1], off[0]), _own_bearing(pos[1], pos[0], off[1])
    printed = rules.wrap(m_ji - o_ij + t_j)
    assert abs(rules.diff(printed + off[1], truth)) > 1e-3
    assert abs(rules.diff(rules.compose_target(t_j, o_ij, m_ji) + off[1], truth)) < 1e-12


def test_composition_error_with_noise_is_bounded():
    """Each hop adds two bearing errors: after k hops the error is a sum of 2k N(0, σ²) terms."""
    rng = np.random.default_rng(3)
    sigma, hops = 0.02, 8
    errs = []
    for _ in range(400):
        truth, world = _chain(rng, hops + 1, noise=sigma)
        errs.append([abs(rules.diff(w, truth)) for w in world])
    errs = np.array(errs)
    for k in range(hops):
        bound = 5 * sigma * math.sqrt(2 * (k + 1))  # 5 standard deviations
        assert errs[:, k].max() < bound
    assert errs[:, -1].mean() > 0.5 * sigma  # the noise really is there


def test_rotation_turns_vectors_between_frames():
    rng = np.random.default_rng(4)
    for _ in range(100):
        pos, off = rng.uniform(-5, 5, (2, 2)), rng.uniform(-math.pi, math.pi, 2)
        m_ji, o_ij = _own_bearing(pos[1], pos[0], off[1]), _own_bearing(pos[0], pos[1], off[0])
        rot = rules.rotation(o_ij, m_ji)  # j = 1's frame into i = 0's
        assert abs(rules.diff(rot, off[1] - off[0])) < 1e-9


def test_lennard_jones_sign_minimum_and_clip():
    assert rules.lj_repulsion(240.0, 240.0) == pytest.approx(0.0)
    assert rules.lj_repulsion(200.0, 240.0) > 0 > rules.lj_repulsion(280.0, 240.0)
    # a neighbour straight ahead (bearing 0) too close: move back (−x), clipped to 0.15 m/s
    vx, vy = rules.lj_velocity([(1.0, 0.0)], 240.0, 0.15)
    assert vx == pytest.approx(-0.15) and vy == pytest.approx(0.0)
    vx, _ = rules.lj_velocity([(2.9, 0.0)], 240.0, 0.15)
    assert vx == pytest.approx(0.15)  # too far: move towards it
    vx, _ = rules.lj_velocity([(2.4001, 0.0)], 240.0, 0.15)
    assert 0 < vx < 0.15  # near the minimum the force is small
    assert rules.lj_velocity([], 240.0, 0.15) == (0.0, 0.0)
    # symmetric neighbours cancel
    v = rules.lj_velocity([(1.0, 0.0), (1.0, math.pi)], 240.0, 0.15)
    assert math.hypot(*v) < 1e-9


def test_flocking_terms():
    # cohesion: a far neighbour ahead pulls forward
    assert rules.flocking_velocity([(2.0, 0.0, (0.0, 0.0))], 1.0)[0] > 0
    # separation: a neighbour inside q pushes back
    assert rules.flocking_velocity([(0.1, 0.0, (0.0, 0.0))], 1.0)[0] < 0
    # alignment: copies the neighbours' mean velocity
    vx, vy = rules.flocking_velocity([(0.6, 0.0, (0.0, 0.1)), (0.6, math.pi, (0.0, 0.1))], 1.0)
    assert vx == pytest.approx(0.0) and vy == pytest.approx(0.1)


def test_spiral_moves_round_the_informer_towards_the_arm():
    # informer straight ahead at 1.5 m; offset < 0: counter-clockwise round j, i.e. to the robot's right
    vx, vy = rules.spiral_velocity(0.0, 1.5, -0.5, 1.5, 0.15, far=2.5)
    assert vy < 0 and abs(vx) < 1e-9 and math.hypot(vx, vy) == pytest.approx(0.15)
    vx, vy = rules.spiral_velocity(0.0, 1.5, 0.5, 1.5, 0.15, far=2.5)
    assert vy > 0
    assert rules.spiral_velocity(0.0, 3.0, 0.5, 1.5, 0.15, far=2.5)[0] == pytest.approx(0.15)
    assert rules.spiral_velocity(0.0, 0.1, 0.5, 1.5, 0.15, far=2.5)[0] == pytest.approx(-0.15)


def test_spiral_converges_to_alignment():
    """Circling j with the spiral rule brings ∠M_ji (where j sees i) to ∠T_j."""
    rng = np.random.default_rng(5)
    for _ in range(20):
        t_j = rng.uniform(0, 2 * math.pi)
        p = rng.uniform(-1.5, 1.5, 2)
        off_i = rng.uniform(-math.pi, math.pi)
        for _step in range(3000):
            m = rules.wrap(math.atan2(p[1], p[0]))  # j at the origin, j's frame = world
            if abs(rules.diff(m, t_j)) < 0.0314:
                break
            o = _own_bearing(p, (0, 0), off_i)
            v = rules.spiral_velocity(o, float(np.hypot(*p)), rules.diff(m, t_j), 1.2, 0.15, far=2.5)
            c, s = math.cos(off_i), math.sin(off_i)
            p = p + 0.1 * np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])
        else:
            pytest.fail("never aligned")


def test_arms_and_informer():
    assert rules.arm_probabilities([1.0, 3.0]) == [0.25, 0.75]
    assert rules.arm_probabilities([0.0, 0.0]) == [0.5, 0.5]
    assert [rules.draw_arm([0.25, 0.75], u) for u in (0.0, 0.24, 0.25, 0.99)] == [0, 0, 1, 1]
    assert rules.pick_informer(True, [(3, 1.0)], 5.0) == -1
    assert rules.pick_informer(False, [(3, 1.0), (4, 2.0), (5, 6.0)], 5.0) == 4
    assert rules.pick_informer(False, [(5, 6.0)], 5.0) is None


@pytest.mark.parametrize("bad", [math.nan, math.inf, -0.1, 2 * math.pi, 7.0, "1.0", True])
def test_bad_angles_are_refused(bad):
    assert not rules.angle_ok(bad)
    cause = "angle" if isinstance(bad, float) else "bad_field"  # not a number at all: the typed decoder's cause
    assert parse_t({"a": 0, "T": bad, "al": False, "d": 1.0, "v": [0.0, 0.0]})[1] == cause
    assert parse_t({"a": -1, "T": [0.5, bad], "al": True, "d": 0.0})[1] == cause
    assert parse_m({"M": [[2, 0.3], [7, bad]]}, 7) == (None, cause)


def test_good_and_malformed_messages():
    assert parse_t({"a": 1, "T": 0.5, "al": True, "d": 2.0, "v": [0.1, 0.0]})[1] is None
    assert parse_t({"a": 1, "T": None, "al": False, "d": None})[1] is None
    assert parse_t([1, 2])[1] == "not_a_map"
    assert parse_t({"a": 1, "T": 0.5, "d": -1.0})[1] == "bad_field"
    assert parse_m({"M": [[2, 0.3]]}, 7) == (None, None)
    assert parse_m({"M": [[7, 0.3]]}, 7) == (0.3, None)
    assert parse_m({"M": "x"}, 7) == (None, "bad_field")


class _Ctx:
    """The two members on_frame reads (a unit test of the refusal path, below the runtime)."""

    id = 7
    clock = "lockstep"
    dt = 0.1
    pose = np.array([0.0, 0.0, 0.0])


def test_behaviour_refuses_and_counts_bad_frames():
    b = SECS()
    ctx = _Ctx()
    b.on_frame(ctx, Frame(src=2, kind="SECS_T", body={"a": 0, "T": math.nan, "d": 1.0}, seq=1, sent=3))
    b.on_frame(ctx, Frame(src=2, kind="SECS_M", body={"M": [[7, 9.0]]}, seq=2, sent=3, rab=(1.0, 0.2)))
    b.on_frame(ctx, Frame(src=2, kind="SECS_M", body=None, seq=3, sent=3, rab=(1.0, 0.2)))
    assert b.refused == {"angle": 2, "not_a_map": 1}
    assert b.info == {} and b.seen_by == {}
    b.on_frame(ctx, Frame(src=2, kind="SECS_M", body={"M": [[7, 1.0]]}, seq=4, sent=3, rab=(1.0, 0.2)))
    assert b.seen_by[2] == (3, 1.0, pytest.approx(0.2))
    assert b.report()["refused"] == {"angle": 2, "not_a_map": 1}


# ------------------------------------------------------------------------------------ the BMU's sequence (§III-C)
def _bmu(stage, slot, elapsed=0.0, *, last=False, duration=30.0, waited=None, gathered=False, settle_max=60.0):
    return rules.bmu_next(stage, slot, elapsed, last=last, duration=duration, waited=waited, gathered=gathered,
                          settle_max=settle_max)


def test_bmu_flocks_until_the_point_is_reached_in_closed_formation():
    assert _bmu("flocking", 0, 99.0, gathered=True) == ("flocking", 0)  # not at the point yet
    assert _bmu("flocking", 0, waited=0.0, gathered=False) == ("flocking", 0)  # there, swarm not gathered
    assert _bmu("flocking", 0, waited=0.0, gathered=True) == ("secs", 0)
    assert _bmu("flocking", 2, waited=60.0, gathered=False) == ("secs", 2)  # a lost robot does not block it


def test_bmu_erupts_for_the_slot_duration_then_regroups_and_moves_on():
    assert _bmu("secs", 0, 29.9, duration=30.0) == ("secs", 0)
    assert _bmu("secs", 0, 30.0, duration=30.0) == ("rendezvous", 0)
    assert _bmu("rendezvous", 0, 1.0, gathered=False) == ("rendezvous", 0)
    assert _bmu("rendezvous", 0, 1.0, gathered=True) == ("flocking", 1)
    assert _bmu("rendezvous", 0, 60.0, gathered=False) == ("flocking", 1)
    assert _bmu("rendezvous", 3, 999.0, gathered=True, last=True) == ("rendezvous", 3)  # the end: stay together
    with pytest.raises(ValueError):
        _bmu("dance", 0)


def test_bmu_walks_a_whole_schedule_in_order():
    durations, seen, stage, slot, t, since = [20.0, 10.0, 5.0], [], "flocking", 0, 0.0, 0.0
    while t < 500:
        at_point = t - since >= 7.0 if stage == "flocking" else False  # the flight takes 7 s
        nxt = rules.bmu_next(stage, slot, t - since, last=slot == 2, duration=durations[slot],
                             waited=(t - since - 7.0) if at_point else None, gathered=True, settle_max=60.0)
        if nxt != (stage, slot):
            stage, slot, since = *nxt, t
            seen.append((round(t, 1), slot, stage))
        t += 0.1
    assert [(s, st) for _, s, st in seen] == [(0, "secs"), (0, "rendezvous"), (1, "flocking"), (1, "secs"),
                                             (1, "rendezvous"), (2, "flocking"), (2, "secs"), (2, "rendezvous")]
    assert seen[1][0] == pytest.approx(27.0, abs=0.15)  # 7 s flight + 20 s eruption


def _contract(rule, pts, ticks=600, dt=0.1, vmax=0.15, rv=90.0):
    """A chain of robots (0 = the master, still) contracting for ``ticks``; returns the longest chain link seen."""
    pts = np.array(pts, dtype=float)
    worst = 0.0
    for _ in range(ticks):
        vel = np.zeros_like(pts)
        for i in range(1, len(pts)):
            nb = {j: (float(np.linalg.norm(pts[j] - pts[i])),
                      math.atan2(*(pts[j] - pts[i])[::-1])) for j in range(len(pts))
                  if j != i and np.linalg.norm(pts[j] - pts[i]) <= 3.0}
            parent = i - 1 if i - 1 in nb else None
            pulls = rules.gather_pulls(nb, parent, rv) if rule == "parent" else list(nb.values())
            vel[i] = rules.lj_velocity(pulls, rv, vmax)
        pts += vel * dt
        worst = max(worst, max(float(np.linalg.norm(pts[i] - pts[i - 1])) for i in range(1, len(pts))))
    return worst, pts


def test_rendezvous_towards_the_parent_keeps_a_stretched_arm_connected():
    """The arm of a real run at its rendez-vous (links 2.1–2.7 m): LJ of every neighbour breaks it."""
    arm = [[0.9, 0.2], [-0.2, 2.0], [-1.5, 4.1], [-2.2, 6.2]]
    assert _contract("all", arm)[0] > 3.0
    worst, end = _contract("parent", arm)
    assert worst <= 2.8
    # and it gathered: links at δ_rv = 0.9 m, the whole arm within the master's 3 m range
    assert max(float(np.linalg.norm(p - end[0])) for p in end) < 3.0


def test_gather_pulls_are_the_parent_and_the_too_close():
    nb = {3: (2.5, 0.0), 5: (0.5, 1.0), 7: (2.0, 2.0)}
    assert rules.gather_pulls(nb, 3, 90.0) == [(2.5, 0.0), (0.5, 1.0)]
    assert rules.gather_pulls(nb, None, 90.0) == [(0.5, 1.0)]


def test_schedule_parameter_is_validated():
    from protocols.secs.behavior import schedule_problem

    ok = {"robots": 4, "slots": [{"deployment": [0.0, 0.0], "duration": 10.0,
                                  "tasks": [{"id": "a", "position": [1.0, 1.0]}]}]}
    assert schedule_problem(ok) is None
    assert SECS.validate({"schedule": ok}) is None
    assert "no flock_at" in SECS.validate({"schedule": ok, "flock_at": 3.0})
    assert "slots[0].duration" in schedule_problem({"slots": [{**ok["slots"][0], "duration": -1}]})
    assert "slots[0].tasks" in schedule_problem({"slots": [{**ok["slots"][0], "tasks": []}]})
    assert "robots" in schedule_problem({**ok, "robots": 1})
    assert "non-empty" in schedule_problem({"slots": []})
    assert parse_t({"a": 0, "T": None, "d": 1.0, "ph": -1})[1] == "bad_field"
    assert parse_t({"a": 0, "T": None, "d": 1.0, "ph": 3})[1] is None
