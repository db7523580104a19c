"""Swarm Relays over Zenoh (issue 16): chains built, reached, healed, judged by the oracle over the trace."""

from __future__ import annotations

import math

import pytest

from protocols.relays.behavior import Relays
from protocols.relays.suite import (
    C_SHAPE,
    default_checks,
    maze_scenario,
    relays_scenario,
    wall_scenario,
    window_scenario,
)

pytestmark = pytest.mark.slow  # every test runs scenarios over Zenoh


def passed(result) -> dict[str, bool]:
    return {c["name"]: c["passed"] for c in result.checks}


def chain_of(result, worker_chain: int = 0) -> list[int]:
    """The final chain from the worker up to the root, by the reports' parent pointers."""
    reps = result.reports("relays")
    (w,) = [r for r, rep in reps.items() if rep["role"] == "worker" and rep["chain"] == worker_chain]
    out = [w]
    while reps[out[-1]]["role"] != "root":
        out.append(reps[out[-1]]["parent"])
    return out


def test_open_field_10_robots_chain_built_target_reached_same_hash_with_1_and_3_hosts(run):
    sc = relays_scenario(10, [[8.0, 0.0]], ticks=260)
    one = run(sc, processes=1)
    assert all(c["passed"] for c in one.checks), one.checks
    links = [c for c in one.checks if c["name"] == "relays.links_within_db"][0]
    assert links["value"] <= 1.8
    chain = chain_of(one)
    assert len(chain) - 1 >= 6  # ceil(8 / 1.4) = 6 links at least
    three = run(sc, processes=3)
    assert three["trace_hash"] == one["trace_hash"]


def test_two_redundant_chains_to_one_target_both_built_both_reach_disjoint_links_within_db(run):
    """Sec. III-C, C_n = 2: chains 0 and 1 serve target 0, each with its own worker, links and side of pi."""
    result = run(relays_scenario(18, [[8.0, 0.0]], ticks=400, chains_per_target=2))
    assert all(c["passed"] for c in result.checks), result.checks
    reached = [c for c in result.checks if c["name"] == "relays.reached"]
    assert len(reached) == 2 and all(c["value"] is not None for c in reached)
    assert [c for c in result.checks if c["name"] == "relays.links_within_db"][0]["value"] <= 1.8
    a, b = chain_of(result, 0), chain_of(result, 1)
    assert a[-1] == b[-1] == 0 and not set(a[:-1]) & set(b[:-1])  # only the root is shared
    assert len(a) - 1 >= 6 and len(b) - 1 >= 6
    final = {row[0]: row[1:] for row in result.trace[-1]["pos"]}
    assert final[a[0]][1] < 0 < final[b[0]][1]  # copy 0 right of pi, copy 1 left


def test_a_generated_maze_the_chain_follows_the_corridors_to_the_far_corner(run):
    """The full suite's maze case: a 3 x 3 perfect maze, root and target in opposite corners, 16 robots.

    Corridors 2 m, walls 1 m; the path winds (13.5 m for an 8.5 m straight line); no robot touches a wall.
    """
    result = run(maze_scenario(16, 3, 3, maze_seed=0, ticks=450))
    assert all(c["passed"] for c in result.checks), result.checks
    path = [r["path"] for r in result.reports("relays").values() if r["role"] == "worker"][0]
    assert len(path) >= 5 and sum(math.dist(a[:2], b[:2]) for a, b in zip(path, path[1:], strict=False)) > 12.0
    # ceil(13.5 / 1.4) = 10 links along pi; straight links cut the corridors' corners, so 9 can suffice
    assert len(chain_of(result)) - 1 >= 9


def test_c_shaped_obstacle_chain_goes_around_without_touching_it(run):
    result = run(relays_scenario(12, [[8.0, 0.0]], ticks=600, obstacles=C_SHAPE))
    assert all(c["passed"] for c in result.checks), result.checks
    path = [r["path"] for r in result.reports("relays").values() if r["role"] == "worker"][0]
    assert max(abs(p[1]) for p in path) > 1.5  # the path leaves the straight line to go around the C


