"""Mobility models (issue 26): positions against the models' stationary distributions, bounds, composition.

The statistical tests drive the real behaviours with a minimal context (the world's single-integrator motion,
``x += v·dt``) and many independent robots, from a start far from equilibrium (every robot in one corner); the
seeds are fixed, so the tests are deterministic. Each also checks that its test would reject the wrong law.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from protocols.mobility.behavior import RandomWalk, RandomWaypoint, fold


class Ctx:
    """What a mobility behaviour uses of a robot's context: pose, tick, dt, rng, move, map and kind."""

    def __init__(self, pos, seed: int, dt: float = 1.0, known=None):
        self.map = known  # a KnownMap when the robot knows the obstacles
        self.kind = "ground"
        self.pose = np.array([*pos, 0.0])
        self.tick = 0
        self.dt = dt
        self.rng = np.random.default_rng(seed)
        self.v = (0.0, 0.0)

    def move(self, v) -> None:
        self.v = v


def simulate(make, n: int, ticks: int, start=(0.0, 0.0), dt: float = 1.0, known=None) -> np.ndarray:
    """Final (x, y) of ``n`` robots after ``ticks`` ticks, each moved as the world moves it."""
    robots = [(make(), Ctx(start, seed, known=known)) for seed in range(n)]
    for t in range(ticks):
        for b, ctx in robots:
            ctx.tick = t
            b.on_tick(ctx, [])
            ctx.pose[0] += ctx.v[0] * dt
            ctx.pose[1] += ctx.v[1] * dt
    return np.array([ctx.pose[:2] for _, ctx in robots])


def test_fold():
    assert fold(1.2, 0.0, 1.0) == pytest.approx((0.8, True))
    assert fold(-0.3, 0.0, 1.0) == pytest.approx((0.3, True))
    assert fold(2.5, 0.0, 1.0) == pytest.approx((0.5, False))
    assert fold(0.4, 0.0, 1.0) == (0.4, False)


def test_random_walk_is_uniform_in_the_box():
    """A reflecting walk with symmetric steps is a folded torus walk: its stationary law is uniform."""
    area = [[0.0, 0.0], [2.0, 1.0]]
    xy = simulate(lambda: RandomWalk(area, speed=0.15), n=400, ticks=250)
    assert ((xy >= [0, 0]) & (xy <= [2, 1])).all()
    assert stats.kstest(xy[:, 0] / 2.0, "uniform").pvalue > 0.001
    assert stats.kstest(xy[:, 1], "uniform").pvalue > 0.001
    counts, _, _ = np.histogram2d(xy[:, 0], xy[:, 1], bins=[4, 2], range=[[0, 2], [0, 1]])
    assert stats.chisquare(counts.ravel()).pvalue > 0.001
    # the same test sees a walk that has not mixed yet (all robots started in the corner)
    early = simulate(lambda: RandomWalk(area, speed=0.15), n=500, ticks=10)
    assert stats.kstest(early[:, 0] / 2.0, "uniform").pvalue < 0.001


def test_random_walk_with_persistent_headings_stays_uniform():
    xy = simulate(lambda: RandomWalk([[0, 0], [1, 1]], speed=0.1, turn_every=5), n=400, ticks=200)
    assert stats.kstest(xy[:, 0], "uniform").pvalue > 0.001
    assert stats.kstest(xy[:, 1], "uniform").pvalue > 0.001


@pytest.mark.slow  # a few seconds: every step asks the map
def test_random_walk_reflects_off_obstacles_and_stays_uniform_in_the_free_space():
    """With the map known, no step enters the obstacle, and the law is uniform over the free space."""
    from swarmactors.robot.knownmap import KnownMap

    block = [[1.0, 0.0], [1.5, 0.0], [1.5, 0.6], [1.0, 0.6]]  # an upright rectangle on the floor of [0,2]x[0,1]
    known = KnownMap.from_spec({"dims": 2, "obstacles": [{"xy": block, "z": None}], "map": None})
    walk = [None]

    def make():
        walk[0] = RandomWalk([[0, 0], [2, 1]], speed=0.12, turn_every=3)
        return walk[0]

    xy = simulate(make, n=250, ticks=200, start=(0.2, 0.2), known=known)
    inside = (xy[:, 0] > 1.0) & (xy[:, 0] < 1.5) & (xy[:, 1] < 0.6)
    assert not inside.any() and walk[0].reflections > 0
    # uniform on the free space (area 2 - 0.3): P(x <= a) is the free area left of a over 1.7
    def free_cdf(a):
        a = np.clip(a, 0.0, 2.0)
        return (a - 0.6 * np.clip(a - 1.0, 0.0, 0.5)) / 1.7

    assert stats.kstest(xy[:, 0], free_cdf).pvalue > 0.001
    top = xy[:, 1] > 0.6  # above the block every x is free: y uniform there, and the right share of robots
    assert stats.kstest((xy[top, 1] - 0.6) / 0.4, "uniform").pvalue > 0.001
    assert stats.binomtest(int(top.sum()), len(xy), 0.8 / 1.7).pvalue > 0.001
    column = (xy[:, 0] > 1.0) & (xy[:, 0] < 1.5)  # above the block only: 0.5 x 0.4 of the free 1.7
    assert stats.binomtest(int(column.sum()), len(xy), 0.2 / 1.7).pvalue > 0.001
    # the same tests see robots that ignore the block (uniform on the whole box, a quarter in that column)
    blind = simulate(lambda: RandomWalk([[0, 0], [2, 1]], speed=0.12, turn_every=3), n=250, ticks=200,
                     start=(0.2, 0.2))
    assert ((blind[:, 0] > 1.0) & (blind[:, 0] < 1.5) & (blind[:, 1] < 0.6)).any()
    column = (blind[:, 0] > 1.0) & (blind[:, 0] < 1.5)
    assert stats.binomtest(int(column.sum()), len(blind), 0.2 / 1.7).pvalue < 0.001


