"""Swarm Relays' pure rules (protocols/relays: zones, planner, motion, plan validation), below Zenoh."""

from __future__ import annotations

import math

import numpy as np
import pytest

from protocols.relays import motion, oracle, planner
from protocols.relays.behavior import Relays, valid_plan
from protocols.relays.messages import Chain
from protocols.relays.zones import BREAKAWAY, CRITICAL, OUT, SAFE, link_quality, robots_needed, zone
from swarmactors import Result

DS, DC, DB = 1.4, 1.6, 1.8


def test_zones_and_link_quality_follow_sec_iii_a():
    assert [zone(d, DS, DC, DB) for d in (0.5, 1.4, 1.5, 1.6, 1.7, 1.8, 1.81)] == [
        SAFE, SAFE, CRITICAL, CRITICAL, BREAKAWAY, BREAKAWAY, OUT]
    assert link_quality(0.1, 2.0, 0.15) == 1.0  # d < delta
    assert link_quality(1.4, 2.0, 0.15) == pytest.approx(math.exp(-0.15 * 1.4 / 2.0))
    assert link_quality(2.01, 2.0, 0.15) == 0.0
    assert robots_needed(8.0, DS) == 6 and robots_needed(2.8, DS) == 2 and robots_needed(0.1, DS) == 1


def _box(x0, y0, x1, y1):
    return lambda x, y: x0 <= x <= x1 and y0 <= y <= y1


def test_planner_goes_around_a_wall_and_keeps_its_clearance():
    wall = _box(2.0, -3.0, 2.4, 3.0)
    grid = planner.Grid([[-1.0, -5.0], [6.0, 5.0]], 0.25, wall, clearance=0.4)
    status, pts = planner.plan(grid, [0.0, 0.0], [5.0, 0.0], 100000)
    assert status == "ok" and pts[0] == [0.0, 0.0] and pts[-1] == [5.0, 0.0]
    assert planner.length(pts) > 2 * math.hypot(2.0, 3.0)  # around the end of the wall, not through it
    for a, b in zip(pts, pts[1:], strict=False):  # no segment crosses the wall
        for t in np.linspace(0, 1, 200):
            assert not wall(a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]))


def test_planner_reports_unreachable_outside_and_budget():
    ring = lambda x, y: 1.0 <= math.hypot(x - 4, y) <= 1.5  # noqa: E731 - a closed ring around (4, 0)
    grid = planner.Grid([[-1.0, -3.0], [7.0, 3.0]], 0.2, ring)
    assert planner.plan(grid, [0.0, 0.0], [4.0, 0.0], 100000) == ("unreachable", [])
    assert planner.plan(grid, [0.0, 0.0], [9.0, 0.0], 100000) == ("outside", [])
    assert planner.plan(grid, [0.0, 0.0], [6.5, 2.5], 3) == ("budget", [])
    a = planner.plan(grid, [0.0, 0.0], [6.5, 2.5], 100000)
    assert a == planner.plan(grid, [0.0, 0.0], [6.5, 2.5], 100000)  # deterministic


def test_eq6_7_forward_backward_and_fc():
    uf, ub = np.array([0.5, 0.0]), np.array([-0.5, 0.0])
    assert motion.preferred(uf, ub, 1.0, None, DS).tolist() == [0.5, 0.0]  # worker: no child, f_c = 1
    assert motion.preferred(uf, ub, 1.0, 1.5, DS).tolist() == [0.0, 0.0]  # child beyond d_s: stop
    assert motion.preferred(uf, ub, 1.0, 1.5, DS, to_child=np.array([1.0, 0.0])).tolist() == [0.5, 0.0]
    assert motion.preferred(uf, ub, 1.5, 1.0, DS).tolist() == [-0.5, 0.0]  # parent beyond d_s: back


