"""Virtual stigmergy: the conformance suite."""

from __future__ import annotations

import numpy as np

from swarmactors.robot.family import Case, Family, comb, line, ring


# ------------------------------------------------------------------ conformance suite
def _vs_case(name: str, positions: list, writes: list, *, checks: list[dict], clock="lockstep", loss=0.0, seed=1,
             anti_entropy=0, ticks=60) -> Case:
    run = {"seed": seed, "clock": clock, "ticks": ticks}
    radio = {"range": 1.0, "latency": 1, "loss": loss}
    if clock == "realtime":
        run.update(dt=0.05)
        radio.update(latency_s=0.02, latency_min_s=0.005)
    beh = {"use": "stigmergy", "writes": writes, "anti_entropy": anti_entropy}
    scenario = {"run": run, "radio": radio, "robots": [{"positions": positions, "behaviors": [beh]}]}
    return Case(f"stigmergy/{name}", scenario, checks)


def _writes(n: int, seed: int, count: int = 6) -> list[dict]:
    """Concurrent writes: two robots write one key in the same tick (a conflict), others write and delete."""
    rng = np.random.default_rng([seed, n, 11])
    a, b = (int(x) for x in rng.choice(n, 2, replace=False))
    out = [{"at": 2, "robot": a, "key": "k0", "value": a}, {"at": 2, "robot": b, "key": "k0", "value": b}]
    for i in range(count - 2):
        out.append({"at": 2 + i, "robot": int(rng.integers(n)), "key": f"k{1 + i % 3}", "value": i})
    out.append({"at": 3 + count, "robot": int(rng.integers(n)), "key": "k1", "delete": True})
    return out


def suite(mode: str) -> list[Case]:
    """Writes, conflicts and deletes on several graphs; loss with anti-entropy; two components; both clocks."""
    from swarmactors.runs.conformance import random_geometric  # draws until connected: when cases are built

    exact = [{"use": "stigmergy.consistent", "within": 40}, {"use": "stigmergy.latency"}]
    repaired = [{"use": "stigmergy.consistent"}]
    two_components = line(5) + [[x + 20.0, y] for x, y in line(5)]
    cases = [
        _vs_case("ring-10", ring(10), _writes(10, 1), checks=exact),
        _vs_case("rgg-20-s1", random_geometric(20, 1), _writes(20, 1), checks=exact),
        _vs_case("two-components", two_components, _writes(10, 2), checks=exact),
        _vs_case("rgg-20-s2-loss-0.2-anti-entropy", random_geometric(20, 2), _writes(20, 2), checks=repaired,
                 loss=0.2, anti_entropy=5, ticks=120),
        _vs_case("rgg-12-s3-realtime", random_geometric(12, 3), _writes(12, 3), checks=repaired, clock="realtime",
                 ticks=40),
    ]
    if mode == "full":
        for n, seed in ((10, 4), (40, 5), (80, 6)):
            cases.append(_vs_case(f"rgg-{n}-s{seed}", random_geometric(n, seed), _writes(n, seed, 10), checks=exact,
                                  seed=seed, ticks=80))
        cases.append(_vs_case("comb-15", comb(15), _writes(15, 7), checks=exact))
        for loss in (0.1, 0.3):
            cases.append(_vs_case(f"rgg-30-s8-loss-{loss}-anti-entropy", random_geometric(30, 8), _writes(30, 8),
                                  checks=repaired, loss=loss, anti_entropy=5, ticks=200, seed=8))
        cases.append(_vs_case("rgg-20-s9-realtime-loss-0.1", random_geometric(20, 9), _writes(20, 9),
                              checks=repaired, clock="realtime", loss=0.1, anti_entropy=3, ticks=60))
    return cases


FAMILY = Family(name="stigmergy", behavior="stigmergy", report={"table": dict, "writes": list, "changed_at": dict},
                suite=suite,
                behaviors={"stigmergy": "protocols.stigmergy.behavior:StigmergyScript",
                           "election": "protocols.stigmergy.behavior:StigmergyElection"},
                checks={f"stigmergy.{c}": f"protocols.stigmergy.oracle:{c}"
                        for c in ("consistent", "latency", "election")})
