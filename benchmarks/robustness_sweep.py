#!/usr/bin/env python
"""How much clock skew and loss the built-in protocols survive, judged by their own checks.

    python benchmarks/robustness_sweep.py [--families flooding,roles,biconnectivity,stigmergy,cbaa,flooding-remaining]
        [--seeds 2] [--jobs 2] [--no-realtime] [--out benchmarks/results/robustness.json]

For each family, two of its quick conformance cases (the scenarios and the oracle checks the family ships,
``swarmactors.runs.conformance``): a *skew case* (a lossless lockstep case) and a *loss case* (the family's lossy
lockstep case when it has one, else the skew case). Four axes, each a coarse grid walked upwards:

- ``clock_offset`` = [-o, o] seconds on every robot group (drawn per robot from the run's seed),
- ``clock_drift`` = [-d, d] ppm on every robot group,
- Bernoulli ``radio.loss`` = p,
- Gilbert-Elliott bursts: ``radio.loss_model = "gilbert"``, ``p_gb`` = g, ``p_bg`` = 0.5, ``loss_good`` = 0,
  ``loss_bad`` = 1 (mean burst 2 ticks; the long-run loss is g / (g + 0.5)).

A grid value passes when every seed's run (lockstep, seeds 1..S: ``run.seed``, which draws the clocks and the
losses) passes all the case's checks; the walk stops at the first failing value, and the largest passing one
is reported (the grid is assumed monotone beyond). Then a realtime spot check per family: its realtime quick
case (if it has one) with the largest passing clock offset and drift at once.
A *variant* (``VARIANTS``) sweeps a family's cases with behaviour parameters changed: ``flooding-remaining``
is flooding with ``lifetime = "remaining"`` (rule F1r). Results go to the JSON file; docs/robustness.md holds
the table.
"""

from __future__ import annotations

import argparse
import copy
import json
import logging
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

CASES = {  # family: (skew case, loss case, realtime case or None)
    "flooding": ("flooding/rgg-20-s1", "flooding/rgg-20-s1-loss-0.2", "flooding/rgg-12-s2-realtime"),
    "roles": ("roles/patrol-10-s1", "roles/patrol-10-s2-loss-0.1", None),
    "biconnectivity": ("biconnectivity/ring-6", "biconnectivity/ring-6", "biconnectivity/ring-5-realtime"),
    "stigmergy": ("stigmergy/rgg-20-s1", "stigmergy/rgg-20-s2-loss-0.2-anti-entropy",
                  "stigmergy/rgg-12-s3-realtime"),
    "cbaa": ("cbaa/rgg-15-s1-tasks-8", "cbaa/rgg-15-s1-tasks-8", "cbaa/rgg-10-s2-realtime-loss-0.1"),
}
# variants: a family's cases with behaviour parameters changed (name: (family, parameters))
VARIANTS = {"flooding-remaining": ("flooding", {"lifetime": "remaining"})}  # F1r: remaining lifetime
for _name, (_fam, _) in VARIANTS.items():
    CASES[_name] = CASES[_fam]
GRIDS = {
    "clock_offset": [0.1, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0],  # seconds, +- (dt = 1 s in every case but realtime)
    "clock_drift": [100.0, 1000.0, 10000.0, 50000.0, 100000.0],  # ppm, +-
    "loss": [0.01, 0.05, 0.1, 0.2, 0.3, 0.5],
    "gilbert": [0.01, 0.05, 0.1, 0.2, 0.4],  # p_gb, with p_bg = 0.5 and loss_bad = 1
}


def scenario(case_name: str, axis: str | None, value: float, seed: int, params: dict | None = None) -> dict:
    """The case's scenario (checks included) with one axis set to ``value``, run with ``seed``.

    ``params``: behaviour parameters set on every behaviour of the case's family (a variant).
    """
    from swarmactors.runs.conformance import case_by_name, prepare

    fam, case = case_by_name(case_name.split("/")[0], case_name, "quick")
    raw = copy.deepcopy(prepare(fam, case, None))
    raw["run"]["seed"] = seed
    raw["run"]["trace"] = True
    for group in raw["robots"]:
        for beh in group.get("behaviors", []):
            if params and beh.get("use") == fam.behavior:
                beh.update(params)
    radio = raw.setdefault("radio", {})
    if axis in ("clock_offset", "clock_drift"):
        for group in raw["robots"]:
            group[axis] = [-value, value]
    elif axis == "loss":
        radio["loss"] = value
    elif axis == "gilbert":
        radio.update(loss=0.0, loss_model="gilbert", p_gb=value, p_bg=0.5, loss_good=0.0, loss_bad=1.0)
    return raw


def run_one(case_name: str, axis: str | None, value: float, seed: int, skew: dict | None = None,
            params: dict | None = None) -> dict:
    """Run one scenario; its checks' outcome. ``skew``: clock offset and drift for the realtime spot check."""
    import swarmactors

    logging.getLogger().setLevel(logging.ERROR)
    raw = scenario(case_name, axis, value, seed, params)
    for key, v in (skew or {}).items():
        for group in raw["robots"]:
            group[key] = [-v, v]
    t0 = time.process_time()
    with tempfile.TemporaryDirectory() as tmp:
        try:
            result = swarmactors.run(raw, out=Path(tmp) / "r")
        except Exception as exc:  # a scenario the axis makes invalid counts as a failure, with the reason
            return {"case": case_name, "axis": axis, "value": value, "seed": seed, "passed": False,
                    "failed": [f"{exc.__class__.__name__}: {exc}"], "cpu_s": time.process_time() - t0}
        failed = [c["name"] for c in result.checks if not c["passed"]]
        return {"case": case_name, "axis": axis, "value": value, "seed": seed, "passed": result.passed,
                "failed": failed, "wall_s": result["wall_s"], "cpu_s": round(time.process_time() - t0, 2)}