def test_random_waypoint_on_a_segment_has_the_known_density():
    """1-D RWP on [0, a] without pauses: f(x) = 6x(a - x)/a^3, whatever the speed law (Bettstetter et al.)."""
    xy = simulate(lambda: RandomWaypoint([[0.0, 0.0], [1.0, 0.0]], speed=0.08, speed_min=0.02), n=800,
                  ticks=250)
    assert (xy[:, 1] == 0).all() and ((xy[:, 0] >= 0) & (xy[:, 0] <= 1)).all()

    def cdf(x):
        return 3 * x**2 - 2 * x**3

    assert stats.kstest(xy[:, 0], cdf).pvalue > 0.001
    assert stats.kstest(xy[:, 0], "uniform").pvalue < 0.001  # and not uniform: the test can tell


def test_random_waypoint_in_a_square_is_denser_in_the_middle():
    """2-D RWP has no closed-form density; its marginals are symmetric and concentrated in the centre."""
    xy = simulate(lambda: RandomWaypoint([[0, 0], [1, 1]], speed=0.1), n=600, ticks=150)
    assert np.abs(xy.mean(axis=0) - 0.5).max() < 0.03
    centre = (np.abs(xy - 0.5) < 0.25).all(axis=1).mean()
    assert centre > 0.35  # uniform would put 0.25 of the robots in the central quarter


def test_random_waypoint_pauses_and_lands_on_waypoints():
    b, ctx = RandomWaypoint([[0, 0], [1, 1]], speed=10.0, pause=3), Ctx((0.5, 0.5), 1)
    moves = []
    for t in range(9):
        ctx.tick = t
        b.on_tick(ctx, [])
        moves.append(ctx.v)
        ctx.pose[:2] += ctx.v
    # arrives at ticks 0, 4 and 8 (speed 10 crosses the square in one tick), resting 3 ticks after each
    assert moves[1:4] == moves[5:8] == [(0.0, 0.0)] * 3 and b.legs == 3


@pytest.mark.parametrize(("cls", "params", "error"), [
    (RandomWalk, {"area": [[0, 0]]}, "area"),
    (RandomWalk, {"area": [[0, 0], [1, 1]], "speed": -1}, "speed"),
    (RandomWalk, {"area": [[0, 0], [1, 1]], "turn_every": 0}, "turn_every"),
    (RandomWaypoint, {"area": [[1, 1], [0, 0]]}, "area"),
    (RandomWaypoint, {"area": [[0, 0], [1, 1]], "speed": 1, "speed_min": 2}, "speed_min"),
])
def test_validation(cls, params, error):
    assert error in cls.validate(params)


def test_valid_parameters_pass():
    assert RandomWalk.validate({"area": [[0, 0], [1, 1]], "speed": 0.5}) is None
    assert RandomWaypoint.validate({"area": [[0, 0], [1, 1]], "speed": 1, "speed_min": 0.5, "pause": 2}) is None


@pytest.mark.slow
def test_composed_with_a_protocol_in_a_run(swarm_run):
    """Registered names, composed with beacons on the same robots, under the world's bounds; ids stay put."""
    sc = {
        "run": {"name": "mobility", "seed": 3, "ticks": 40},
        "radio": {"range": 1.0},
        "world": {"bounds": [[0.0, 0.0], [3.0, 3.0]]},
        "robots": [
            {"count": 6, "placement": "uniform",
             "behaviors": [{"use": "random_walk", "area": [[0.0, 0.0], [3.0, 3.0]], "speed": 0.2},
                           {"use": "beacon", "every": 5}]},
            {"count": 6, "placement": "uniform",
             "behaviors": [{"use": "random_waypoint", "area": [[0.0, 0.0], [3.0, 3.0]], "speed": 0.3}]},
        ],
    }
    result = swarm_run(sc)
    xy = np.array([row[1:3] for rec in result.trace for row in rec["pos"]])
    assert ((xy >= 0) & (xy <= 3)).all()
    walked = [r["random_walk"]["travelled"] for r in result.robots.values() if "random_walk" in r]
    assert len(walked) == 6 and all(math.isclose(w, 0.2 * 39, rel_tol=0.05) for w in walked)
    assert all(r["random_waypoint"]["legs"] >= 1 for r in result.robots.values() if "random_waypoint" in r)
    assert all(r["beacon"]["sent"] == 8 for r in result.robots.values() if "beacon" in r)
    assert Path(result.path).exists()
