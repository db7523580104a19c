"""A sweep's wall time against the number of workers: the local pool and a Dask LocalCluster (docs/scaling.md).

    python benchmarks/sweep_scaling.py [--trials 8] [--ticks 300] [--out /tmp/sweep_scaling.json]

Runs the same sweep (flooding on 10 robots, ``--trials`` trials) with 1 and 2 workers, in the local
process pool and on a LocalCluster of single-threaded workers, and the same with 1-tick trials to
isolate the per-trial cost of starting a trial (the cluster's fresh child process and Dask's round
trip against the local pool's reused worker process). Prints and writes the times as JSON.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

from swarmactors.tools import sweep as sw

SCENARIO = """
[run]
name = "scaling"
seed = 3
ticks = {ticks}

[[robots]]
count = 10
placement = "line"
spacing = 0.9
behaviors = [{{ use = "flooding", origin = 0, at = 1, expiry = 8 }}]
"""


def timed(scenario: Path, trials: int, out: Path, workers: int, cluster: str | None) -> float:
    plan = sw.prepare(scenario, [], [], trials, out)
    t0 = time.perf_counter()
    outcome = sw.run_sweep(plan, workers=workers, keep="none", cluster=cluster)
    assert outcome.ran == trials and outcome.errors == 0, outcome
    return time.perf_counter() - t0


def main() -> None:
    from distributed import LocalCluster

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=8)
    ap.add_argument("--ticks", type=int, default=300)
    ap.add_argument("--out", type=Path, default=Path("/tmp/sweep_scaling.json"))
    args = ap.parse_args()
    report = {"trials": args.trials, "ticks": args.ticks, "cpus": os.cpu_count(), "runs": []}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for ticks in (args.ticks, 1):
            scenario = tmp / f"s{ticks}.toml"
            scenario.write_text(SCENARIO.format(ticks=ticks))
            for workers in (1, 2):
                load = os.getloadavg()[0]
                local = timed(scenario, args.trials, tmp / f"l{ticks}-{workers}", workers, None)
                with LocalCluster(n_workers=workers, threads_per_worker=1, dashboard_address=None) as c:
                    remote = timed(scenario, args.trials, tmp / f"c{ticks}-{workers}", 1, c.scheduler_address)
                row = {"ticks": ticks, "workers": workers, "local_s": round(local, 2), "cluster_s": round(remote, 2),
                       "load_before": round(load, 1)}
                print(json.dumps(row), flush=True)
                report["runs"].append(row)
    one = {r["workers"]: r for r in report["runs"] if r["ticks"] == 1}
    report["overhead_per_trial_s"] = round((one[1]["cluster_s"] - one[1]["local_s"]) / args.trials, 2)
    report["cluster_per_trial_1tick_s"] = round(one[1]["cluster_s"] / args.trials, 2)
    print(json.dumps(report, indent=1))
    args.out.write_text(json.dumps(report, indent=1) + "\n")


if __name__ == "__main__":
    main()
