"""The world's space end to end (issue 14).

A flood in a maze with occlusion, ground and flying robots, bodies and collisions, the known map and rays,
the same trace hash with 1 and 3 host processes, bad input.
"""

from __future__ import annotations

import json
from pathlib import Path

import networkx as nx
import numpy as np
import pytest
from shapely.geometry import LineString, box

from swarmactors.exitcodes import EXIT_INPUT
from swarmactors.runs.launcher import run
from swarmactors.runs.scenario import load

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"
MAZE = SCENARIOS / "maze-flood.toml"


def occlusion_aware_graph(sc: dict, ids: list[int], pos: np.ndarray) -> nx.Graph:
    """Mutual links in range that cross no wall cell: computed here, cell by cell, with shapely."""
    m = sc["world"]["map"]
    cell, (x0, y0) = m["cell"], m["origin"]
    rows = m["layers"][0]["rows"]
    h = len(rows)
    walls = [box(x0 + c * cell, y0 + (h - 1 - r) * cell, x0 + (c + 1) * cell, y0 + (h - r) * cell)
             for r, row in enumerate(rows) for c, ch in enumerate(row) if ch == "@"]
    rng = sc["radio"]["range"]
    g = nx.Graph()
    g.add_nodes_from(ids)
    for a in range(len(ids)):
        for b in range(a + 1, len(ids)):
            if np.linalg.norm(pos[a] - pos[b]) > rng:
                continue
            seg = LineString([pos[a], pos[b]])
            if not any(seg.intersection(w).length > 1e-9 for w in walls):
                g.add_edge(ids[a], ids[b])
    return g


@pytest.mark.slow
def test_a_flood_in_a_maze_with_occlusion_reaches_exactly_the_occlusion_aware_component(tmp_path):
    on = run(MAZE, out=tmp_path / "on", processes=0)
    off = run(MAZE, out=tmp_path / "off", processes=0, radio__occlusion=False)
    assert on.passed and off.passed, (on.checks, off.checks)  # flooding.reach against graph_at (occlusion-aware)
    assert on["world"]["dropped"]["occluded"] > 0 and off["world"]["dropped"]["occluded"] == 0
    reached_on = {rid for rid, r in on.reports("flooding").items() if r.get("received")}
    reached_off = {rid for rid, r in off.reports("flooding").items() if r.get("received")}
    assert len(reached_on) < len(reached_off)
    # robots do not move: the receivers are the origin's component in the graph computed in this test
    first = on.trace[0]
    ids = [row[0] for row in first["pos"]]
    pos = np.array([row[1:] for row in first["pos"]])
    g = occlusion_aware_graph(on["scenario"], ids, pos)
    assert reached_on | {0} == nx.node_connected_component(g, 0)
    assert nx.utils.graphs_equal(g, on.graph_at(0))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["maze-flood.toml", "ground-and-flying.toml"])
def test_same_trace_hash_with_one_and_three_host_processes(name, tmp_path):
    one = run(SCENARIOS / name, out=tmp_path / "k1", processes=1)
    three = run(SCENARIOS / name, out=tmp_path / "k3", processes=3)
    assert one["trace_hash"] == three["trace_hash"]


@pytest.mark.slow
def test_ground_robots_stay_west_of_the_wall_and_drones_cross_it_through_the_window(tmp_path):
    result = run(SCENARIOS / "ground-and-flying.toml", out=tmp_path, processes=0, run__ticks=240)
    xs = {}
    for rec in result.trace:
        for rid, x, _y, z in rec["pos"]:
            xs.setdefault(rid, []).append((x, z))
    sc = result["scenario"]
    ground = [i for i in range(sc["robots"][0]["count"])]
    flying = [i + len(ground) for i in range(sc["robots"][1]["count"])]
    for rid in ground:
        assert all(x < 9.5 and z == 0.0 for x, z in xs[rid]), rid
    for rid in flying:
        assert all(0.5 <= z <= 2.5 for _x, z in xs[rid])
    assert any(x > 10.5 for rid in flying for x, _z in xs[rid])  # some drone got through the window
    assert result["world"]["dropped"]["occluded"] > 0
    col = result["world"]["collisions"]
    assert col["robot_robot"] + col["robot_obstacle"] == len(col["episodes"])