def sweep_axis(pool, case_name: str, axis: str, seeds: int, params: dict | None = None) -> dict:
    """Walk the axis's grid upwards until a value fails on some seed."""
    rows, best = [], 0.0
    for value in GRIDS[axis]:
        futs = [pool.submit(run_one, case_name, axis, value, s, None, params) for s in range(1, seeds + 1)]
        got = [f.result() for f in futs]
        rows += got
        ok = all(g["passed"] for g in got)
        why = sorted({c for g in got for c in g["failed"]})
        print(f"  {case_name:45s} {axis:13s} {value:>9g}: {'pass' if ok else f'FAIL {why}'}", flush=True)
        if not ok:
            return {"largest_passing": best, "first_failing": value,
                    "failed_checks": sorted({c for g in got for c in g["failed"]}), "rows": rows}
        best = value
    return {"largest_passing": best, "first_failing": None, "failed_checks": [], "rows": rows}


def table(data: dict) -> str:
    """The Markdown table of docs/robustness.md from the JSON file."""
    def cell(ax: dict, unit: str) -> str:
        best, bad = ax["largest_passing"], ax["first_failing"]
        if bad is None:
            return f"≥ {best:g}{unit} (whole grid)"
        first = "< smallest" if not best else f"{best:g}{unit}"
        return f"{first} (fails at {bad:g}{unit}: {', '.join(c.split('.', 1)[-1] for c in ax['failed_checks'])})"

    lines = ["| family | skew case / loss case | clock offset ± | clock drift ± | Bernoulli loss "
             "| Gilbert–Elliott p_gb (p_bg 0.5, loss_bad 1) | realtime spot check (largest passing skew) | CPU s |",
             "|---|---|---|---|---|---|---|---:|"]
    for fam, f in data["families"].items():
        ax = f["axes"]
        rt = f.get("realtime")
        rt_cell = "no realtime case" if rt is None else (
            f"`{rt['case'].split('/', 1)[1]}`: {sum(r['passed'] for r in rt['rows'])}/{len(rt['rows'])} passed")
        lines.append(f"| {fam} | `{f['skew_case'].split('/', 1)[1]}` / `{f['loss_case'].split('/', 1)[1]}` | "
                     f"{cell(ax['clock_offset'], ' s')} | {cell(ax['clock_drift'], ' ppm')} | {cell(ax['loss'], '')} | "
                     f"{cell(ax['gilbert'], '')} | {rt_cell} | {f['cpu_s']:g} |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--families", default=",".join(CASES))
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--no-realtime", action="store_true")
    ap.add_argument("--table", action="store_true", help="print the Markdown table from --out and exit")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "robustness.json")
    args = ap.parse_args()
    data = json.loads(args.out.read_text()) if args.out.exists() else {}
    if args.table:
        print(table(data))
        return
    data.setdefault("families", {})
    t0 = time.time()
    with ProcessPoolExecutor(args.jobs) as pool:
        for fam in args.families.split(","):
            skew_case, loss_case, rt_case = CASES[fam]
            params = VARIANTS.get(fam, (fam, None))[1]
            base = [pool.submit(run_one, c, None, 0.0, s, None, params) for c in sorted({skew_case, loss_case})
                    for s in range(1, args.seeds + 1)]
            out = {"skew_case": skew_case, "loss_case": loss_case, "baseline": [f.result() for f in base],
                   "axes": {}, **({"params": params} if params else {})}
            for axis in GRIDS:
                case = skew_case if axis.startswith("clock") else loss_case
                out["axes"][axis] = sweep_axis(pool, case, axis, args.seeds, params)
            if rt_case and not args.no_realtime:
                skew = {k: out["axes"][k]["largest_passing"] for k in ("clock_offset", "clock_drift")
                        if out["axes"][k]["largest_passing"]}
                rt = [pool.submit(run_one, rt_case, None, 0.0, s, skew, params) for s in (1, 2)]
                out["realtime"] = {"case": rt_case, "skew": skew, "rows": [f.result() for f in rt]}
                print(f"  realtime {rt_case} with {skew}: "
                      f"{[r['passed'] for r in out['realtime']['rows']]}", flush=True)
            out["cpu_s"] = round(sum(r.get("cpu_s", 0) for ax in out["axes"].values() for r in ax["rows"])
                                 + sum(r.get("cpu_s", 0) for r in out["baseline"]), 1)
            data["families"][fam] = out
            data["seeds"] = args.seeds
            data["grids"] = GRIDS
            args.out.parent.mkdir(parents=True, exist_ok=True)
            args.out.write_text(json.dumps(data, indent=1, default=float))
    data["wall_s" if set(args.families.split(",")) >= set(CASES) - set(VARIANTS) else "wall_s_last_part"] = round(
        time.time() - t0, 1)  # a partial rerun keeps the whole sweep's time
    args.out.write_text(json.dumps(data, indent=1, default=float))
    print(f"wrote {args.out} in {data['wall_s']} s")


if __name__ == "__main__":
    main()
