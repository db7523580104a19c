"""λ2 estimation: scenarios and the conformance family (``swarmactors check lambda2``).

A user's estimator replaces the built-in ``lambda2`` behaviour (default method PI1) and must report, under
``lambda2``, ``final`` (its last estimate, a number or null) and ``estimates`` (one per iteration, a number
or null): the checks judge every robot's own estimates (robots at a zero of the Fiedler vector excepted, see
``oracle.accurate``).
"""

from __future__ import annotations

import math

from swarmactors.robot.family import Case, Family, line, ring


def star(n: int, radius: float = 0.95) -> list[list[float]]:
    """A star: one hub, n − 1 ≤ 5 leaves on a circle of ``radius`` (neighbouring leaves > 1 apart)."""
    if not 2 <= n <= 6:
        raise ValueError("star: 2 to 6 robots in range 1")
    return [[0.0, 0.0]] + [[round(radius * math.cos(2 * math.pi * i / (n - 1)), 6),
                            round(radius * math.sin(2 * math.pi * i / (n - 1)), 6)] for i in range(n - 1)]


def complete(n: int) -> list[list[float]]:
    """A complete graph: n robots on a circle of diameter 0.9 (all within range 1)."""
    return [[round(0.45 * math.cos(2 * math.pi * i / n), 6), round(0.45 * math.sin(2 * math.pi * i / n), 6)]
            for i in range(n)]


def lambda2_scenario(positions: list, ticks: int, *, method: str = "pi1", loss: float = 0.0, seed: int = 1,
                     clock: str = "lockstep", name: str = "lambda2", checks: list | None = None,
                     dt: float = 0.05, **params) -> dict:
    """A scenario of static robots at ``positions`` running the estimator for ``ticks`` ticks."""
    beh = {"use": "lambda2", "method": method, **params} if method != "pi1" or params else {"use": "lambda2"}
    run = {"name": name, "seed": seed, "clock": clock, "ticks": ticks}
    radio = {"range": 1.0, "latency": 1, "loss": loss}
    if clock == "realtime":
        run["dt"] = dt
        radio.update(latency_s=dt / 4, latency_min_s=dt / 8)
    return {"run": run, "radio": radio, "robots": [{"positions": positions, "behaviors": [beh]}],
            "checks": checks if checks is not None else [{"use": "lambda2.accurate"}]}


def two_rings(n: int) -> list[list[float]]:
    """Two rings of n robots, 10 apart: a disconnected graph (λ2 = 0), each ring its own component."""
    return ring(n) + [[x + 10.0, y] for x, y in ring(n)]


def _case(name: str, positions: list, ticks: int, checks: list[dict], **kw) -> Case:
    sc = lambda2_scenario(positions, ticks, checks=[], **kw)
    sc["run"].pop("name")
    return Case(f"lambda2/{name}", sc, checks)


def suite(mode: str) -> list[Case]:
    """Lossless graph families within 1 % (the stated iteration), a disconnected pair, loss, realtime."""
    from swarmactors.runs.conformance import random_geometric  # draws until connected: when cases are built

    acc = [{"use": "lambda2.accurate", "tol": 1.0}, {"use": "lambda2.robust"}]
    cases = [
        _case("ring-8", ring(8), 120, acc),
        _case("rgg-10-s1", random_geometric(10, 1), 200, acc),
        _case("two-rings-6", two_rings(6), 120, [{"use": "lambda2.accurate", "tol": 1.0}]),
        _case("rgg-10-s2-loss-0.1", random_geometric(10, 2), 200, [{"use": "lambda2.robust"}], loss=0.1),
        _case("ring-8-realtime", ring(8), 120, [{"use": "lambda2.accurate", "tol": 5.0}], clock="realtime"),
    ]
    if mode == "full":
        cases += [
            _case("line-6", line(6), 200, acc),
            _case("star-6", star(6), 120, acc),
            _case("rgg-10-s3", random_geometric(10, 3), 400, acc),
            _case("rgg-10-s4", random_geometric(10, 4), 400, acc),
            _case("rgg-10-s5-loss-0.3", random_geometric(10, 5), 300, [{"use": "lambda2.robust"}], loss=0.3),
            _case("rgg-10-s1-realtime", random_geometric(10, 1), 200, [{"use": "lambda2.accurate", "tol": 5.0}],
                  clock="realtime"),
        ]
    return cases


FAMILY = Family(name="lambda2", behavior="lambda2",
                report={"final": (float, int, type(None)), "estimates": list},
                suite=suite,
                behaviors={"lambda2": "protocols.lambda2.behavior:Lambda2"},
                checks={f"lambda2.{c}": f"protocols.lambda2.oracle:{c}"
                        for c in ("accurate", "robust")})
