#!/usr/bin/env python
"""The papers' protocols on a shared channel: what breaks, against density and medium access.

    python benchmarks/channel_protocols.py [--seeds 2] [--jobs 2] [--only flooding lambda2 ...]

Four protocols, each run in process (``swarmactors.runs.inprocess``, lockstep, the robots' own code), with six
radios and at three densities. The radio range is 40 m in every run (``unit_m`` = 40 m / the scenario's
range), the channel the generic preset (0 dBm, n = 3, L0 = 40 dB, σ = 4 dB, noise −100 dBm, sensitivity
−95 dBm, SINR 6 dB, 250 kbit/s):

* ``off``       - no channel: every copy within range arrives (the disk model);
* ``none``      - path loss and shadowing, no contention (``mac = "none"``);
* ``aloha``     - pure ALOHA, each frame sent at a uniform time within its tick (``window_s`` = ``run.dt``);
* ``aloha-sync``, ``slotted-sync``, ``csma-sync`` - pure ALOHA, slotted ALOHA and CSMA with every frame
  sent within the first 5 ms of its tick (``window_s`` = 0.005: robots that react at once to what they
  received at the start of the tick; a frame of 25 to 120 bytes is 1.7 to 4.7 ms on the air).

Density is the mean degree of the disk graph: static robots placed uniformly in a square whose side is set
for the target degree (the expectation with the square's border effect), re-drawn until connected; the
measured mean degree is reported. Per protocol:

* **flooding** - 50 robots, degrees 5, 10, 20; robot 0 floods once (forward-once, expiry 20): the delivery
  ratio (robots reached / 49) and the mean latency in ticks of those reached;
* **biconnectivity** - 8 robots, degrees 3, 4, 5 (its relay enumerates every simple path: 10 robots at degree
  5 are already over the relay budget without a channel); robot 0 starts Ahmadi & Stone's check at tick 1:
  the verdicts of the check-running robots (robot 0 and those that heard its request) against the paper's
  biconnectivity of the disk graph, wrong and missing (null: timeout) in percent;
* **lambda2** - 24 robots, degrees 5, 10, 20; PI1 for 600 ticks: the error of the median final estimate
  against λ2 of the disk graph's Laplacian, in percent;
* **roles** - Kobayashi et al.'s patrol (role switching) with 10, 20 and 30 robots (the mission sets the
  geometry: more robots, a denser swarm), 800 ticks: targets reached and the oracle's disconnections from the
  base station (episodes, and ticks with some robot disconnected).

Prints one line per run group and writes benchmarks/results/channel_protocols.json; nothing is asserted.
The defaults are a reduced budget (``--seeds 2``: 2 placements per cell for λ2 and roles, 4 for flooding, 8 for
biconnectivity, the cheap ones; 800 ticks of patrol instead of the paper's 2000): about 10 minutes on 2 loaded
cores.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import networkx as nx
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

RANGE_M = 40.0  # every radio range, in metres
SYNC_S = 0.005  # the synchronised MACs' send window
RADIOS = {
    "off": None,
    "none": {"mac": "none"},
    "aloha": {"mac": "aloha"},
    "aloha-sync": {"mac": "aloha", "window_s": SYNC_S},
    "slotted-sync": {"mac": "slotted", "window_s": SYNC_S},
    "csma-sync": {"mac": "csma", "window_s": SYNC_S},
}
PROTOCOLS = {  # name: (robots, densities: mean degrees, or robots for roles)
    "flooding": (50, [5, 10, 20]),
    "biconnectivity": (8, [3, 4, 5]),
    "lambda2": (24, [5, 10, 20]),
    "roles": (None, [10, 20, 30]),
}
SEED_FACTOR = {"flooding": 2, "biconnectivity": 4, "lambda2": 1, "roles": 1}  # the cheap ones get more seeds
ROLES_TICKS = 800
LAMBDA2_TICKS = 600


def channel(radio: str, scenario_range: float) -> dict | None:
    cfg = RADIOS[radio]
    if cfg is None:
        return None
    return {**cfg, "unit_m": RANGE_M / scenario_range}


def side_for_degree(n: int, degree: float, r: float = 1.0) -> float:
    """The side L of the square in which n uniform robots with range r have the expected mean degree ``degree``.

    Expected degree (n − 1)·(πρ² − 8ρ³/3 + ρ⁴/2), ρ = r / L ≤ 1 (two uniform points of the unit square
    within ρ of each other).
    """
    def expected(rho: float) -> float:
        return (n - 1) * (math.pi * rho**2 - 8 * rho**3 / 3 + rho**4 / 2)

    lo, hi = 1e-6, 1.0
    if expected(hi) < degree:
        raise ValueError(f"degree {degree} unreachable with {n} robots")
    for _ in range(100):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if expected(mid) < degree else (lo, mid)
    return r / hi


def placement(n: int, degree: float, seed: int) -> tuple[np.ndarray, nx.Graph]:
    """N robots uniform in the square for ``degree`` (range 1), re-drawn until connected; with their disk graph."""
    rng = np.random.default_rng([seed, n, int(degree * 10), 38])
    side = side_for_degree(n, degree)
    for _ in range(10_000):
        pts = rng.random((n, 2)) * side
        g = disk_graph(pts, 1.0)
        if nx.is_connected(g):
            return np.round(pts, 6), g
    raise RuntimeError(f"no connected placement of {n} at degree {degree}")


def disk_graph(pts: np.ndarray, r: float) -> nx.Graph:
    d = np.linalg.norm(pts[:, None, :] - pts[None, :, :], axis=2)
    g = nx.Graph()
    g.add_nodes_from(range(len(pts)))
    g.add_edges_from((int(i), int(j)) for i, j in zip(*np.nonzero(np.triu(d <= r, 1)), strict=True))
    return g


def static_scenario(name: str, pts: np.ndarray, seed: int, ticks: int, radio: str, behavior: dict) -> dict:
    r: dict = {"range": 1.0, "latency": 1}
    ch = channel(radio, 1.0)
    if ch is not None:
        r["channel"] = ch
    return {"run": {"name": name, "seed": seed, "ticks": ticks, "trace": False}, "radio": r,
            "robots": [{"positions": pts.tolist(), "behaviors": [behavior]}], "checks": []}


def drops(result) -> dict:
    d = result["world"]["dropped"]
    return {k: d.get(k, 0) for k in ("collision", "below_sensitivity", "deferred_too_long")}


# ---------------------------------------------------------------- one run per protocol
def run_flooding(n: int, degree: float, seed: int, radio: str, out: Path) -> dict:
    from swarmactors.runs.inprocess import run_inprocess

    pts, g = placement(n, degree, seed)
    r = run_inprocess(out=out, scenario=static_scenario("channel-flooding", pts, seed, 24, radio,
                                      {"use": "flooding", "origin": 0, "at": 1, "expiry": 20}))
    got = [rob["flooding"]["received"]["0/0"] for rid, rob in r["robots"].items()
           if int(rid) != 0 and rob["flooding"]["received"].get("0/0")]
    return {"degree": 2 * g.number_of_edges() / n, "delivery": len(got) / (n - 1),
            "latency": statistics.mean(e["tick"] - 1 for e in got) if got else None, **drops(r)}


def run_biconnectivity(n: int, degree: float, seed: int, radio: str, out: Path) -> dict:
    from protocols.biconnectivity.oracle import paper_biconnected
    from swarmactors.runs.inprocess import run_inprocess

    pts, g = placement(n, degree, seed)
    truth = paper_biconnected(g)
    beh = {"use": "biconnectivity", "N": n, "c": 1, "initiator": 0, "at": 1, "hello": 0}
    r = run_inprocess(out=out, scenario=static_scenario("channel-biconnectivity", pts, seed, 6 * n + 8, radio, beh))
    checks = wrong = missing = budget = 0
    for rep in r.reports("biconnectivity").values():
        for ck in rep.get("checks", []):
            if ck.get("reason") == "budget":
                budget += 1
                continue
            checks += 1
            if ck["verdict"] is None:
                missing += 1
            elif ck["verdict"] != truth:
                wrong += 1
    return {"degree": 2 * g.number_of_edges() / n, "biconnected": truth, "checks": checks, "wrong": wrong,
            "missing": missing, "budget": budget, **drops(r)}


def run_lambda2(n: int, degree: float, seed: int, radio: str, out: Path) -> dict:
    from protocols.lambda2.oracle import laplacian_lambda2
    from swarmactors.runs.inprocess import run_inprocess

    pts, g = placement(n, degree, seed)
    truth = laplacian_lambda2(g)
    beh = {"use": "lambda2", "method": "pi1"}
    r = run_inprocess(out=out, scenario=static_scenario("channel-lambda2", pts, seed, LAMBDA2_TICKS, radio, beh))
    finals = []
    for rep in r.reports("lambda2").values():
        est = [e for e in rep["estimates"] if e is not None and math.isfinite(e)]
        if est:
            finals.append(est[-1])
    med = float(np.median(finals)) if finals else None
    err = abs(med - truth) / (1e-2 * truth) if med is not None else None
    return {"degree": 2 * g.number_of_edges() / n, "lambda2": truth, "estimate": med, "error_percent": err,
            **drops(r)}


def run_roles(n: int, _density: float, seed: int, radio: str, out: Path) -> dict:
    from protocols.roles.oracle import disconnection_episodes
    from protocols.roles.scenarios import D_C, patrol_scenario
    from swarmactors.runs.inprocess import run_inprocess

    sc = patrol_scenario(n, seed, ROLES_TICKS, checks=[])
    ch = channel(radio, D_C)
    if ch is not None:
        sc["radio"]["channel"] = ch
    r = run_inprocess(out=out, scenario=sc)
    reached = sum(len(rep.get("reached", [])) for rep in r.reports("roles").values())
    info = disconnection_episodes(r)
    return {"targets": reached, "disconnections": len(info["episodes"]),
            "ticks_disconnected": sum(1 for _, k in info["per_tick"] if k), **drops(r)}


RUN = {"flooding": run_flooding, "biconnectivity": run_biconnectivity, "lambda2": run_lambda2, "roles": run_roles}


def task(args: tuple) -> tuple:
    proto, n, density, seed, radio = args
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        out = RUN[proto](n if n is not None else density, density, seed, radio, Path(tmp))
    out["wall_s"] = round(time.perf_counter() - t0, 2)
    return args, out


# ---------------------------------------------------------------- aggregation
def mean(xs: list) -> float | None:
    xs = [x for x in xs if x is not None]
    return round(float(statistics.mean(xs)), 3) if xs else None


def summarise(proto: str, runs: list[dict]) -> dict:
    row = {"degree": mean([x.get("degree") for x in runs])}
    if proto == "flooding":
        row.update(delivery=mean([x["delivery"] for x in runs]), latency=mean([x["latency"] for x in runs]))
    elif proto == "biconnectivity":
        checks = sum(x["checks"] for x in runs)
        row.update(checks=checks, biconnected=sum(x["biconnected"] for x in runs),
                   wrong_percent=round(100 * sum(x["wrong"] for x in runs) / checks, 1) if checks else None,
                   missing_percent=round(100 * sum(x["missing"] for x in runs) / checks, 1) if checks else None,
                   budget=sum(x["budget"] for x in runs))
    elif proto == "lambda2":
        errs = [x["error_percent"] for x in runs]
        row.update(error_percent=mean(errs), error_max=max((e for e in errs if e is not None), default=None),
                   no_estimate=sum(e is None for e in errs))
    else:
        row.update(targets=mean([x["targets"] for x in runs]), disconnections=mean([x["disconnections"] for x in runs]),
                   ticks_disconnected=mean([x["ticks_disconnected"] for x in runs]))
    row.update({k: mean([x[k] for x in runs]) for k in ("collision", "below_sensitivity", "deferred_too_long")})
    row["wall_s"] = round(sum(x["wall_s"] for x in runs), 1)
    return row


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, default=2)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--only", nargs="+", choices=list(PROTOCOLS), default=list(PROTOCOLS))
    p.add_argument("--radios", nargs="+", choices=list(RADIOS), default=list(RADIOS))
    p.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "channel_protocols.json")
    args = p.parse_args()
    tasks = [(proto, PROTOCOLS[proto][0], dens, seed, radio)
             for proto in args.only for dens in PROTOCOLS[proto][1] for radio in args.radios
             for seed in range(1, args.seeds * SEED_FACTOR[proto] + 1)]
    # the costliest first, so that the pool's two workers finish together
    tasks.sort(key=lambda t: ({"roles": 0, "lambda2": 1, "biconnectivity": 2, "flooding": 3}[t[0]], -t[2]))
    t0 = time.perf_counter()
    done: dict[tuple, list[dict]] = {}
    with ProcessPoolExecutor(args.jobs) as pool:
        for (proto, _n, dens, _seed, radio), out in pool.map(task, tasks):
            done.setdefault((proto, dens, radio), []).append(out)
    rows = []
    for proto in args.only:
        for dens in PROTOCOLS[proto][1]:
            for radio in args.radios:
                row = {"protocol": proto, "robots": PROTOCOLS[proto][0] or dens, "density": dens, "radio": radio,
                       **summarise(proto, done[(proto, dens, radio)])}
                rows.append(row)
                print(json.dumps(row), flush=True)
    wall = round(time.perf_counter() - t0, 1)
    print(f"{len(tasks)} runs in {wall} s")
    args.out.write_text(json.dumps({"seeds": {k: args.seeds * f for k, f in SEED_FACTOR.items()},
                                    "roles_ticks": ROLES_TICKS, "lambda2_ticks": LAMBDA2_TICKS, "range_m": RANGE_M,
                                    "sync_window_s": SYNC_S, "wall_s": wall, "jobs": args.jobs,
                                    "radios": {k: v for k, v in RADIOS.items()}, "rows": rows}, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
