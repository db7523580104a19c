"""The world's space (issue 14), below Zenoh: obstacles, motion against them, occlusion, maps, collisions."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely.geometry import LineString, Polygon, box

from swarmactors.oracle.occlusion_oracle import Occluders
from swarmactors.robot.knownmap import KnownMap
from swarmactors.runs import maps
from transport.scenario import robot_spec
from transport.space import Space, convex, space_from_spec
from world.registry import Robots
from world.space import SpaceRules

WALL = {"xy": [[4.0, 0.0], [5.0, 0.0], [5.0, 10.0], [4.0, 10.0]], "z": [0.0, 2.0]}  # a wall 2 high at x in [4, 5]
# a wall with a window between heights 1 and 1.5: two boxes
WINDOW = [{"xy": WALL["xy"], "z": [0.0, 1.0]}, {"xy": WALL["xy"], "z": [1.5, 3.0]}]


def robots(specs, dims):
    """Robots from spec tables, checked and completed as a control add's (a radio range of 1)."""
    r = Robots(dims)
    r.add([robot_spec(s, dims, 1.0) for s in specs], tick=0)
    return r


def step(world: dict, specs: list[dict], vel: list[list[float]], ticks: int = 1, dt: float = 1.0) -> np.ndarray:
    """Move robots with constant velocities through the world's space rules; final positions."""
    from world.kinematics import integrate

    dims = world.get("dims", 2)
    r = robots(specs, dims)
    rules = SpaceRules(space_from_spec(world), dims, occlusion=False, blocking=bool(world.get("blocking")))
    r.vel[:] = np.array(vel, dtype=float)
    for _ in range(ticks):
        before = r.pos.copy()
        integrate(r.pos, r.heading, r.vel, r.speed, r.turn_rate, r.alive, dt, None)
        rules.constrain(before, r.pos, r, dt)
        rules.unblock_bodies(before, r.pos, r)
    return r.pos


# ------------------------------------------------------------------------------------------------ motion
def test_a_wall_stops_a_ground_robot_and_not_a_flying_one_above_it():
    world = {"dims": 3, "obstacles": [WALL]}
    specs = [{"pos": [2.0, 5.0, 0.0], "speed": 1.0},
             {"pos": [2.0, 5.0, 2.5], "speed": 1.0, "kind": "flying"}]
    pos = step(world, specs, [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]], ticks=6)
    assert pos[0, 0] == pytest.approx(4.0, abs=1e-5) and pos[0, 0] < 4.0  # stopped at the wall's face
    assert pos[0, 2] == 0.0
    assert pos[1, 0] == pytest.approx(8.0)  # flew over it


def test_a_window_lets_a_flying_robot_through_at_its_height_only():
    world = {"dims": 3, "obstacles": WINDOW}
    specs = [{"pos": [2.0, 5.0, z], "speed": 1.0, "kind": "flying"} for z in (0.5, 1.2, 2.0)]
    pos = step(world, specs, [[1.0, 0.0, 0.0]] * 3, ticks=6)
    assert pos[0, 0] < 4.0 and pos[2, 0] < 4.0
    assert pos[1, 0] == pytest.approx(8.0)


def test_in_2d_flying_robots_cross_walls_and_water_stops_only_ground_robots():
    rows = ["....W.....", "....W....."]
    grid = maps.parse_map(["type octile", "height 2", "width 10", "map", *rows])
    world = {"dims": 2, "obstacles": [WALL], "map": grid | {"origin": [0.0, 20.0]}}
    specs = [{"pos": [2.0, 5.0], "speed": 1.0}, {"pos": [2.0, 5.0], "speed": 1.0, "kind": "flying"},
             {"pos": [2.5, 21.0], "speed": 1.0}, {"pos": [2.5, 21.0], "speed": 1.0, "kind": "flying"}]
    pos = step(world, specs, [[1.0, 0.0]] * 4, ticks=6)
    assert pos[0, 0] < 4.0 and pos[1, 0] == pytest.approx(8.0)
    assert pos[2, 0] < 4.0 and pos[3, 0] == pytest.approx(8.5)


def test_flying_robots_keep_their_altitude_limits_and_climb_rate():
    world = {"dims": 3}
    specs = [{"pos": [0.0, 0.0, 1.0], "kind": "flying", "altitude": [0.5, 3.0], "climb_rate": 0.5, "speed": 10.0}]
    pos = step(world, specs, [[0.0, 0.0, 5.0]], ticks=1)
    assert pos[0, 2] == pytest.approx(1.5)  # climbed at most 0.5 per second
    pos = step(world, specs, [[0.0, 0.0, 5.0]], ticks=10)
    assert pos[0, 2] == pytest.approx(3.0)  # and no higher than its ceiling


