"""CBAA: the conformance suite."""

from __future__ import annotations

import math

import numpy as np

from swarmactors.robot.family import Case, Family, comb, ladder, line, ring


def _cbaa_case(name: str, positions: list, tasks: list, *, clock="lockstep", loss=0.0, seed=1,
               checks=("cbaa.conflict_free", "cbaa.greedy", "cbaa.rounds", "cbaa.optimality")) -> Case:
    run = {"seed": seed, "clock": clock, "ticks": 60}
    radio = {"range": 1.0, "latency": 1, "loss": loss}
    if clock == "realtime":
        run.update(dt=0.05, ticks=60)
        radio.update(latency_s=0.02, latency_min_s=0.005)
    scenario = {"run": run, "radio": radio,
                "robots": [{"positions": positions, "behaviors": [{"use": "cbaa", "at": 1, "tasks": tasks}]}]}
    return Case(f"cbaa/{name}", scenario, [{"use": c} for c in checks])


def _tasks(n: int, seed: int, spread: float) -> list[list[float]]:
    rng = np.random.default_rng([seed, n, 7])
    return np.round(rng.random((n, 2)) * spread, 4).tolist()


def suite(mode: str) -> list[Case]:
    """Static networks of several shapes, fewer and more tasks than robots, both clocks, loss."""
    from swarmactors.runs.conformance import random_geometric  # draws until connected: when cases are built

    ties = [[0.4 + 0.8 * i, 0.0] for i in range(5)]  # each task equidistant from two robots: equal bids
    cases = [
        _cbaa_case("line-6-tied-tasks-5", line(6), ties),
        _cbaa_case("line-6-tasks-4", line(6), _tasks(4, 1, 4.0)),
        _cbaa_case("ring-8-tasks-10", ring(8), _tasks(10, 2, 2.5)),
        _cbaa_case("rgg-15-s1-tasks-8", random_geometric(15, 1), _tasks(8, 3, 3.5)),
        _cbaa_case("rgg-10-s2-realtime-loss-0.1", random_geometric(10, 2), _tasks(6, 4, 3.0), clock="realtime",
                   loss=0.1, checks=("cbaa.conflict_free", "cbaa.greedy")),
    ]
    if mode == "full":
        for n, seed in ((10, 1), (20, 2), (30, 3)):
            for k in (n // 2, n, 2 * n):
                cases.append(_cbaa_case(f"rgg-{n}-s{seed}-tasks-{k}", random_geometric(n, seed),
                                        _tasks(k, seed, math.sqrt(n) * 1.2), seed=seed))
        cases.append(_cbaa_case("comb-13-tasks-7", comb(13), _tasks(7, 5, 5.0)))
        cases.append(_cbaa_case("ladder-12-tasks-12", ladder(12), _tasks(12, 6, 4.0)))
        for seed in (3, 4):
            cases.append(_cbaa_case(f"rgg-14-s{seed}-realtime-loss-0.1", random_geometric(14, seed),
                                    _tasks(9, seed, 3.5), clock="realtime", loss=0.1,
                                    checks=("cbaa.conflict_free", "cbaa.greedy")))
    return cases


FAMILY = Family(name="cbaa", behavior="cbaa",
                report={"task": (int, type(None)), "bids": list, "winners": list, "changed_at": (int, type(None))},
                suite=suite,
                behaviors={"cbaa": "protocols.cbaa.behavior:CBAA"},
                checks={f"cbaa.{c}": f"protocols.cbaa.oracle:{c}"
                        for c in ("conflict_free", "greedy", "rounds", "optimality")})