def test_eq8_reading_bounds_only_separation_and_keeps_pairs_within_ds():
    dt, v = 0.2, 0.5
    x, parent = np.array([1.3, 0.0]), np.array([0.0, 0.0])
    u = motion.constrain(np.array([0.4, 0.3]), x, [(parent, DS)], [], 0.25, dt, v)
    assert u[0] == pytest.approx((DS - 1.3) / (2 * dt)) and u[1] == pytest.approx(0.3)  # across: free
    u = motion.constrain(np.array([0.5, 0.0]), np.array([1.5, 0.0]), [(parent, DS)], [], 0.25, dt, v)
    assert u[0] <= 0.0  # Eq. 4: beyond d_s a pair may only close up
    assert motion.constrain(np.array([-0.5, 0.0]), x, [(parent, DS)], [], 0.25, dt, v)[0] == -0.5  # closing: free
    # both robots of a pair apply it: the pair ends within d_s (plus the across drift)
    a, b = np.array([0.0, 0.0]), np.array([1.35, 0.0])
    ua = motion.constrain(np.array([-0.5, 0.0]), a, [(b, DS)], [], 0.25, dt, v)
    ub = motion.constrain(np.array([0.5, 0.0]), b, [(a, DS)], [], 0.25, dt, v)
    assert np.linalg.norm((b + ub * dt) - (a + ua * dt)) <= DS + 1e-9


def test_path_following_tracks_arc_and_stops_at_the_end():
    p, cum = motion.arc_points([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]])
    assert cum.tolist() == [0.0, 2.0, 4.0]
    assert motion.point_at(p, cum, 3.0).tolist() == [2.0, 1.0]
    s = motion.project(p, cum, np.array([2.1, 1.0]))
    assert s == pytest.approx(3.0)
    u = motion.u_path(p, cum, s, np.array([2.0, 1.0]), True, 0.5, 0.2, 0.5)
    assert u.tolist() == pytest.approx([0.0, 0.5])
    u = motion.u_path(p, cum, 4.0, np.array([2.0, 1.95]), True, 0.5, 0.2, 0.5)
    assert u.tolist() == pytest.approx([0.0, 0.25])  # the last step lands on the end


@pytest.mark.parametrize("value,why", [
    ("path", "not a table"),
    ({"pe": 1, "pi": [], "pig": [], "n": 1}, "pe is not a boolean"),
    ({"pe": True, "pi": "x", "pig": [[0, 0], [1, 1]], "n": 1}, "pi is not a list of at least 2 points"),
    ({"pe": True, "pi": [[0, 0], [1, float("nan")]], "pig": [[0, 0], [1, 1]], "n": 1}, "pi has a point"),
    ({"pe": True, "pi": [[0, 0], [1, 1]], "pig": [[0, 0], [1, 1]], "n": 0}, "n is not a positive integer"),
])
def test_a_malformed_plan_is_refused_with_its_reason(value, why):
    assert valid_plan(value).startswith(why)
    assert valid_plan({"pe": True, "pi": [[0, 0, 0], [1, 1, 0]], "pig": [[0, 0], [1, 1]], "n": 1}) is None
    assert valid_plan({"pe": False, "pi": [], "pig": [], "n": 0, "why": "unreachable"}) is None


@pytest.mark.parametrize("params,fragment", [
    ({}, "targets"),
    ({"targets": [[1, "a"]]}, "targets"),
    ({"targets": [[1, 0]], "ds": 1.7}, "ds < dc < db"),
    ({"targets": [[1, 0]], "vmax": 0}, "vmax"),
    ({"targets": [[1, 0]], "area": [[5, 0], [0, 5]]}, "area"),
    ({"targets": [[1, 0]], "k": 0}, "k = 0"),
    ({"targets": [[1, 0]], "wp": "yes"}, "wp"),
    ({"targets": [[1, 0]], "chains_per_target": 0}, "chains_per_target = 0"),
    ({"targets": [[1, 0]], "spacing": -0.3}, "spacing"),
    ({"targets": [[1, 0]], "air": [2.0, 1.0]}, "air = [2.0, 1.0]"),
    ({"targets": [[1, 0]], "air": 2.5}, "air = 2.5"),
])
def test_bad_parameters_are_refused(params, fragment):
    assert fragment in Relays.validate(params)
    assert Relays.validate({"targets": [[8.0, 0.0]]}) is None


