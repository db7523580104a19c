"""Scenario builders for the paper's two experiments (Sec. IV).

Used by the tests, the experiments script and the conformance suite. They return raw scenario dicts (the
TOML tables as Python data).
"""

from __future__ import annotations

import math

import numpy as np

from swarmactors.runs.scenario import draw_until_connected

# Values the paper gives (Sec. III-C, IV-B) and the ones we chose where it gives none (docs/protocols/roles.md).
SPEED = 0.03  # length units per timestep (paper)
TURN = 0.15  # rad per timestep (paper)
D_C = 1.5  # radio range d_c = sensing range d_s (ours)


def patrol_placement(n: int, seed: int, d_c: float = D_C, digits: int = 4) -> tuple[list[list[float]], int]:
    """Place the patrol's robots.

    Sec. IV-B: the base station at the origin and n - 1 robots uniform in the fan (quarter disk of the
    first quadrant, where the targets are) of radius d_init = 0.6 sqrt(n), re-drawn until the network is
    connected without repeaters. Returns (positions with the base station first, the id of the robot closest
    to the base station, the initial local leader).
    """
    rng = np.random.default_rng([seed, n, 4])
    d_init = 0.6 * math.sqrt(n)

    def draw() -> np.ndarray:
        r = d_init * np.sqrt(rng.random(n - 1))
        a = rng.random(n - 1) * math.pi / 2
        pts = np.round(np.stack([r * np.cos(a), r * np.sin(a)], axis=1), digits)
        return np.vstack([[0.0, 0.0], pts])

    try:
        allp = draw_until_connected(draw, d_c, attempts=10_000)
    except ValueError:
        raise RuntimeError(f"no connected placement for n={n}") from None
    d = np.hypot(allp[1:, 0], allp[1:, 1])
    return allp.tolist(), int(np.argmin(d)) + 1


def patrol_targets(n: int, seed: int, count: int = 60, digits: int = 4) -> list[list[float]]:
    """Targets uniform in [0, 1.8 sqrt(n)]^2 (Sec. IV-B), drawn from the seed: the base station's list."""
    rng = np.random.default_rng([seed, n, 7])
    side = 1.8 * math.sqrt(n)
    return np.round(rng.uniform(0.0, side, size=(count, 2)), digits).tolist()


def patrol_scenario(n: int = 10, seed: int = 1, ticks: int = 2000, loss: float = 0.0, clock: str = "lockstep",
                    checks: list[dict] | None = None, name: str | None = None, trace: bool = True,
                    d_c: float = D_C, d_s: float | None = None, **params) -> dict:
    """Return the patrol of Sec. IV-B as a scenario.

    Robot 0 is the base station (alone in the first group, with the
    target list), robots 1..n-1 the swarm. ``d_c`` is the radio range (``radio.range`` and the groups'
    ``range``), ``d_s`` the groups' ``sensing`` (default d_c): the robots read both from their context.
    ``params`` go to every robot's ``roles`` behaviour.
    """
    d_c = float(d_c)
    d_s = float(d_s or d_c)
    pts, leader = patrol_placement(n, seed, d_c)
    beh = {"use": "roles", "leader": leader, "base": 0, **params}
    group = {"range": d_c, "sensing": d_s, "speed": SPEED, "turn_rate": TURN}
    return {
        "run": {"name": name or f"roles-patrol-{n}", "seed": seed, "clock": clock, "ticks": ticks, "dt": 1.0,
                "trace": trace},
        "radio": {"range": d_c, "latency": 1, "loss": loss},
        "world": {"bounds": [[-1000.0, -1000.0], [1000.0, 1000.0]]},
        "robots": [
            {"positions": [pts[0]], **group, "behaviors": [{**beh, "targets": patrol_targets(n, seed)}]},
            {"positions": pts[1:], **group, "behaviors": [beh]},
        ],
        "checks": checks if checks is not None else [],
    }


def aat_scenario(n: int = 20, seed: int = 1, ticks: int = 1000, mode: str = "proposed", d_c: float = 3.0,
                 eta_c: int = 3, step: float = 1.0, walk_until: int | None = None, loss: float = 0.0,
                 checks: list[dict] | None = None, name: str | None = None, trace: bool = True,
                 circles: bool = True) -> dict:
    """Return the preliminary experiment of Sec. IV-A as a scenario (``circles = False``: without lines 9-15).

    n explorers uniform in a sqrt(n) x sqrt(n) field, random walk
    of step ``step`` per tick in a uniform direction, d_c = d_s = 3 (the robots' radio and sensing ranges,
    which they read from their context), eta_c = 3.
    """
    side = math.sqrt(n)
    beh = {"use": "aat", "mode": mode, "eta_c": eta_c, "step": step}
    if walk_until is not None:
        beh["walk_until"] = walk_until
    if not circles:
        beh["circles"] = False
    return {
        "run": {"name": name or f"roles-aat-{mode}-{n}", "seed": seed, "ticks": ticks, "trace": trace},
        "radio": {"range": d_c, "latency": 1, "loss": loss},
        "world": {"bounds": [[0.0, 0.0], [side, side]]},
        "robots": [{"count": n, "placement": "uniform", "range": d_c, "sensing": d_c, "speed": step,
                    "behaviors": [beh]}],
        "checks": checks if checks is not None else [],
    }
