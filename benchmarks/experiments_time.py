"""Wall time of one run of each headline paper experiment, and where it goes (docs/experiments-speed.md).

One run is one trial of the experiment's sweep file (``protocols/<family>/experiments/*.toml``) at the grid
point named below, called as the sweep calls it (``function(params, seed=, trial=)``, trial 0 and its seed),
in this process. ``--profile`` runs it under cProfile and splits the time by the code that spent it:

* world: ``world/`` (clock, kinematics, radio, sensing);
* hosts: ``swarmactors/robot``, ``swarmactors/runs``, ``transport/`` (the robots' runtime, the sessions, frames);
* behaviour: ``protocols/`` (the robots' rules, and a solver's model building);
* checks: ``swarmactors/oracle`` (reading the trace back, the oracles' bookkeeping);
* the profile counts this process's CPU time (``children_cpu_s``: the CPU of child processes it waited for,
  e.g. HiGHS in a forked child or host processes, not split);
* libraries (numpy, msgpack, scipy/HiGHS, asyncio ...) are charged to the project code that called them, in
  proportion to each caller's share of the calls' time; what no project code called stays ``other``.

    python benchmarks/experiments_time.py --list
    python benchmarks/experiments_time.py relays-fig7-a1 leader-follower-starts --profile --json
    python benchmarks/experiments_time.py relays-fig7-a3 --set ticks=500 --profile   # a shortened run

``--set KEY=VALUE`` changes the trial's parameters (a TOML value), e.g. a shorter ``ticks``.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import pstats
import sys
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


@dataclass(frozen=True)
class Experiment:
    name: str
    what: str  # the paper's figure or table
    sweep: str  # the sweep file, from the checkout
    point: dict = field(default_factory=dict)  # the grid point of "one run"


EXPERIMENTS = [
    Experiment("relays-fig6", "Swarm Relays Fig. 6 middle/top (time factor)", "protocols/relays/experiments/fig6.toml",
               {"targets": 4, "obstacle": True, "wp": True}),
    Experiment("relays-fig6-failures", "Swarm Relays Fig. 6 bottom (failures)",
               "protocols/relays/experiments/fig6-failures.toml", {"failed": 5}),
    Experiment("relays-fig7-a1", "Swarm Relays Fig. 7, arena 1 (25 robots, 1,500 ticks)",
               "protocols/relays/experiments/fig7.toml", {"arena": 1, "chains": 3, "F": 0.0}),
    Experiment("relays-fig7-a2", "Swarm Relays Fig. 7, arena 2 (60 robots, 2,200 ticks)",
               "protocols/relays/experiments/fig7.toml", {"arena": 2, "chains": 1, "F": 0.0}),
    Experiment("relays-fig7-a3", "Swarm Relays Fig. 7, arena 3 (100 robots, 5,000 ticks)",
               "protocols/relays/experiments/fig7.toml", {"arena": 3, "chains": 1, "F": 0.0}),
    Experiment("tsc-table2", "TSC Table II (one instance, TCTM + TDSM, 60 s limit each)",
               "protocols/tsc/experiments/tsc-table2.toml", {"class": 3, "density": 0.05}),
    Experiment("secs-table1", "SECS Table I (N = 20, 300 s)", "protocols/secs/experiments/table1.toml",
               {"delta": 240.0, "n": 20}),
    Experiment("roles-fig6-11", "Roles Figs. 6-11 (N = 50, 2,000 ticks)", "protocols/roles/experiments/fig6-11.toml",
               {"n": 50}),
    Experiment("roles-fig3-5", "Roles Figs. 3-5 (N = 100, 1,000 ticks)", "protocols/roles/experiments/fig3-5.toml",
               {"n": 100}),
    Experiment("lambda2-fig2", "lambda2 Fig. 2 (K = 10, PI2, p = 0.3)", "protocols/lambda2/experiments/fig2.toml",
               {"method": "pi2", "p": 0.3, "drop": "drop"}),
    Experiment("biconnectivity-coverage", "Biconnectivity coverage (73 % / 91 %, cr = 2)",
               "protocols/biconnectivity/experiments/coverage.toml", {"cr": 2.0}),
    Experiment("cbaa-instances", "CBAA instances (one instance)", "protocols/cbaa/experiments/instances.toml", {}),
    Experiment("leader-follower-starts", "Leader-follower starts (proposed, 30 s)",
               "protocols/leader_follower/experiments/starts.toml", {"method": "proposed"}),
    Experiment("stigmergy-convergence", "Virtual stigmergy convergence (n = 200, loss 0.3)",
               "protocols/stigmergy/experiments/convergence.toml", {"n": 200, "loss": 0.3, "anti_entropy": 5}),
]
BY_NAME = {e.name: e for e in EXPERIMENTS}

CATEGORIES = ("world", "hosts", "behaviour", "checks", "other")


def category(filename: str) -> str | None:
    """The project part a source file belongs to (None: a library, charged to its callers)."""
    f = filename.replace(os.sep, "/")
    root = str(ROOT).replace(os.sep, "/") + "/"
    if not f.startswith(root) or "/site-packages/" in f:  # a virtual environment may sit in the checkout
        return None
    rel = f[len(root):]
    if rel.startswith("world/"):
        return "world"
    if rel.startswith(("swarmactors/robot/", "swarmactors/runs/", "transport/")):
        return "hosts"
    if rel.startswith("protocols/"):
        return "behaviour"
    if rel.startswith("swarmactors/oracle/"):
        return "checks"
    return "other"


def shares(stats: pstats.Stats) -> dict[str, float]:
    """Seconds of own time per category; a library function's time goes to its callers' categories.

    A function's own time is split over its callers in proportion to the cumulative time each caller spent
    in it, climbing through library callers until project code (a recursion's own calls left out).
    """
    raw = stats.stats  # func -> (cc, nc, tt, ct, callers {caller: (cc, nc, tt, ct)})
    memo: dict = {}

    def split(func, stack: set) -> dict[str, float]:
        """Fractions of func's time per category (callers already on ``stack``, a recursion, are left out)."""
        if func in memo:
            return memo[func]
        cat = category(func[0])
        if cat is not None:
            return {cat: 1.0}
        callers = {c: v for c, v in (raw[func][4] if func in raw else {}).items() if c not in stack}
        total = sum(v[3] for v in callers.values())
        if len(stack) > 60 or not callers or total <= 0:
            return {"other": 1.0}
        stack.add(func)
        out: dict[str, float] = {}
        for caller, v in callers.items():
            for k, frac in split(caller, stack).items():
                out[k] = out.get(k, 0.0) + frac * v[3] / total
        stack.discard(func)
        memo[func] = out
        return out

    seconds = dict.fromkeys(CATEGORIES, 0.0)
    for func, (_cc, _nc, tt, _ct, _callers) in raw.items():
        for k, frac in split(func, set()).items():
            seconds[k] += tt * frac
    return seconds


def load_trial(exp: Experiment, sets: list[str]):
    """(function, params, seed) of trial 0 of ``exp``'s sweep file at its grid point, with ``--set``s applied."""
    from swarmactors.tools.sweep import _load_function, read_spec, trial_seed

    spec = read_spec(ROOT / exp.sweep)
    if spec is None:
        raise SystemExit(f"{exp.sweep}: not a callable sweep file")
    params = {**spec.get("params", {}), **exp.point}
    for item in sets:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise SystemExit(f"--set {item!r}: expected KEY=VALUE")
        try:
            params[key] = tomllib.loads(f"v = {value}")["v"]
        except tomllib.TOMLDecodeError as exc:
            raise SystemExit(f"--set {item!r}: {value!r} is not a TOML value ({exc})") from None
    return _load_function(spec["trial"], str(exp.sweep), "trial"), params, trial_seed(spec["seed"], 0)


def measure(exp: Experiment, sets: list[str], profile: bool) -> dict:
    fn, params, seed = load_trial(exp, sets)
    prof = cProfile.Profile(time.process_time) if profile else None  # CPU time: waiting is no one's share
    load = os.getloadavg()[0]
    t0, c0, k0 = time.perf_counter(), time.process_time(), os.times()
    if prof:
        prof.enable()
    result = fn(dict(params), seed=seed, trial=0)
    if prof:
        prof.disable()
    out = {"name": exp.name, "what": exp.what, "params": params, "seed": seed,
           "wall_s": round(time.perf_counter() - t0, 2), "cpu_s": round(time.process_time() - c0, 2),
           "children_cpu_s": round(sum(os.times()[2:4]) - sum(k0[2:4]), 2),
           "load_before": round(load, 2), "load_after": round(os.getloadavg()[0], 2)}
    if prof:
        sec = shares(pstats.Stats(prof))
        total = sum(sec.values()) or 1.0
        out["profile_s"] = round(total, 2)
        out["shares"] = {k: round(v / total, 3) for k, v in sec.items()}
    out["result"] = {k: v for k, v in (result or {}).items() if isinstance(v, (int, float, str, bool)) or v is None}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help="experiments to run (default: all; --list names them)")
    ap.add_argument("--list", action="store_true", help="name the experiments and their grid points, then stop")
    ap.add_argument("--profile", action="store_true", help="split the time into world / hosts / behaviour / checks")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a trial parameter (TOML value)")
    ap.add_argument("--json", action="store_true", help="one JSON object a run on stdout")
    args = ap.parse_args(argv)
    if args.list:
        for e in EXPERIMENTS:
            print(f"{e.name:26} {e.what}  [{e.sweep} {e.point}]")
        return 0
    unknown = [n for n in args.names if n not in BY_NAME]
    if unknown:
        ap.error(f"unknown experiment(s) {', '.join(unknown)}; --list names them")
    for name in args.names or list(BY_NAME):
        row = measure(BY_NAME[name], args.set, args.profile)
        if args.json:
            print(json.dumps(row), flush=True)
        else:
            sh = row.get("shares")
            print(f"{row['name']:26} {row['wall_s']:9.1f} s wall {row['cpu_s']:9.1f} s CPU  load {row['load_before']}"
                  + ("" if not sh else "  " + " ".join(f"{k} {100 * v:.0f} %" for k, v in sh.items())), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