def test_ground_reach_ends_where_the_path_meets_a_ground_obstacle():
    wall = _box(4.0, -5.0, 4.6, 5.0)
    assert planner.ground_reach([[0.0, 0.0], [8.0, 0.0]], wall, 0.4) == pytest.approx(3.6 - 0.4, abs=0.06)
    assert planner.ground_reach([[0.0, 0.0], [3.0, 0.0]], wall, 0.4) == pytest.approx(3.0)


def test_ground_reach_is_not_cut_by_a_wall_the_path_passes_closer_than_the_clearance():
    """Only a wall across the path ends the ground part.

    A path planned at resolution R keeps its clearance at cell centres only: between them (a maze corner) it may
    pass 0.5 m from a wall a ground robot still passes; the ground part ends ``clearance`` before the point where
    the body (r_col / 2) touches a wall.
    """
    corner = _box(2.0, 0.5, 3.0, 4.0)  # 0.5 m beside the path, within the 1 m clearance
    across = _box(6.0, -5.0, 6.5, 5.0)
    both = lambda x, y: corner(x, y) or across(x, y)  # noqa: E731
    path = [[0.0, 0.0], [10.0, 0.0]]
    assert planner.ground_reach(path, both, 1.0) < 1.0  # the old reading: cut beside the corner, not at the wall
    assert planner.ground_reach(path, both, 1.0, body=0.125) == pytest.approx(6.0 - 0.125 - 1.0, abs=0.06)
    assert Relays.validate({"targets": [[1, 0]], "kind": "boat"}).startswith("kind")


def test_redundant_chains_run_side_by_side_parallel_to_pi_and_clear_of_walls():
    """Sec. III-C: C_n chains per target; copy j of target t is chain t C_n + j, (j - (C_n - 1)/2) * 0.3 m aside."""
    assert [Relays([[1, 0]], chains_per_target=3).side(c) for c in range(6)] == pytest.approx(
        [-0.3, 0.0, 0.3, -0.3, 0.0, 0.3])
    assert Relays([[1, 0]]).side(4) == 0.0  # C_n = 1: every chain on pi itself
    assert [Relays([[1, 0]], chains_per_target=2).side(c) for c in range(2)] == pytest.approx([-0.15, 0.15])
    pts = [[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]]
    left = planner.offset(pts, 0.3)
    assert left == [[0.0, 0.3], [3.7, 0.3], [3.7, 3.7], [0.0, 3.7]]  # inside the turns: shorter
    assert planner.offset(pts, -0.3) == [[0.0, -0.3], [4.3, -0.3], [4.3, 4.3], [0.0, 4.3]]
    assert planner.offset(pts, 0.0) == pts and planner.offset([[1.0, 1.0], [1.0, 1.0], [2.0, 1.0]], 0.1) == [
        [1.0, 1.1], [2.0, 1.1]]
    # planned with 0.3 m more clearance, the shifted path stays as clear of the wall as a plain plan (~0.3 m
    # here, the grid's quantisation included): two body radii at least
    wall = _box(2.0, -3.0, 2.4, 3.0)
    grid = planner.Grid([[-1.0, -5.0], [6.0, 5.0]], 0.25, wall, clearance=0.4 + 0.3)
    status, path = planner.plan(grid, [0.0, 0.0], [5.0, 0.0], 100000)
    assert status == "ok"

    def gap(x, y):
        return math.hypot(max(2.0 - x, 0, x - 2.4), max(-3.0 - y, 0, y - 3.0))

    for o in (-0.3, 0.3):
        shifted = planner.offset(path, o)
        assert min(gap(a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]))
                   for a, b in zip(shifted, shifted[1:], strict=False) for t in np.linspace(0, 1, 100)) >= 0.25


