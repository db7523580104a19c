"""SECS navigation controller: the conformance family (``swarmactors check secs``).

A user's controller replaces the built-in ``secs`` behaviour; it must report, under ``secs``, ``arm`` (its
arm, -1 for the master), ``target`` (∠T in its own frame or null), ``aligned``, ``odo`` (its odometry
position when it last reported) and ``at`` (that tick), and ``master`` (the master's id). The checks judge
connectivity at every tick, the task reached, no collision of the 10 cm bodies, and ∠T against the truth.
"""

from __future__ import annotations

from protocols.secs.scenarios import secs_scenario
from swarmactors.robot.family import Case, Family

ALL = [{"use": "secs.connected"}, {"use": "secs.reach"}, {"use": "world.no_collisions"},
       {"use": "secs.angle", "bound": 0.05}]


def _case(name: str, checks: list[dict], **kw) -> Case:
    sc = secs_scenario(checks=[], **kw)
    sc["run"].pop("name")
    return Case(f"secs/{name}", sc, checks)


def suite(mode: str) -> list[Case]:
    """One short arm, with and without loss; ``full`` adds longer arms, δ = 120, three arms, noisy bearings."""
    cases = [
        _case("n5-d240-3r2", ALL, n=5, distance=3 * 2**0.5, seconds=32),
        _case("n5-d240-3r2-loss-0.1", ALL, n=5, distance=3 * 2**0.5, seconds=32, loss=0.1),
    ]
    if mode == "full":
        cases += [
            _case("n10-d240-5r2", ALL, n=10, distance=5 * 2**0.5, seconds=100),
            _case("n10-d120-3r2", ALL, n=10, distance=3 * 2**0.5, delta=120.0, seconds=140),
            _case("n16-d240-3arms", ALL[:3], n=16, distance=5.0, tasks=3, seconds=300),
            _case("n10-d240-5r2-noise", [*ALL[:3], {"use": "secs.angle", "bound": 0.3}], n=10,
                  distance=5 * 2**0.5, seconds=120, bearing_noise=0.02, range_noise=0.01),
            _case("n5-d240-3r2-s2", ALL, n=5, distance=3 * 2**0.5, seconds=60, seed=2),
            _case("n5-d240-3r2-realtime", ALL[:3], n=5, distance=3 * 2**0.5, seconds=45, clock="realtime"),
        ]
    return cases


FAMILY = Family(name="secs", behavior="secs",
                report={"arm": (int, type(None)), "target": (float, int, type(None)), "aligned": bool,
                        "odo": (list, type(None)), "at": (int, type(None)), "master": int},
                suite=suite,
                behaviors={"secs": "protocols.secs.behavior:SECS"},
                checks={f"secs.{c}": f"protocols.secs.oracle:{c}"
                        for c in ("connected", "reach", "angle", "slots")})
