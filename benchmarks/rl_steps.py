#!/usr/bin/env python
"""Environment steps per second of ``swarmactors.rl.parallel_env`` at N agents (docs/rl.md, "Speed").

    python benchmarks/rl_steps.py [--n 10 100] [--steps 300] [--repeats 3] [--out FILE]

The swarm: N robots placed uniformly in a square of side 1.2·sqrt(N) (about 8 others within radio range 2,
whatever N), speed cap 0.5, latency 1, loss 0.1. Four cases at each N:

* ``talk``: the default observation (pose, 6 neighbours, 4 messages of 4 floats) and random actions in which
  every agent broadcasts a payload every step (the radio's heaviest case for the env);
* ``quiet``: pose and 6 neighbours, no messages (velocity-only actions);
* ``dispersion``: ``talk`` with the built-in dispersion task's reward (coverage on a 40 x 40 grid and the
  radio graph's largest component, each step); the other cases have no task (a reward of 0);
* ``ticks``: for reference, the same swarm as a plain in-process run (``InProcessRun.sync_step``) whose robots
  run the ``beacon`` behaviour (one frame per robot per tick), without the environment.

Actions are drawn before the clock starts; the time is that of ``env.step`` alone (``reset`` excluded), the
median over ``--repeats`` episodes. Nothing is asserted: numbers go to stdout and the JSON file, and by hand to
docs/rl.md.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import statistics
import time
from pathlib import Path

import numpy as np


def scenario(n: int, steps: int, behaviors: list[dict]) -> dict:
    side = 1.2 * math.sqrt(n)
    return {"run": {"name": f"rl-bench-{n}", "ticks": steps + 1, "seed": 1, "trace": False},
            "radio": {"range": 2.0, "latency": 1, "loss": 0.1},
            "world": {"bounds": [[0.0, 0.0], [side, side]]},
            "robots": [{"count": n, "speed": 0.5, "behaviors": behaviors}]}


def env_rate(n: int, steps: int, talk: bool, seed: int, task: str | None = None) -> float:
    from swarmactors.rl import parallel_env

    kw = {} if talk else {"observe": ("pose", "neighbors")}
    env = parallel_env(scenario(n, steps, [{"use": "rl"}]), task=task, **kw)
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    width = env.action_space(env.possible_agents[0]).shape[0]
    plan = [{a: rng.uniform(-1, 1, width).astype(np.float32) for a in env.possible_agents} for _ in range(steps)]
    if talk:
        for actions in plan:
            for a in actions.values():
                a[-1] = 1.0  # every agent broadcasts
    t0 = time.perf_counter()
    done = 0
    for actions in plan:
        if not env.agents:
            break
        env.step({a: actions[a] for a in env.agents})
        done += 1
    rate = done / (time.perf_counter() - t0)
    env.close()
    return rate


def tick_rate(n: int, steps: int) -> float:
    from swarmactors.runs.inprocess import InProcessRun
    from swarmactors.runs.launcher import resolve_run
    from transport.scenario import Scenario

    spec = Scenario.from_dict(resolve_run(scenario(n, steps, [{"use": "beacon"}])))
    run = InProcessRun(spec)
    t0 = time.perf_counter()
    for _ in range(steps):
        run.sync_step()
    return steps / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[10, 100])
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    rows = []
    for n in args.n:
        for case in ("talk", "quiet", "dispersion", "ticks"):
            rates = [tick_rate(n, args.steps) if case == "ticks"
                     else env_rate(n, args.steps, case != "quiet", r, "dispersion" if case == "dispersion" else None)
                     for r in range(args.repeats)]
            med = statistics.median(rates)
            rows.append({"n": n, "case": case, "steps_per_s": round(med, 1), "agent_steps_per_s": round(med * n),
                         "runs": [round(r, 1) for r in rates]})
            print(f"N = {n:4d}  {case:<10} {med:8.1f} steps/s  ({med * n:9.0f} agent-steps/s)  runs {rows[-1]['runs']}")
    if args.out:
        meta = {"steps": args.steps, "repeats": args.repeats, "python": platform.python_version(),
                "machine": platform.machine()}
        args.out.write_text(json.dumps({"meta": meta, "rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
