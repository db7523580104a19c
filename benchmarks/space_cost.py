#!/usr/bin/env python
"""The cost of the world's space rules: occlusion and collision detection on the world's tick.

    python benchmarks/space_cost.py [--robots 1000] [--ticks 40] [--repeats 5]

Issue 14's measurement: 1,000 robots in a 512 x 512 grid maze (one length unit per cell), radio range 10
cells, every robot broadcasting once per tick. The positions are recorded once (a random walk that the
world's own motion rule keeps out of the walls) and replayed, so each configuration does the same work:

* ``no-map``    - no obstacles at all: reach and sensing (k-d tree), the radio's decisions for every frame
  (``Medium.decide``) and motion (``integrate``): the parts of the world's tick that depend on positions;
* ``off``       - the maze, occlusion off: the same plus motion against the walls (``SpaceRules.constrain``);
* ``occlusion`` - ``off`` plus the occlusion test of every in-range link (``SpaceRules.hidden_by_sender``);
* ``bodies``    - ``occlusion`` plus collision episodes for bodies of radius 0.3 against robots and walls.

The issue's ratio is ``occlusion`` against ``off``.

The world's per-tick CPU time (``time.process_time``) is measured per configuration, the configurations
interleaved, ``--repeats`` times; the script prints medians and ratios to ``off`` and writes
benchmarks/results/space_cost.json. Nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

import numpy as np

from swarmactors.runs import maps
from transport.scenario import Radio, robot_spec
from transport.space import space_from_spec
from world.kinematics import integrate
from world.radio import Medium, Outgoing
from world.registry import Robots
from world.sensing import sense, within
from world.space import SpaceRules

ROOT = Path(__file__).resolve().parent.parent


def world_spec() -> dict:
    rows = maps.maze(170, 170, seed=1)  # 511 x 511 cells
    grid = maps.parse_map(["type octile", f"height {len(rows)}", f"width {len(rows[0])}", "map", *rows], "maze")
    return {"dims": 2, "map": grid}


def record(spec: dict, n: int, ticks: int, seed: int) -> list[np.ndarray]:
    """Positions of ``n`` robots over ``ticks`` ticks: random walks kept out of the walls by the world's rule."""
    space = space_from_spec(spec)
    rules = SpaceRules(space, 2, occlusion=False, blocking=False)
    rng = np.random.default_rng(seed)
    pts = np.zeros((0, 2))
    while len(pts) < n:  # placement outside the walls
        p = rng.uniform(0, 511, (n, 2))
        pts = np.vstack([pts, p[~space.inside(np.column_stack([p, np.zeros(n)]))]])
    r = Robots(2)
    r.add([robot_spec({"pos": list(p), "speed": 1.0}, 2, 1.0) for p in pts[:n]], tick=0)
    out = []
    for _ in range(ticks):
        out.append(r.pos.copy())
        r.vel[:] = rng.normal(0, 1, (n, 2))
        before = r.pos.copy()
        integrate(r.pos, r.heading, r.vel, r.speed, r.turn_rate, r.alive, 1.0, None)
        rules.constrain(before, r.pos, r, 1.0)
    return out


def tick_cost(config: str, spec: dict, trace: list[np.ndarray], radius: float) -> float:
    """Median CPU seconds of one world tick (reach, occlusion, radio decisions, collisions) over the trace."""
    n = len(trace[0])
    robots = Robots(2)
    robots.add([robot_spec({"pos": list(p), "range": radius, "body_radius": 0.3 if config == "bodies" else 0.0},
                           2, radius) for p in trace[0]], tick=0)
    rules = (SpaceRules(space_from_spec(spec), 2, occlusion=config in ("occlusion", "bodies"), blocking=False)
             if config != "no-map" else None)
    rng = np.random.default_rng(5)
    medium = Medium(Radio(range=radius), seed=1)
    ids = np.arange(n)
    frames = [Outgoing(i, None, "b", 1, b"x" * 16) for i in range(n)]
    vel = rng.normal(0, 1, (len(trace), n, 2))
    costs = []
    for t, pos in enumerate(trace):
        robots.pos[:] = pos
        c0 = time.process_time()
        reach = within(pos, ids, robots.range)
        sense(pos, reach, robots.noise, 1, t)
        occluded = {}
        if rules is not None:
            occluded = rules.hidden_by_sender(pos, reach)  # as World.begin does
            if config == "bodies":
                rules.collisions(t, pos, robots)
        medium.decide(t, frames, reach, robots.alive, pos, robots.range, occluded)  # (deliveries, drops, overheard)
        robots.vel[:] = vel[t]
        before = robots.pos.copy()
        integrate(robots.pos, robots.heading, robots.vel, robots.speed, robots.turn_rate, robots.alive, 1.0, None)
        if rules is not None:
            rules.constrain(before, robots.pos, robots, 1.0)
        costs.append(time.process_time() - c0)
    return statistics.median(costs)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--robots", type=int, default=1000)
    ap.add_argument("--ticks", type=int, default=40)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--range", type=float, default=10.0)
    args = ap.parse_args()
    spec = world_spec()
    trace = record(spec, args.robots, args.ticks, seed=3)
    configs = ["no-map", "off", "occlusion", "bodies"]
    runs: dict[str, list[float]] = {c: [] for c in configs}
    for _ in range(args.repeats):
        for c in configs:  # interleaved
            runs[c].append(tick_cost(c, spec, trace, args.range))
    med = {c: statistics.median(v) for c, v in runs.items()}
    out = {"robots": args.robots, "grid": [511, 511], "range_cells": args.range, "ticks": args.ticks,
           "repeats": args.repeats, "median_tick_cpu_ms": {c: round(v * 1e3, 3) for c, v in med.items()},
           "ratio_to_off": {c: round(v / med["off"], 3) for c, v in med.items()},
           "runs_ms": {c: [round(x * 1e3, 3) for x in v] for c, v in runs.items()}}
    path = ROOT / "benchmarks" / "results" / "space_cost.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(out, indent=2) + "\n")
    for c in configs:
        print(f"{c:10s} {med[c] * 1e3:8.2f} ms per tick  x{med[c] / med['off']:.2f} of off")


if __name__ == "__main__":
    main()