def test_blocking_bodies_cannot_overlap():
    world = {"dims": 2, "blocking": True}
    specs = [{"pos": [0.0, 0.0], "body_radius": 0.5, "speed": 1.0}, {"pos": [3.0, 0.0], "body_radius": 0.5}]
    pos = step(world, specs, [[1.0, 0.0], [0.0, 0.0]], ticks=5)
    assert np.linalg.norm(pos[0] - pos[1]) >= 1.0
    assert pos[0, 0] == pytest.approx(2.0)  # it moved until the next step would overlap


# ------------------------------------------------------------------------------------------------ occlusion
def random_prisms(rng, n, flat):
    out = []
    for _ in range(n):
        c = rng.uniform(1, 9, 2)
        w, h = rng.uniform(0.3, 2.0, 2)
        xy = [[c[0] - w, c[1] - h], [c[0] + w, c[1] - h], [c[0] + w, c[1] + h], [c[0] - w, c[1] + h]]
        lo, hi = sorted(rng.uniform(0, 3, 2).round(3).tolist())
        z = None if flat else [lo, max(hi, lo + 0.001)]  # z0 < z1, as a scenario must give them
        out.append({"xy": xy, "z": z})
    return out


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), flat=st.booleans())
def test_occlusion_of_prisms_agrees_with_shapely(seed, flat):
    rng = np.random.default_rng(seed)
    world = {"dims": 2 if flat else 3, "obstacles": random_prisms(rng, 3, flat)}
    space = space_from_spec(world)
    a = np.column_stack([rng.uniform(0, 10, (60, 2)), np.zeros(60) if flat else rng.uniform(0, 3, 60)])
    b = np.column_stack([rng.uniform(0, 10, (60, 2)), np.zeros(60) if flat else rng.uniform(0, 3, 60)])
    got = space.blocked(a, b)
    oracle = Occluders(world)
    want = [oracle.blocks(p, q) for p, q in zip(a, b, strict=True)]
    assert got.tolist() == want


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_occlusion_of_a_grid_agrees_with_a_segment_test_on_its_cells(seed):
    """Grid occlusion against shapely boxes of the blocked cells, an independent test per segment."""
    rng = np.random.default_rng(seed)
    rows = ["".join("@" if rng.random() < 0.15 else "." for _ in range(12)) for _ in range(9)]
    grid = maps.parse_map(["type octile", "height 9", "width 12", "map", *rows], cell=0.7, origin=(1.0, -2.0))
    space = space_from_spec({"dims": 2, "map": grid})
    cells = [box(1.0 + c * 0.7, -2.0 + (8 - r) * 0.7, 1.0 + (c + 1) * 0.7, -2.0 + (9 - r) * 0.7)
             for r, row in enumerate(rows) for c, ch in enumerate(row) if ch == "@"]
    a = np.column_stack([rng.uniform(0, 10, (50, 2)) - [0, 2], np.zeros(50)])
    b = np.column_stack([rng.uniform(0, 10, (50, 2)) - [0, 2], np.zeros(50)])
    got = space.blocked(a, b)
    want = [any(LineString([p[:2], q[:2]]).intersection(c).length > 1e-9 for c in cells) for p, q in zip(a, b,
                                                                                                         strict=True)]
    assert got.tolist() == want


def test_occlusion_drops_exactly_the_links_that_cross_the_wall():
    rules = SpaceRules(space_from_spec({"dims": 2, "obstacles": [WALL]}), 2, occlusion=True, blocking=False)
    pos = np.array([[2.0, 5.0], [7.0, 5.0], [3.0, 5.0], [2.0, 11.0], [7.0, 11.0]])
    src = np.array([0, 0, 1, 3, 0])
    dst = np.array([1, 2, 2, 4, 3])
    assert rules.occluded(pos, src, dst).tolist() == [True, False, True, False, False]


def test_first_hit_is_where_the_segment_enters():
    space = Space([maps_prism(WALL)], None, flat=True)
    t = space.first_hit(np.array([[0.0, 5.0, 0.0]]), np.array([[8.0, 5.0, 0.0]]))
    assert t[0] == pytest.approx(0.5)


def maps_prism(ob):
    from transport.space import Prism

    return Prism(np.array(ob["xy"]), (-np.inf, np.inf))


def test_convex_check():
    assert convex(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float))
    assert not convex(np.array([[0, 0], [2, 0], [1, 0.2], [2, 2], [0, 2]], dtype=float))
    assert not convex(np.array([[0, 0], [1, 1], [2, 2]], dtype=float))


# ------------------------------------------------------------------------------------------------ maps
def write(tmp_path, text: str):
    p = tmp_path / "m.map"
    p.write_text(text)
    return p