def _chains_result(parents: dict[int, int]) -> Result:
    """A one-tick trace: root 0, workers 1 (chain 0) and 2 (chain 1) of one target (C_n = 2), networkers 3, 4."""
    pos = {0: (0, 0), 1: (2.0, 0.2), 2: (2.0, -0.2), 3: (1.0, 0.2), 4: (1.0, -0.2)}
    status = {0: {"role": "root"}, 1: {"role": "worker", "chain": 0}, 2: {"role": "worker", "chain": 1},
              3: {"role": "networker", "chain": 0}, 4: {"role": "networker", "chain": 1}}
    for r, p in parents.items():
        status[r]["parent"] = p
    spec = {"use": "relays", "as": "relays", "targets": [[2.0, 0.0]], "chains_per_target": 2}
    result = Result({"robots": {str(i): {"range": 2.0} for i in pos},
                     "scenario": {"run": {"dt": 1.0}, "robots": [{"behaviors": [spec]}]}})
    result.__dict__["trace"] = [{"t": 0, "pos": [[i, *p] for i, p in pos.items()],
                                 "status": {str(i): s for i, s in status.items()}}]
    return result


def test_connected_requires_the_chains_of_one_target_to_share_only_the_root():
    (ok,) = oracle.connected(_chains_result({1: 3, 3: 0, 2: 4, 4: 0}))
    assert ok.passed
    (shared,) = oracle.connected(_chains_result({1: 3, 3: 0, 2: 3, 4: 0}))  # both workers hang on robot 3
    assert not shared.passed and "sharing a robot" in shared.detail


def test_a_parent_that_announces_itself_free_is_lost_and_join_time_defaults_to_link_fail():
    """R5/R6: a recruit released (free) just as its child took it must not stay that child's parent."""
    from types import SimpleNamespace

    r = Relays([[8.0, 0.0]], root=0)
    r.role, r.chain, r.parent, r.child = "networker", 0, 7, 9
    r._on_chain(SimpleNamespace(tick=5, id=3), 7, Chain("free"))
    assert r.parent is None and r.parent_lost and r.chain == 0  # the chain id is not taken from a free robot
    r.parent = 0
    r._on_chain(SimpleNamespace(tick=6, id=3), 0, Chain("root", depth=0))
    assert r.parent == 0  # the root is never a lost parent
    assert r.times["join"] == r.times["fail"] == 5.0 and Relays([[1, 0]], join_time=30.0).times["join"] == 30.0


def test_a_lost_parent_is_never_spliced_to_a_robot_last_heard_free():
    """R6 after R5: a recruit released before its child's ack reached it stays in the child's ``up`` list.

    Splicing to it made the free robot the parent again, the child dropped it at its next status, and so on
    to the end of the run (Fig. 6 bottom, f = 2, chain 17: the chain cut for 32 s). The splice goes on up the
    list, here to the root.
    """
    from types import SimpleNamespace

    r = Relays([[8.0, 0.0]], root=0)
    r.role, r.chain, r.parent, r.child, r.up = "networker", 0, 9, 7, [5, 9, 0]
    ctx = SimpleNamespace(tick=100, id=5, dt=0.2, position=[1.0, 0.0, 0.0])
    r.sensed = {9: np.array([1.5, 0.0]), 0: np.array([0.0, 0.0])}
    r._on_chain(ctx, 0, Chain("root", depth=0))
    r._on_chain(ctx, 9, Chain("free"))  # the recruit went back to free
    assert r.parent is None and r.parent_lost
    r._links(ctx)
    assert r.parent == 0 and not r.parent_lost and r.splices[-1] == [100, "parent", 0]
    # a chain robot of ``up`` is still a splice target
    r.parent, r.parent_lost, r.up = None, True, [5, 9, 0]
    r._on_chain(ctx, 9, Chain("networker", chain=0, depth=1))
    r._links(ctx)
    assert r.parent == 9