@pytest.mark.slow
@pytest.mark.parametrize("processes", [0, 1])
def test_known_map_and_rays_reach_the_robot(tmp_path, processes):
    raw = {
        "run": {"name": "sees", "ticks": 2},
        "world": {"bounds": [[0, 0], [10, 10]], "obstacles": [{"box": [[4.0, 0.0], [5.0, 10.0]]}]},
        "robots": [{"positions": [[2.0, 5.0]], "knows_map": True, "obstacle_rays": 4, "sensing": 3.0,
                    "behaviors": [{"use": "behaviors_for_tests:SeesSpace"}]},
                   {"positions": [[7.0, 5.0]], "behaviors": [{"use": "behaviors_for_tests:SeesSpace"}]}],
    }
    result = run(raw, out=tmp_path, processes=processes)
    knows = result.robots[0]["sees_space"]["seen"]
    assert knows["knows"] and knows["inside"] and not knows["clear"] and knows["obstacles"] == 1
    # inf (no obstacle in range) becomes null in result.json
    assert knows["rays"][0] == pytest.approx(2.0) and knows["rays"][1:] == [None] * 3
    blind = result.robots[1]["sees_space"]["seen"]
    assert blind == {"knows": False, "rays": None, "inside": None, "clear": None, "obstacles": None}


@pytest.mark.slow
def test_collisions_fail_world_no_collisions_and_blocking_prevents_them(tmp_path):
    raw = {
        "run": {"name": "bump", "ticks": 12},
        "world": {"bounds": [[0, 0], [10, 10]]},
        "robots": [{"positions": [[1.0, 5.0], [5.0, 5.0]], "body_radius": 0.5, "speed": 1.0,
                    "behaviors": [{"use": "random_waypoint", "area": [[1, 5], [9, 5.0001]], "speed": 1.0}]}],
        "checks": [{"use": "world.no_collisions"}],
    }
    free = run(raw, out=tmp_path / "free", processes=0, run__seed=4)
    blocked = run(raw, out=tmp_path / "blocked", processes=0, run__seed=4, world__blocking=True)
    assert blocked.passed and blocked["world"]["collisions"]["robot_robot"] == 0
    col = free["world"]["collisions"]
    if col["robot_robot"]:
        assert not free.passed
        (outcome,) = free.checks
        assert outcome["name"] == "world.no_collisions" and outcome["value"] == col["robot_robot"]
        ev = [e for rec in free.trace for e in rec.get("ev", []) if "collision" in e]
        assert ev and all(e["end"] >= e["start"] for e in ev)


# ------------------------------------------------------------------------------------------------ bad input
GOOD = """
[run]
ticks = 3
[world]
bounds = [[0.0, 0.0], [10.0, 10.0]]
{world}
[[robots]]
{group}
"""


@pytest.mark.parametrize("world,group,key,words", [
    ('obstacles = [{ box = [[2.0, 2.0], [4.0, 4.0]] }]', "positions = [[3.0, 3.0]]",
     "robots[0].positions[0]", "inside an obstacle"),
    ('obstacles = [{ xy = [[0.0, 0.0], [1.0, 1.0]] }]', "count = 2", "world.obstacles[0].xy", "at least 3 vertices"),
    ('obstacles = [{ xy = [[0, 0], [2, 0], [1, 0.2], [2, 2], [0, 2]] }]', "count = 2", "world.obstacles[0].xy",
     "convex"),
    ("", 'count = 2\nkind = "wheeled"', "robots[0].kind", "wheeled"),
    ('map = "nothere.map"', "count = 2", "world.map.file", "nothere.map"),
    ('map = "bad.map"', "count = 2", "world.map.file", "bad.map:6:3"),
    ('obstacles = [{ box = [[2.0, 2.0], [4.0, 4.0]], z = [3.0, 1.0] }]', "count = 2", "world.obstacles[0].z",
     "z_min < z_max"),
])
def test_bad_space_input_exits_2_naming_file_key_and_line(tmp_path, monkeypatch, capsys, world, group, key, words):
    from swarmactors.cli import main

    (tmp_path / "bad.map").write_text("type octile\nheight 2\nwidth 4\nmap\n....\n..#.\n")
    (tmp_path / "s.toml").write_text(GOOD.format(world=world, group=group))
    monkeypatch.chdir(tmp_path)
    capsys.readouterr()
    code = main(["run", "s.toml"])
    err = capsys.readouterr().err
    assert code == EXIT_INPUT, err
    assert "s.toml" in err and key in err and words in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_placement_never_puts_a_robot_inside_an_obstacle():
    sc = load(MAZE)
    from transport.space import space_from_spec

    space = space_from_spec(sc["world"])
    pts = np.array(sc["robots"][0]["positions"])
    assert not space.inside(np.column_stack([pts, np.zeros(len(pts))])).any()
    assert json.dumps(sc["world"]["map"])  # the resolved map is plain data (the trace header records it)