def test_moving_ai_reader_reads_every_character(tmp_path):
    p = write(tmp_path, "type octile\nheight 3\nwidth 5\nmap\n.GS@O\nTW.A.\n...X.\n")
    m = maps.read_map(p, tree_height=2.0, cell=2.0)
    assert m["markers"] == {"A": [[7.0, 3.0]], "X": [[7.0, 1.0]]}
    low, high = m["layers"]
    assert low["z"] == [None, 2.0] and high["z"] == [2.0, None]
    assert low["rows"] == ["...@@", "@....", "....."] and high["rows"] == ["...@@", ".....", "....."]
    assert m["water"] == [".....", ".W...", "....."]
    space = space_from_spec({"dims": 3, "map": m})
    # the tree (row 1, col 0: x in [0, 2], y in [2, 4]) blocks below 2 only
    assert space.inside(np.array([[1.0, 3.0, 1.0], [1.0, 3.0, 2.5]])).tolist() == [True, False]
    # water stops ground robots only
    assert space.inside(np.array([[3.0, 3.0, 0.0]]), ground=True).tolist() == [True]
    assert space.inside(np.array([[3.0, 3.0, 0.0]]), ground=False).tolist() == [False]


@pytest.mark.parametrize("text,where,message", [
    ("type octile\nheight 2\nwidth 3\nmap\n...\n.?.\n", "m.map:6:2", "unknown map character '?'"),
    ("type octile\nheight 2\nwidth 3\nmap\n...\n..\n", "m.map:6", "row has 2 characters"),
    ("type octile\nheight 3\nwidth 3\nmap\n...\n...\n", "m.map", "has 2 map rows"),
    ("type hex\nheight 3\nwidth 3\nmap\n", "m.map", "type must be"),
    ("type octile\nwidth 3\n", "m.map:2", "expected 'height'"),
    ("type octile\nheight x\nwidth 3\nmap\n", "m.map", "'height' must be a positive integer"),
])
def test_moving_ai_reader_errors_name_the_line_and_column(tmp_path, text, where, message):
    p = write(tmp_path, text)
    with pytest.raises(maps.MapError) as err:
        maps.read_map(p)
    assert err.value.where.endswith(where) and message in err.value.message


def test_a_3d_map_is_a_stack_of_planes(tmp_path):
    p = write(tmp_path, "type octile3d\nheight 1\nwidth 3\nlayers 2\nlayer 0 1\n@@.\nlayer 1 2\n.@@\n")
    m = maps.read_map(p)
    space = space_from_spec({"dims": 3, "map": m})
    pts = np.array([[0.5, 0.5, 0.5], [0.5, 0.5, 1.5], [2.5, 0.5, 1.5], [2.5, 0.5, 0.5], [0.5, 0.5, 2.5]])
    assert space.inside(pts).tolist() == [True, False, True, False, False]
    bad = write(tmp_path, "type octile3d\nheight 1\nwidth 1\nlayers 2\nlayer 0 1\n.\nlayer 2 3\n.\n")
    with pytest.raises(maps.MapError, match="touch the previous one"):
        maps.read_map(bad)


def test_the_maze_is_perfect_and_connected():
    import networkx as nx

    rows = maps.maze(5, 4, seed=2)
    free = {(r, c) for r, row in enumerate(rows) for c, ch in enumerate(row) if ch == "."}
    g = nx.grid_2d_graph(len(rows), len(rows[0]))
    assert nx.is_connected(g.subgraph(free))
    assert len(rows) == 4 * 3 + 1 and len(rows[0]) == 5 * 3 + 1
    assert maps.maze(5, 4, seed=2) == rows and maps.maze(5, 4, seed=3) != rows


def test_c_shape_is_three_boxes_open_towards_its_opening():
    boxes = maps.c_shape([0.0, 0.0], 4.0, 0.5, "+x")
    space = space_from_spec({"dims": 2, "obstacles": boxes})
    assert len(boxes) == 3
    assert not space.blocked(np.array([[0.0, 0.0, 0]]), np.array([[5.0, 0.0, 0]]))[0]  # out through the opening
    assert space.blocked(np.array([[0.0, 0.0, 0]]), np.array([[-5.0, 0.0, 0]]))[0]
    union = Polygon()
    for b in boxes:
        union = union.union(Polygon(b["xy"]))
    assert union.area == pytest.approx(4 * 4 - 3.5 * 3)


