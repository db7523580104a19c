#!/usr/bin/env python
"""A/B: CPU cost per delivery of the world and of the robot hosts, this tree against a baseline commit.

    python benchmarks/core_ab.py [--base COMMIT] [--n 1000] [--repeats 5] [--out benchmarks/results/core_ab.json]

The workload is the lockstep beacon (scenarios/beacon.toml: every robot broadcasts one small frame per tick)
with K = 2 host processes. A lockstep run is a pure function of the scenario and the seed, so both versions
process exactly the same inputs (the script checks that their trace hashes agree). For each version it runs
the scenario for ``--short`` and for ``--long`` ticks and takes the difference, so start-up (imports, joining,
spawning) cancels out:

* world CPU per delivery = Δ(CPU time of the world process) / Δ(deliveries),
* host CPU per delivery = Δ(CPU time of the host processes, as children) / Δ(deliveries).

Both include the Zenoh threads of their processes, which are the same code in both versions. Versions run
interleaved (A B B A A B …) ``--repeats`` times; the medians are compared. A compared commit is checked out as a
detached git worktree under the system's temporary directory; its modules shadow the installed ones through
PYTHONPATH (the behaviour is named by module path, so the installed entry points do not matter).
Nothing is asserted: the numbers go to the JSON file and docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MEASURE = r"""
import json, os, sys
from swarmactors.runs.launcher import run
def main():
    n, ticks, out = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
    sc = {"run": {"name": "ab", "seed": 1, "ticks": ticks, "trace": False},
          "radio": {"range": 1.5},
          "robots": [{"count": n, "placement": "grid", "spacing": 1.0,
                      "behaviors": [{"use": "beacon", "every": 1}]}]}
    t0 = os.times()
    r = run(sc, out=out, processes=2)
    t1 = os.times()
    print(json.dumps({"world_cpu": (t1.user - t0.user) + (t1.system - t0.system),
                      "hosts_cpu": (t1.children_user - t0.children_user) + (t1.children_system - t0.children_system),
                      "deliveries": r["world"]["deliveries"], "ticks": r["ticks"], "hash": r["trace_hash"]}))
if __name__ == "__main__":
    main()
"""


def worktree(commit: str) -> Path:
    path = Path(tempfile.gettempdir()) / f"swarmactors-base-{commit[:12]}"
    if not path.exists():
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(path), commit], check=True,
                       capture_output=True)
    return path


def measure(tree: Path, n: int, ticks: int) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree), "PYTHONHASHSEED": "0"}
    with tempfile.TemporaryDirectory() as out:
        p = subprocess.run([sys.executable, "-c", MEASURE, str(n), str(ticks), out], cwd=tree, env=env,
                           capture_output=True, text=True, timeout=900)
    if p.returncode != 0:
        raise RuntimeError(f"{tree}: {p.stderr[-2000:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def marginal(tree: Path, n: int, short: int, long: int) -> dict:
    a, b = measure(tree, n, short), measure(tree, n, long)
    d = b["deliveries"] - a["deliveries"]
    return {"world_us": 1e6 * (b["world_cpu"] - a["world_cpu"]) / d,
            "hosts_us": 1e6 * (b["hosts_cpu"] - a["hosts_cpu"]) / d,
            "deliveries": d, "hash": b["hash"]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", default="08e4ba6", help="baseline commit (default: before Core v2)")
    ap.add_argument("--new", default=None, help="commit to compare (default: this working tree)")
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--short", type=int, default=10)
    ap.add_argument("--long", type=int, default=50)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "core_ab.json")
    args = ap.parse_args(argv)
    trees = {"base": worktree(args.base), "new": worktree(args.new) if args.new else ROOT}
    runs: dict[str, list[dict]] = {"base": [], "new": []}
    for i in range(args.repeats):
        order = ("base", "new") if i % 2 == 0 else ("new", "base")
        for name in order:
            r = marginal(trees[name], args.n, args.short, args.long)
            runs[name].append(r)
            print(f"{i} {name:4s} world {r['world_us']:.2f} us/delivery  hosts {r['hosts_us']:.2f} us/delivery",
                  flush=True)
    summary = {}
    for name, rs in runs.items():
        summary[name] = {k: statistics.median(r[k] for r in rs) for k in ("world_us", "hosts_us")}
    hashes = {r["hash"] for rs in runs.values() for r in rs}
    ratio = {k: summary["new"][k] / summary["base"][k] for k in ("world_us", "hosts_us")}
    result = {"base": args.base, "new": args.new or "working tree", "n": args.n, "ticks": [args.short, args.long],
              "repeats": args.repeats,
              "median": summary, "ratio_new_over_base": ratio, "same_trace_hash": len(hashes) == 1,
              "runs": runs, "cpus": os.cpu_count()}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2))
    print(json.dumps({"median": summary, "ratio_new_over_base": ratio, "same_trace_hash": len(hashes) == 1},
                     indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
