"""Leader-follower navigation, beyond the paper: prior vs proposed, and margins against noise and sampling.

Prior vs proposed over random starts and meanders, and the proposed method's margin (minimum distance
between bodies) against sensing noise and the sampling period.

    python -m protocols.leader_follower.experiments.sweep [RUNS] [FOLLOWERS] [DURATION_S]    # defaults 20 6 30

Each run is one random configuration under Assumption 1 (suite.random_scenario: Table 1 rows drawn at random,
a random meander of the leader). Part 1 runs each configuration with both methods at dt = 0.05 s and counts
robot-robot collisions and runs where Assumptions 1–3 broke. Part 2 runs the first RUNS/4 configurations with
the proposed method at noise 0, 0.01, 0.02, 0.05 m (dt = 0.05 s) and at dt = 0.01, 0.05, 0.1, 0.2 s (no noise)
and reports the smallest body margin (distance between bodies) and the guarantee checks. Prints one JSON line
per run and a summary; wall time is printed too.

Part 1 over the issue's 200 starts as one sweep (a trial = one start with one method; the post step writes
starts.json with the tallies beside trials.csv), locally or on a Dask cluster:

    swarmactors sweep protocols/leader_follower/experiments/starts.toml [--cluster tcp://SCHEDULER:8786] [--trials 20]

Part 2 as one sweep too (a trial = one start with one noise level or sampling period; the post step writes
margins.json, the margin's spread per variant, beside trials.csv):

    swarmactors sweep protocols/leader_follower/experiments/margins.toml [--cluster tcp://SCHEDULER:8786] [--trials 10]
"""

from __future__ import annotations

import json
import sys
import tempfile
import time

from protocols.leader_follower import oracle, suite
from swarmactors.runs.launcher import run


def one(sc: dict) -> dict:
    with tempfile.TemporaryDirectory() as d:
        r = run(sc, out=d)
        ru = oracle.load(r)
        m = oracle.margins(ru)
        v = oracle.violations(ru)
    col = (r["world"].get("collisions") or {}).get("robot_robot", 0)
    checks = r.verdicts()
    return {"collisions": col, "assumptions_held": not v, "body_margin": round(m["body"], 4),
            "guarantees": all(checks[k] for k in ("leader_follower.spanning_tree", "leader_follower.target_distance",
                                                  "leader_follower.speed", "leader_follower.sigma"))}


def sweep_trial(params: dict, *, seed: int, trial: int) -> dict:
    """One start of ``starts.toml`` (beside this module): configuration ``1000 + trial``, one method."""
    sc = suite.random_scenario(int(params["followers"]), 1000 + trial, duration=float(params["duration"]),
                               dt=float(params["dt"]), method=params["method"])
    return {"start": 1000 + trial, "method": params["method"], **one(sc)}


def sweep_tally(csv_path, out_dir) -> list:
    """The post step: runs with a collision per method, and the proposed method's runs that broke an assumption."""
    from pathlib import Path

    from swarmactors.tools.sweep import returned_values

    rows = returned_values(csv_path)
    tally = {}
    for method in sorted({r["method"] for r in rows}):
        mine = [r for r in rows if r["method"] == method]
        tally[method] = {"runs": len(mine), "collision_runs": sum(r["collisions"] > 0 for r in mine),
                         "assumption_broken_runs": sum(not r["assumptions_held"] for r in mine),
                         "collision_runs_with_assumptions_held": sum(r["collisions"] > 0 and r["assumptions_held"]
                                                                     for r in mine),
                         "guarantees_held_runs": sum(bool(r["guarantees"]) for r in mine),
                         "min_body_margin": min(r["body_margin"] for r in mine)}
    path = Path(out_dir) / "starts.json"
    path.write_text(json.dumps(tally, indent=1))
    return [path]


