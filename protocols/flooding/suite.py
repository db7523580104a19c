"""Flooding: the conformance suite."""

from __future__ import annotations

from swarmactors.robot.family import Case, Family, comb, ladder, line, ring


def _flood_case(name: str, positions: list, checks: list[str], *, expiry=4, loss=0.0, clock="lockstep",
                seed=1, events=(), ticks=None) -> Case:
    run = {"seed": seed, "clock": clock, "ticks": ticks or int(expiry) + 4}
    radio = {"range": 1.0, "latency": 1, "loss": loss}
    if clock == "realtime":
        run.update(dt=0.05, ticks=ticks or 40)
        radio.update(latency_s=0.02, latency_min_s=0.01)
    scenario = {"run": run, "radio": radio,
                "robots": [{"positions": positions,
                            "behaviors": [{"use": "flooding", "origin": 0, "at": 1, "expiry": expiry}]}],
                "events": list(events)}
    return Case(f"flooding/{name}", scenario, [{"use": c} for c in checks])


def suite(mode: str) -> list[Case]:
    """Graph families x clocks x loss x faults; ``quick`` is a small subset of ``full``."""
    from swarmactors.runs.conformance import random_geometric  # draws until connected: when cases are built

    exact = ["flooding.reach", "flooding.forwarding"]
    lossy = ["flooding.delivered", "flooding.forwarding"]
    cases = [
        _flood_case("ring-8", ring(8), exact, expiry=3),
        _flood_case("comb-9", comb(9), exact, expiry=5),
        _flood_case("rgg-20-s1", random_geometric(20, 1), exact),
        _flood_case("rgg-20-s1-loss-0.2", random_geometric(20, 1), lossy, loss=0.2, expiry=6),
        _flood_case("line-8-killed-relay", line(8), exact, expiry=8, events=[{"at": 0, "kill": [3]}]),
        _flood_case("rgg-12-s2-realtime", random_geometric(12, 2), ["flooding.component", "flooding.forwarding"],
                    expiry=3.0, clock="realtime"),
    ]
    if mode == "full":
        for n in (16, 32):
            cases.append(_flood_case(f"ring-{n}", ring(n), exact, expiry=n // 3))
        for n in (10, 20):
            cases.append(_flood_case(f"ladder-{n}", ladder(n), exact, expiry=4))
        cases.append(_flood_case("comb-17", comb(17), exact, expiry=6))
        for n in (10, 40):
            for seed in (1, 2, 3):
                cases.append(_flood_case(f"rgg-{n}-s{seed}", random_geometric(n, seed), exact, seed=seed))
        for loss in (0.1, 0.3):
            for seed in (2, 3):
                cases.append(_flood_case(f"rgg-30-s{seed}-loss-{loss}", random_geometric(30, seed), lossy,
                                         loss=loss, expiry=8, seed=seed))
        cases.append(_flood_case("rgg-30-s3-realtime", random_geometric(30, 3),
                                 ["flooding.component", "flooding.forwarding"], expiry=4.0, clock="realtime"))
        cases.append(_flood_case("ring-12-cut", ring(12), exact, expiry=8, events=[{"at": 0, "cut": [[0, 1]]}]))
    return cases


FAMILY = Family(name="flooding", behavior="flooding", report={"received": dict, "forwarded": int}, suite=suite,
                behaviors={"flooding": "protocols.flooding.behavior:Flooding"},
                checks={f"flooding.{c}": f"protocols.flooding.oracle:{c}"
                        for c in ("reach", "delivered", "component", "forwarding")})