def test_a_wall_only_flying_robots_cross_a_flying_worker_takes_over_and_reaches_the_target(run):
    result = run(wall_scenario(ticks=500))
    assert all(c["passed"] for c in result.checks), result.checks
    reps = result.reports("relays")
    handed = [r for r, rep in reps.items() if rep["plan_status"] == "handed to a flying robot"]
    assert len(handed) == 1 and reps[handed[0]]["kind"] == "ground"  # the first worker planned, then handed over
    chain = chain_of(result)
    assert reps[chain[0]]["kind"] == "flying" and reps[chain[0]]["reached_at"] is not None
    path = reps[chain[0]]["path"]
    assert path[1][2] == 0.7  # a 3-D path at the flying altitude, over the wall
    final = {row[0]: row[1:] for row in result.trace[-1]["pos"]}
    assert all(final[r][0] < 4.0 for r in chain if reps[r]["kind"] == "ground")  # ground robots stay before it
    assert any(final[r][0] > 4.6 for r in chain if reps[r]["kind"] == "flying")


def chain_at(result, tick: int) -> list[int]:
    """The chain worker -> root at ``tick``, replayed from the trace's status changes."""
    status: dict[int, dict] = {}
    for rec in result.trace:
        if rec["t"] > tick:
            break
        for rid, fields in rec.get("status", {}).items():
            status.setdefault(int(rid), {}).update(fields)
    (w,) = [r for r, s in status.items() if s.get("role") == "worker"]
    out = [w]
    while status[out[-1]]["role"] != "root":
        out.append(status[out[-1]]["parent"])
    return out


def middle_networkers(run, n: int, loss: float, count: int, tick: int = 250) -> list[int]:
    """``count`` consecutive networkers from the middle of the chain at ``tick`` - 1, read from a run cut there.

    The run with the kills is the same run up to that tick (lockstep, same seed), so these are the robots the
    kills hit; the test checks it again on the run itself.
    """
    chain = chain_at(run(relays_scenario(n, [[8.0, 0.0]], ticks=tick, loss=loss, checks=[])), tick - 1)
    inner = chain[1:-1]  # without the worker and the root
    assert len(inner) >= count, chain
    first = (len(inner) - count) // 2
    return inner[first:first + count]


@pytest.mark.parametrize("count,n,loss", [(1, 10, 0.0), (1, 10, 0.1), (3, 12, 0.0), (3, 12, 0.1)])
def test_consecutive_networker_failures_heal(run, count, n, loss):
    kill = middle_networkers(run, n, loss, count)
    result = run(relays_scenario(n, [[8.0, 0.0]], ticks=650, loss=loss, kills=[(250, kill)],
                                 checks=default_checks(heal=True)))
    chain = chain_at(result, 249)
    at = sorted(chain.index(k) for k in kill)  # the killed robots were consecutive networkers of the chain
    assert at == list(range(at[0], at[0] + len(kill))) and 0 < at[0] and at[-1] < len(chain) - 1, chain
    assert all(c["passed"] for c in result.checks), result.checks
    healed = [c for c in result.checks if c["name"] == "relays.healed"][0]
    assert healed["value"] <= 5.0 + 20.0  # link-failure time plus the stated healing bound (s)
    reps = result.reports("relays")
    assert any(rep["splices"] for rep in reps.values())
    assert not set(kill) & set(chain_of(result))


def test_a_worker_that_dies_before_recruiting_is_replaced_by_a_new_election(run):
    """R8: robot 9 wins the election (tick 51) and dies at tick 58, alone in its chain; the root re-elects."""
    result = run(relays_scenario(10, [[8.0, 0.0]], ticks=600, kills=[(58, [9])], checks=default_checks(heal=True)))
    assert chain_at(result, 57) == [9, 0]  # the worker, alone with the root
    assert all(c["passed"] for c in result.checks), result.checks
    reps = result.reports("relays")
    (new,) = [r for r, rep in reps.items() if rep["role"] == "worker" and r != 9]
    assert reps[new]["won_at"] > 58 + 25 and reps[new]["reached_at"] is not None  # after link_fail (25 ticks)


def test_realtime_small_open_field(run):
    result = run(relays_scenario(6, [[3.0, 0.0]], ticks=160, dt=0.1, clock="realtime", bid_time=1.0))
    assert passed(result)["relays.reached"], result.checks
    assert passed(result)["relays.links_within_db"], result.checks


def test_target_inside_an_obstacle_or_outside_the_map_is_refused_not_looped_on(run):
    box = [{"box": [[2.5, -0.5], [3.5, 0.5]]}]
    result = run(relays_scenario(6, [[3.0, 0.0]], ticks=120, obstacles=box, bid_time=2.0,
                                 checks=[{"use": "relays.reached"}]))
    reps = result.reports("relays")
    assert [r["plan_status"] for r in reps.values() if r["role"] == "worker"] == ["target inside an obstacle"]
    assert all(r["role"] in ("root", "worker", "free") for r in reps.values())  # nobody recruited
    assert passed(result)["relays.reached"] and "target inside an obstacle" in result.checks[0]["detail"]
    result = run(relays_scenario(6, [[30.0, 0.0]], ticks=120, bid_time=2.0, area=[[-3.0, -3.0], [10.0, 3.0]],
                                 checks=[]))
    assert [r["plan_status"] for r in result.reports("relays").values() if r["role"] == "worker"] == [
        "target outside the map"]