VARIANTS = {"noise 0": (0.0, 0.05), "noise 0.01": (0.01, 0.05), "noise 0.02": (0.02, 0.05),
            "noise 0.05": (0.05, 0.05), "dt 0.01": (0.0, 0.01), "dt 0.1": (0.0, 0.1), "dt 0.2": (0.0, 0.2)}


def margin_trial(params: dict, *, seed: int, trial: int) -> dict:
    """One start of ``margins.toml`` (beside this module): the proposed method on configuration ``1000 + trial``.

    The sensing noise (m) and sampling period (s) are those of ``params["variant"]`` (``VARIANTS``).
    """
    noise, dt = VARIANTS[params["variant"]]
    sc = suite.random_scenario(int(params["followers"]), 1000 + trial, duration=float(params["duration"]), dt=dt,
                               noise=noise)
    return {"start": 1000 + trial, "variant": params["variant"], "noise": noise, "dt": dt, **one(sc)}


def margin_tally(csv_path, out_dir) -> list:
    """The post step of the margins sweep: per variant, the body margin's quantiles and the guarantee counts."""
    from pathlib import Path

    import numpy as np

    from swarmactors.tools.sweep import returned_values

    rows = returned_values(csv_path)
    out = {}
    for variant in VARIANTS:
        mine = [r for r in rows if r["variant"] == variant]
        if not mine:
            continue
        held = [r for r in mine if r["assumptions_held"]]
        margins = np.array([r["body_margin"] for r in mine])
        out[variant] = {"runs": len(mine), "collision_runs": sum(r["collisions"] > 0 for r in mine),
                        "assumption_broken_runs": len(mine) - len(held),
                        "guarantees_broken_where_assumptions_held": sum(not r["guarantees"] for r in held),
                        "margin_min": float(margins.min()), "margin_p10": float(np.quantile(margins, 0.1)),
                        "margin_median": float(np.median(margins))}
    path = Path(out_dir) / "margins.json"
    path.write_text(json.dumps(out, indent=1))
    return [path]


def main(runs: int, n: int, duration: float) -> None:
    t0 = time.time()
    tally = {"prior": [0, 0], "proposed": [0, 0, 0]}  # runs with a collision, ...
    for seed in range(runs):
        for method in ("prior", "proposed"):
            res = one(suite.random_scenario(n, 1000 + seed, duration=duration, dt=0.05, method=method))
            print(json.dumps({"part": 1, "seed": 1000 + seed, "method": method, **res}), flush=True)
            tally[method][0] += res["collisions"] > 0
            if method == "proposed":
                tally[method][1] += not res["assumptions_held"]
                tally[method][2] += res["collisions"] > 0 and res["assumptions_held"]
    print(json.dumps({"summary": 1, "runs": runs, "prior_collision_runs": tally["prior"][0],
                      "proposed_collision_runs": tally["proposed"][0],
                      "proposed_assumption_broken_runs": tally["proposed"][1],
                      "proposed_collision_runs_with_assumptions_held": tally["proposed"][2]}), flush=True)
    for seed in range(max(1, runs // 4)):
        for noise in (0.0, 0.01, 0.02, 0.05):
            res = one(suite.random_scenario(n, 1000 + seed, duration=duration, dt=0.05, noise=noise))
            print(json.dumps({"part": 2, "seed": 1000 + seed, "noise": noise, "dt": 0.05, **res}), flush=True)
        for dt in (0.01, 0.1, 0.2):
            res = one(suite.random_scenario(n, 1000 + seed, duration=duration, dt=dt))
            print(json.dumps({"part": 2, "seed": 1000 + seed, "noise": 0.0, "dt": dt, **res}), flush=True)
    print(json.dumps({"wall_s": round(time.time() - t0, 1)}), flush=True)


if __name__ == "__main__":
    args = [int(sys.argv[1]) if len(sys.argv) > 1 else 20, int(sys.argv[2]) if len(sys.argv) > 2 else 6,
            float(sys.argv[3]) if len(sys.argv) > 3 else 30.0]
    main(*args)
