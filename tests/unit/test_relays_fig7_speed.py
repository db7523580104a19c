"""Fig. 7's heterogeneous arenas (the low wall of arenas 2 and 3) and the relays checks' single trace pass."""

from __future__ import annotations

import pytest

from protocols.relays import oracle, planner
from protocols.relays.experiments import fig7
from swarmactors.oracle.trace import record_problem
from swarmactors.runs.maps import maze


def _ground_reachable(arena: int, with_fence: bool) -> bool:
    """A 1 m grid of the arena (maze walls, and the fence when asked): is the target reachable from the root?"""
    a = fig7.ARENAS[arena]
    plan = maze(a["cols"], a["rows"], seed=a["maze_seed"])
    cell, h = a["cell"], len(plan)
    boxes = fig7.fence(arena) if with_fence else []

    def blocked(x: float, y: float) -> bool:
        u, v = int(x // cell), int(y // cell)
        if not (0 <= u < len(plan[0]) and 0 <= v < h) or plan[h - 1 - v][u] == "@":
            return True
        return any(b[0][0] <= x <= b[1][0] and b[0][1] <= y <= b[1][1] for b in boxes)

    width, height = cell * len(plan[0]), cell * h
    grid = planner.Grid([[0.0, 0.0], [width, height]], 1.0, blocked, 0.0)
    sc = fig7.scenario(arena, 1, 0.0, 0, 10)
    root, target = sc["robots"][0]["positions"][0], sc["robots"][0]["behaviors"][0]["targets"][0]
    return planner.reachable(grid, grid.cell(*root), grid.cell(*target))


@pytest.mark.parametrize("arena", [2, 3])
def test_the_low_wall_of_arenas_2_and_3_leaves_ground_robots_no_way_to_the_target(arena):
    assert _ground_reachable(arena, with_fence=False)
    assert not _ground_reachable(arena, with_fence=True)


def test_the_fence_stands_gap_from_the_target_and_hetero_arenas_are_3d_with_5_flying_robots():
    sc = fig7.scenario(3, 1, 0.0, 0, 10, hetero=True)
    tx, ty = sc["robots"][0]["behaviors"][0]["targets"][0]
    (top, left) = [o["box"] for o in sc["world"]["obstacles"]]
    assert top[0][1] == pytest.approx(ty + 5.9) and left[1][0] == pytest.approx(tx - 5.9)
    assert all(o["z"] == [0.0, 0.5] for o in sc["world"]["obstacles"])
    assert sc["world"]["dims"] == 3 and [len(g["positions"]) for g in sc["robots"]] == [95, 5]
    assert sc["robots"][1]["kind"] == "flying"


def test_arena_1_keeps_its_full_height_wall():
    sc = fig7.scenario(1, 1, 0.0, 0, 10, hetero=True)
    assert [o["box"] for o in sc["world"]["obstacles"]] == [[[32.3, 0.0], [33.3, 49.0]]]


class _Run:
    """A stand-in result: two robots, a worker reaching its target at tick 2 and a kill at tick 3."""

    def __init__(self):
        self.passes = 0
        self.data = {"scenario": {"run": {"dt": 1.0}}}

    def __getitem__(self, key):
        return self.data[key]

    def behavior_params(self, name):
        return {"targets": [[5.0, 0.0]], "ds": 1.4, "db": 1.8, "rcol": 0.25}

    def reports(self, name):
        return {1: {"chain": 0, "role": "worker", "path": [[0.0, 0.0], [5.0, 0.0]], "plan_status": "ok"}}

    def records(self):
        self.passes += 1
        yield {"t": 1, "pos": [[0, 0.0, 0.0], [1, 1.5, 0.0]],
               "status": {0: {"role": "root"}, 1: {"role": "worker", "chain": 0, "parent": 0}}}
        yield {"t": 2, "pos": [[0, 0.0, 0.0], [1, 5.0, 0.0]]}
        yield {"t": 3, "pos": [[0, 0.0, 0.0], [1, 5.0, 0.0]], "ev": [{"kill": [2]}]}


def test_reached_and_links_within_db_read_the_trace_once_and_count_the_kill():
    r = _Run()
    (reach,) = oracle.reached(r)
    (links,) = oracle.links_within_db(r)
    assert r.passes == 1
    assert reach.value == 2.0 and "path 5.00 m" in reach.detail
    n = 4  # ceil(5 / 1.4); the bound holds one kill's 60 s
    assert reach.bound == pytest.approx(1 + 10 + 2 + n * (10 + 1.4 / 0.5) + 5 / 0.5 + 60)
    assert links.value == 5.0 and not links.passed and links.first_tick == 2
    oracle.reached(r, tol=0.1)  # another tolerance is another pass
    assert r.passes == 2


def test_record_problem_names_the_first_bad_row_as_before():
    assert record_problem({"t": 0, "del": [[1, 2, 3, 4], [True, 2, 3, 4]]}) is None  # a bool id passes, as isinstance
    assert "holds (1, 2, 3, 4)" in record_problem({"t": 0, "del": [[1, 2, 3, 4], (1, 2, 3, 4)]})
    assert "holds [1, 2]" in record_problem({"t": 0, "del": [[1, 2, 3, 4], [1, 2]]})
    assert "holds ['a', 2, 3, 4]" in record_problem({"t": 0, "del": [["a", 2, 3, 4]]})
    assert "holds []" in record_problem({"t": 0, "cmd": [[]]})