def test_a_malformed_plan_in_the_stigmergy_is_refused_counted_and_survived(run):
    sc = relays_scenario(10, [[6.0, 0.0]], ticks=230)
    bad = {"pe": True, "pi": "not a path", "pig": [[0, 0]], "n": 1}
    sc["robots"].append({"positions": [[-1.0, 0.0]], "behaviors": [
        {"use": "stigmergy", "sid": "relay", "writes": [{"at": 3, "robot": 10, "key": "plan/0", "value": bad}]}]})
    result = run(sc)
    reps = result.reports("relays")
    (worker,) = [r for r in reps.values() if r["role"] == "worker"]
    assert worker["refused"] == {"plan": 1} and worker["plan_status"] == "ok"  # refused once, then its own plan
    assert not any(rob.get("error") for rob in result.robots.values())
    assert all(c["passed"] for c in result.checks), result.checks


class RelaysNoSplice(Relays):
    """Mutant: a robot that lost its parent never takes a new one (no splice)."""

    def _links(self, ctx):
        lost = self.parent_lost
        super()._links(ctx)
        if lost and not self.parent_lost:
            self.parent, self.parent_lost = None, True


class RelaysOverstretch(Relays):
    """Mutant: Eq. 8 bounds links at 2.5 m instead of d_s (the checks still judge d_b = 1.8 m)."""

    def on_start(self, ctx):
        super().on_start(ctx)
        self.ds, self.dc = 2.5, 2.6


@pytest.mark.parametrize("mutant,check", [("RelaysNoSplice", "relays.healed"),
                                          ("RelaysOverstretch", "relays.links_within_db")])
def test_mutants_are_caught(run, mutant, check):
    kills = [(250, middle_networkers(run, 12, 0.0, 3))] if mutant == "RelaysNoSplice" else None
    sc = relays_scenario(12, [[8.0, 0.0]], ticks=450 if kills else 250, kills=kills, checks=default_checks(True))
    sc["robots"][0]["behaviors"][0].update({"use": f"test_relays:{mutant}", "as": "relays"})
    assert passed(run(sc))[check] is False


def test_a_wall_with_a_window_a_flying_worker_flies_through_it_in_3d_and_reaches_the_target(run):
    """The 3-D planner (``air``): a wall from the ground to the ceiling with a window 0.8-1.8 m high.

    The only way is the window: pi climbs to it, passes it, and descends to the target on the ground. The
    first worker (a ground robot) hands over to a flying one (Fig. 4); the flying robots follow pi in 3-D, the
    ground ones pi_g up to g, every body inside the wall's slab is inside the window, and every link of the
    chain stays within d_b (3-D distances).
    """
    result = run(window_scenario(8, 6, ticks=450))
    assert all(c["passed"] for c in result.checks), result.checks
    links = [c for c in result.checks if c["name"] == "relays.links_within_db"][0]
    assert links["value"] <= 1.8
    reps = result.reports("relays")
    handed = [r for r, rep in reps.items() if rep["plan_status"] == "handed to a flying robot"]
    assert len(handed) == 1 and reps[handed[0]]["kind"] == "ground"
    chain = chain_of(result)
    assert reps[chain[0]]["kind"] == "flying" and reps[chain[0]]["reached_at"] is not None
    assert len(chain) - 1 >= 6
    path = reps[chain[0]]["path"]
    assert path[0][2] == 0.0 and path[-1][2] == 0.0 and max(p[2] for p in path) > 0.8  # up and down again
    crossed = set()
    for row in result.trace:
        for i, x, y, z in row["pos"]:
            if 4.0 - 0.125 <= x <= 4.5 + 0.125:  # a body in the wall's slab is in the window
                assert -1.0 < y < 1.0 and 0.8 < z < 1.8, (row["tick"], i, x, y, z)
                crossed.add(i)
    assert chain[0] in crossed
    final = {row[0]: row[1:] for row in result.trace[-1]["pos"]}
    assert final[chain[0]][0] > 7.5  # the worker beyond the wall
    assert all(final[r][0] < 4.0 and final[r][2] == 0.0 for r in reps if reps[r]["kind"] == "ground")