# ------------------------------------------------------------------------------------------------ collisions
def test_collision_episodes_start_and_end_once():
    r = robots([{"pos": [0.0, 0.0], "body_radius": 0.5}, {"pos": [3.0, 0.0], "body_radius": 0.5},
                {"pos": [4.3, 0.0], "body_radius": 0.2}], 2)
    rules = SpaceRules(space_from_spec({"dims": 2, "obstacles": [maps.box([10, -1], [11, 1])]}), 2, False, False)
    track = {0: [0.0, 2.0, 2.2, 2.5, 0.0, 0.0], 2: [4.3, 4.3, 4.3, 9.9, 9.9, 9.0]}
    events = []
    for t in range(6):
        r.pos[0, 0] = track[0][t]
        r.pos[2, 0] = track[2][t]
        events += rules.collisions(t, r.pos, r)
    events += rules.close(6)
    robot_robot = [e for e in events if e["collision"][1] != "obstacle"]
    # at tick 1 the bodies touch (1.0 apart, radii 0.5 + 0.5): touching is not overlapping
    assert robot_robot == [{"collision": [0, 1], "start": 2, "end": 4}]
    obstacle = [e for e in events if e["collision"][1] == "obstacle"]
    assert obstacle == [{"collision": [2, "obstacle", 0], "start": 3, "end": 5}]  # 1.0 from the box at tick 5
    assert rules.summary()["robot_robot"] == 1 and rules.summary()["robot_obstacle"] == 1


def test_known_map_is_the_worlds_map_and_each_robot_has_its_own_copy():
    spec = {"dims": 2, "obstacles": [WALL], "map": None}
    a, b = KnownMap.from_spec(spec), KnownMap.from_spec(spec)
    assert a.inside([4.5, 5.0]) and not a.inside([3.0, 5.0])
    assert not a.clear([0, 5], [8, 5]) and a.clear([0, 12], [8, 12])
    a.obstacles[0]["xy"].clear()
    assert b.obstacles[0]["xy"] and a.obstacles[0]["xy"]
    assert a._space is not b._space


def test_rays_measure_the_distance_to_the_wall():
    rules = SpaceRules(space_from_spec({"dims": 2, "obstacles": [WALL]}), 2, occlusion=False, blocking=False)
    pos = np.array([[2.0, 5.0]])
    out = rules.rays(pos, np.array([0.0]), np.array([3.0]), np.array([4]), np.array([0]))
    assert out[0][0] == pytest.approx(2.0) and out[0][1:] == [np.inf] * 3


def test_the_one_who_is_in_range_leaves_out_occluded_links_and_placement_respects_it():
    """mutual_links with the occluding space (issue 13's one rule).

    A link through the wall is not a link; a connected placement with occlusion on is connected in the
    occlusion-aware graph (checked with shapely).
    """
    import networkx as nx

    from swarmactors.runs.scenario import mutual_links, resolve_scenario

    space = space_from_spec({"dims": 2, "obstacles": [WALL]})
    pos = np.array([[3.5, 5.0], [5.5, 5.0], [3.5, 6.0]])
    assert mutual_links(pos, np.full(3, 3.0)) == [(0, 1), (0, 2), (1, 2)]
    assert mutual_links(pos, np.full(3, 3.0), space) == [(0, 2)]
    sc = resolve_scenario({"run": {"ticks": 1, "seed": 4}, "radio": {"range": 2.5, "occlusion": True},
                           "world": {"bounds": [[0, 0], [10, 10]],
                                     "obstacles": [{"box": [[4.0, 0.0], [5.0, 7.0]]}]},
                           "robots": [{"count": 25, "connected": True}]}, "<test>")
    pts = np.array(sc["robots"][0]["positions"])
    oracle = Occluders(sc["world"])
    g = nx.Graph()
    g.add_nodes_from(range(len(pts)))
    g.add_edges_from((a, b) for a in range(len(pts)) for b in range(a + 1, len(pts))
                     if np.linalg.norm(pts[a] - pts[b]) <= 2.5 and not oracle.blocks(pts[a], pts[b]))
    assert nx.is_connected(g)


def test_in_2d_a_flying_body_over_an_obstacle_is_no_collision_and_ctx_tells_the_kind():
    """Flying robots pass over obstacles in a 2-D world, so their bodies do not collide with them.

    A behaviour reads its robot's kind from the context (found missing by the Swarm Relays work).
    """
    from swarmactors.robot.behavior import Context

    r = robots([{"pos": [4.5, 5.0], "body_radius": 0.3}, {"pos": [4.5, 5.0], "body_radius": 0.3, "kind": "flying"}],
               2)
    rules = SpaceRules(space_from_spec({"dims": 2, "obstacles": [WALL]}), 2, False, False)
    r.pos[1] = [4.5, 8.0]  # apart from robot 0, both inside the wall's footprint
    rules.collisions(0, r.pos, r)
    assert set(rules.open) == {(0, "obstacle", 0)}
    assert Context(1, np.random.default_rng(0), "lockstep", kind="flying").kind == "flying"
