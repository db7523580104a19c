"""Scenarios of the ARGoS set-up of §IV-A: 30 m × 30 m arena, 10 cm robots at 0.15 m/s, 3 m radio range.

Robot 0 is the master at the origin, with global sensing (it alone knows the tasks: world objects ``task*``
known by it only; the core hands ``ctx.objects`` in world coordinates, so a robot in its own frame could not
use them). The N backbone robots sense in their own frame (``sensing_frame = "local"``) and start in a
compact hexagonal cluster round the master, 0.4 m apart (the swarm after a rendez-vous).
"""

from __future__ import annotations

import math


def cluster(n: int, spacing: float = 0.4) -> list[list[float]]:
    """The n hexagonal-lattice points nearest the origin, the origin itself excluded, sorted by distance."""
    pts = []
    k = int(math.ceil(math.sqrt(n))) + 2
    for a in range(-k, k + 1):
        for b in range(-k, k + 1):
            x, y = spacing * (a + b / 2), spacing * b * math.sqrt(3) / 2
            if (a, b) != (0, 0):
                pts.append((round(math.hypot(x, y), 9), round(math.atan2(y, x), 9), round(x, 6), round(y, 6)))
    pts.sort()
    return [[x, y] for _, _, x, y in pts[:n]]


def tasks_at(distance: float, count: int = 1, first: float = math.pi / 4) -> list[dict]:
    """``count`` tasks at ``distance`` from the master, evenly spread in angle from ``first``."""
    out = []
    for k in range(count):
        a = first + 2 * math.pi * k / count
        out.append({"name": f"task{k}", "pos": [round(distance * math.cos(a), 6), round(distance * math.sin(a), 6)],
                    "known_by": [0]})
    return out


def secs_scenario(n: int, distance: float, *, tasks: int = 1, delta: float = 240.0, seconds: float = 200.0,
                  seed: int = 1, name: str = "secs", loss: float = 0.0, bearing_noise: float = 0.0,
                  range_noise: float = 0.0, checks: list | None = None, clock: str = "lockstep",
                  **params) -> dict:
    """N backbone robots plus the master, ``tasks`` tasks at ``distance`` m, run for ``seconds``.

    dt = 0.1 s, ARGoS's 10 ticks per second.
    """
    beh = {"use": "secs", "delta": delta, **params}
    common = {"range": 3.0, "speed": 0.15, "body_radius": 0.05, "behaviors": [beh]}
    backbone = {"positions": cluster(n), "sensing_frame": "local", **common}
    if bearing_noise or range_noise:
        backbone.update(bearing_noise=bearing_noise, range_noise=range_noise)
    radio = {"range": 3.0, "latency": 1, "loss": loss}
    if clock == "realtime":  # frames arrive within half a tick, after at least a fifth
        radio.update(latency_s=0.05, latency_min_s=0.02)
    return {
        "run": {"name": name, "seed": seed, "clock": clock, "dt": 0.1, "ticks": int(round(seconds / 0.1))},
        "radio": radio,
        "world": {"bounds": [[-15.0, -15.0], [15.0, 15.0]], "objects": tasks_at(distance, tasks)},
        "robots": [{"positions": [[0.0, 0.0]], **common}, backbone],
        "checks": checks if checks is not None else [
            {"use": "secs.connected"}, {"use": "secs.reach"}, {"use": "world.no_collisions"}],
    }
