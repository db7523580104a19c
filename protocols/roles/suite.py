"""The role-switching family for the conformance kit (``swarmactors check roles``)."""

from __future__ import annotations

from swarmactors.robot.family import Case, Family

LOSSLESS = [{"use": "roles.leader"}, {"use": "roles.chain"}, {"use": "roles.gabriel", "grace": 2},
            {"use": "roles.disconnections", "max_recovery": 60}]


def _patrol(name: str, n: int, seed: int, ticks: int, checks: list[dict], **kw) -> Case:
    from protocols.roles.scenarios import patrol_scenario  # the scenario loader: when cases are built, not on hosts

    sc = patrol_scenario(n, seed, ticks, checks=[], **kw)
    sc["run"].pop("name", None)
    return Case(f"roles/{name}", sc, checks)


def _realtime(name: str, n: int, seed: int, ticks: int, dt: float = 0.04) -> Case:
    case = _patrol(name, n, seed, ticks, [{"use": "roles.leader"}, {"use": "roles.chain"},
                                          {"use": "roles.gabriel", "grace": 3}], clock="realtime")
    sc = case.scenario
    sc["run"]["dt"] = dt
    sc["radio"].update({"latency_s": dt / 2, "latency_min_s": dt / 4})
    for g in sc["robots"]:
        g["speed"], g["turn_rate"] = 0.03 / dt, 0.15 / dt
    return case


def suite(mode: str) -> list[Case]:
    """Return the cases: patrols of the paper's Sec. IV-B.

    Lossless (one leader, chain, Gabriel links, recovery) and lossy (hand-over gaps); ``full`` adds larger
    swarms, the full 2000 timesteps and the realtime clock.
    """
    cases = [
        _patrol("patrol-10-s1", 10, 1, 400, LOSSLESS),
        _patrol("patrol-20-s3", 20, 3, 400, LOSSLESS),
        _patrol("patrol-10-s2-loss-0.1", 10, 2, 600, [{"use": "roles.handover", "H": 3, "quantile": 0.99}],
                loss=0.1),
    ]
    if mode == "full":
        cases += [
            _patrol("patrol-10-s1-2000", 10, 1, 2000, LOSSLESS + [{"use": "roles.targets", "min_targets": 8}]),
            _patrol("patrol-30-s2-2000", 30, 2, 2000, LOSSLESS + [{"use": "roles.targets", "min_targets": 5}]),
            _patrol("patrol-10-s3-baseline", 10, 3, 600, LOSSLESS, aat="baseline"),
            _patrol("patrol-10-s4-loss-0.1", 10, 4, 2000, [{"use": "roles.handover", "H": 3, "quantile": 0.99}],
                    loss=0.1),
            _realtime("patrol-10-s1-realtime", 10, 1, 150),
        ]
    return cases


FAMILY = Family(name="roles", behavior="roles",
                report={"role": str, "roles": list, "connections": list, "handovers": list, "refused": dict,
                        "reached": list},
                suite=suite,
                behaviors={"roles": "protocols.roles.behavior:RoleSwitching",
                           "aat": "protocols.roles.behavior:AATWalk"},
                checks={f"roles.{c}": f"protocols.roles.oracle:{c}"
                        for c in ("leader", "chain", "gabriel", "disconnections", "targets", "connectivity",
                                  "handover")})
