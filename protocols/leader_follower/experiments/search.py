"""Search the §5.1 start and meander (the paper prints neither).

Table 1 followers 1..10 placed at random under Assumption 1 with a random meander; keep the seeds where the
prior method collides and the proposed method passes every check. Coarse sampling for the search (dt = 0.1 s
was used); the chosen seed is then run at 0.01 s. The §5.1 scenario is seed 42 with SPREAD 3.0, EDGE 0.8.

    python -m protocols.leader_follower.experiments.search FIRST LAST [DT] [DURATION] [SPREAD] [EDGE]
"""

from __future__ import annotations

import sys
import tempfile

from protocols.leader_follower import oracle, suite
from swarmactors.runs.launcher import run


def trial(seed: int, dt: float, duration: float, spread: float, edge: float | None) -> tuple:
    out = {}
    for method in ("prior", "proposed"):
        sc = suite.random_scenario(10, seed, duration=duration, dt=dt, table=True, method=method, spread=spread,
                                    edge=edge)
        with tempfile.TemporaryDirectory() as d:
            r = run(sc, out=d)
            out[method] = r
            if method == "proposed":
                v = oracle.violations(oracle.load(r))
    prior, prop = out["prior"], out["proposed"]
    col = prior["world"]["collisions"]["robot_robot"] if prior["world"].get("collisions") else 0
    fails = [c["name"] for c in prop.checks if not c["passed"]]
    pair = prior["world"]["collisions"]["episodes"][:1] if col else []
    return col > 0, col, pair, not fails, ",".join(fails), v[:1]


if __name__ == "__main__":
    first, last = int(sys.argv[1]), int(sys.argv[2])
    dt = float(sys.argv[3]) if len(sys.argv) > 3 else 0.05
    duration = float(sys.argv[4]) if len(sys.argv) > 4 else 70.0
    spread = float(sys.argv[5]) if len(sys.argv) > 5 else 3.0
    edge = float(sys.argv[6]) if len(sys.argv) > 6 else None
    for seed in range(first, last + 1):
        print(seed, *trial(seed, dt, duration, spread, edge), flush=True)
