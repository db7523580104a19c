"""Biconnectivity: the conformance suite."""

from __future__ import annotations

from swarmactors.robot.family import Case, Family, comb, ladder, line, ring


# ------------------------------------------------------------------ conformance suite
def _bicon_case(name: str, positions: list, *, initiator: int = 0, clock: str = "lockstep", seed: int = 1,
                checks=("biconnectivity.lists", "biconnectivity.verdict", "biconnectivity.paths")) -> Case:
    n = len(positions)
    run = {"seed": seed, "clock": clock, "ticks": 6 * (n + 2) + 10}
    radio = {"range": 1.0, "latency": 1}
    beh = {"use": "biconnectivity", "N": n + 2, "c": 1, "initiator": initiator, "at": 1, "hello": 0}
    if clock == "realtime":
        run.update(dt=0.02, ticks=6 * (n + 2) + 20)
        radio.update(latency_s=0.02, latency_min_s=0.01)
        beh["c"] = 0.02
    scenario = {"run": run, "radio": radio, "robots": [{"positions": positions, "behaviors": [beh]}]}
    return Case(f"biconnectivity/{name}", scenario, [{"use": c} for c in checks])


def suite(mode: str) -> list[Case]:
    """Biconnected and not: rings, ladders, trees, a bow tie, two components; both clocks.

    Graphs stay small: the relay enumerates simple paths.
    """
    from swarmactors.runs.conformance import random_geometric  # draws until connected: when cases are built

    bowtie = [[0.0, 0.0], [0.8, 0.4], [0.0, 0.8], [1.6, 0.0], [1.6, 0.8]]  # two triangles sharing robot 1
    two_rings = ring(5) + [[x + 20.0, y] for x, y in ring(5)]
    cases = [
        _bicon_case("ring-6", ring(6)),
        _bicon_case("ladder-8", ladder(8)),
        _bicon_case("comb-7", comb(7)),
        _bicon_case("bowtie-5", bowtie, initiator=1),
        _bicon_case("two-components", two_rings),
        _bicon_case("ring-5-realtime", ring(5), clock="realtime",
                    checks=("biconnectivity.lists", "biconnectivity.verdict")),
    ]
    if mode == "full":
        cases += [_bicon_case("ring-9", ring(9)), _bicon_case("ladder-10", ladder(10)),
                  _bicon_case("line-6", line(6)), _bicon_case("pair", line(2)), _bicon_case("comb-9", comb(9))]
        for seed in (1, 2, 3):
            cases.append(_bicon_case(f"rgg-8-s{seed}", random_geometric(8, seed, degree=3.0), seed=seed))
        cases.append(_bicon_case("ladder-8-realtime", ladder(8), clock="realtime",
                                 checks=("biconnectivity.lists", "biconnectivity.verdict")))
    return cases


FAMILY = Family(name="biconnectivity", behavior="biconnectivity",
                report={"cr": list, "dcr": list, "biconnected": (bool, type(None)), "decided_at": (int, float,
                                                                                                  type(None))},
                suite=suite,
                behaviors={"biconnectivity": "protocols.biconnectivity.behavior:Biconnectivity"},
                checks={f"biconnectivity.{c}": f"protocols.biconnectivity.oracle:{c}"
                        for c in ("lists", "verdict", "paths", "removal", "join")})
