"""Swarm Relays' 3-D planner (planner.Grid3: A* on voxels over the known map's prisms), below Zenoh."""

from __future__ import annotations

import math
import time

import numpy as np

from protocols.relays import planner
from protocols.relays.behavior import valid_plan
from protocols.relays.suite import window_wall
from swarmactors.robot.knownmap import KnownMap

BOX = [[-1.0, -3.0, 0.0], [7.0, 3.0, 2.5]]
WIN = {"x": (3.0, 3.5), "y": (-1.0, 1.0), "z": (0.8, 1.8)}  # the window in the wall x in [3, 3.5]


def _map(obstacles) -> KnownMap:
    """The known map of these boxes (resolved to polygons, as the world gives them to robots)."""
    xy = [{"xy": [[o["box"][0][0], o["box"][0][1]], [o["box"][1][0], o["box"][0][1]], [o["box"][1][0], o["box"][1][1]],
                  [o["box"][0][0], o["box"][1][1]]], "z": o["z"]} for o in obstacles]
    return KnownMap.from_spec({"dims": 3, "obstacles": xy, "map": None})


def _blocked(m: KnownMap):
    return lambda pts: m.inside_all(pts, ground=False)


def _segments_clear(m: KnownMap, pts, step: float = 0.02) -> bool:
    for a, b in zip(pts, pts[1:], strict=False):
        n = max(1, int(math.dist(a, b) / step))
        if any(m.inside(list(np.add(a, t * np.subtract(b, a))), ground=False) for t in np.linspace(0, 1, n + 1)):
            return False
    return True


def test_the_path_goes_through_the_window_at_its_height_and_nowhere_through_the_wall():
    m = _map(window_wall(x=WIN["x"], y_span=(-3.0, 3.0), window_y=WIN["y"], window_z=WIN["z"], top=2.5))
    grid = planner.Grid3(BOX, 0.25, _blocked(m), clearance=0.4)
    t0 = time.perf_counter()
    status, pts = planner.plan(grid, [0.0, 0.0, 0.0], [6.0, 0.0, 0.0], 20000)
    took = time.perf_counter() - t0
    assert status == "ok" and pts[0] == [0.0, 0.0, 0.0] and pts[-1] == [6.0, 0.0, 0.0]
    assert _segments_clear(m, pts)  # nowhere through the wall
    crossing = []  # where pi crosses the wall's mid-plane x = 3.25
    for a, b in zip(pts, pts[1:], strict=False):
        if (a[0] - 3.25) * (b[0] - 3.25) <= 0 and a[0] != b[0]:
            t = (3.25 - a[0]) / (b[0] - a[0])
            crossing.append([a[k] + t * (b[k] - a[k]) for k in range(3)])
    assert len(crossing) == 1
    _, y, z = crossing[0]
    assert WIN["y"][0] + 0.25 <= y <= WIN["y"][1] - 0.25 and WIN["z"][0] + 0.25 <= z <= WIN["z"][1] - 0.25
    # within a stated factor of the true shortest: no path is shorter than the one over the bare window's
    # bottom edge (z = 0.8, no clearance), L0; the continuous shortest path keeping the 0.4 m clearance is at
    # most Lc, the one over that edge raised by 0.4 m; the planner's path is within [L0, 1.05 Lc]
    def over(z):
        return math.hypot(3.0, z) + 0.5 + math.hypot(2.5, z)

    assert over(0.8) <= planner.length(pts) <= 1.05 * over(1.2)
    assert took < 5.0


def test_a_sealed_wall_gives_no_path_and_an_open_field_a_straight_one():
    sealed = _map([{"box": [[3.0, -3.0], [3.5, 3.0]], "z": [0.0, 2.5]}])
    grid = planner.Grid3(BOX, 0.25, _blocked(sealed), clearance=0.4)
    assert planner.plan(grid, [0.0, 0.0, 0.0], [6.0, 0.0, 0.0], 20000) == ("unreachable", [])
    assert planner.plan(grid, [0.0, 0.0, 0.0], [9.0, 0.0, 0.0], 20000) == ("outside", [])
    free = planner.Grid3(BOX, 0.25, _blocked(_map([])), clearance=0.4)
    assert planner.plan(free, [0.0, 0.0, 0.0], [6.0, 1.0, 0.0], 20000) == ("ok", [[0.0, 0.0, 0.0], [6.0, 1.0, 0.0]])
    assert planner.plan(free, [0.0, 0.0, 0.0], [6.0, 1.0, 0.0], 3)[0] == "budget"


def test_no_corner_cutting_between_voxels_touching_along_an_edge():
    # two blocked voxels touching along an edge: the diagonal move between them is refused
    hard = {(1, 0, 0), (0, 1, 0)}
    grid = planner.Grid3([[0, 0, 0], [2, 2, 1]], 1.0, lambda p: np.array([tuple(np.floor(q).astype(int)) in hard
                                                                          for q in p]))
    assert (1, 1, 0) not in [n for n, _ in grid.neighbours((0, 0, 0))]
    assert planner.plan(grid, [0.5, 0.5, 0.5], [1.5, 1.5, 0.5], 100)[0] == "unreachable"


def test_a_3d_plan_keeps_the_wire_format():
    """The tuple stays well formed: pi a 3-D polyline with altitude changes, pi_g its ground projection."""
    m = _map(window_wall(x=WIN["x"], y_span=(-3.0, 3.0), window_y=WIN["y"], window_z=WIN["z"], top=2.5))
    _, pts = planner.plan(planner.Grid3(BOX, 0.25, _blocked(m), clearance=0.4), [0, 0, 0], [6, 0, 0], 20000)
    pi = [[round(v, 4) for v in p] for p in pts]
    assert valid_plan({"pe": True, "pi": pi, "pig": [p[:2] for p in pi], "n": 5, "g": 2.5}) is None


def test_known_map_inside_all_agrees_with_inside():
    m = _map(window_wall(top=2.5))
    pts = np.random.default_rng(0).uniform([3.5, -2.0, 0.0], [5.0, 2.0, 2.5], size=(300, 3))
    assert m.inside_all(pts, ground=False).tolist() == [m.inside(list(p), ground=False) for p in pts]
    assert 0 < m.inside_all(pts, ground=False).sum() < len(pts) and m.inside_all(np.zeros((0, 3))).shape == (0,)


def test_arc_3d_lifts_a_ground_arc_length_onto_pi():
    pi = [[0.0, 0.0, 0.0], [3.0, 0.0, 4.0], [6.0, 0.0, 4.0]]  # a climb of slope 4/3, then level
    assert planner.arc_3d(pi, 1.5) == 2.5 and planner.arc_3d(pi, 4.0) == 6.0 and planner.arc_3d(pi, 99.0) == 8.0
