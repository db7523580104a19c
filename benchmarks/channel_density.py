#!/usr/bin/env python
"""Flooding on a shared channel: delivery ratio and latency against density, with and without contention.

    python benchmarks/channel_density.py [--counts 25 50 100 200 400] [--seeds 3]

N robots placed uniformly (re-drawn until the disk graph of radius 40 m is connected) in a 100 m x 100 m
square; robot 0 floods one message at tick 1 (forward-once flooding with an expiration period of 20 ticks,
protocols/flooding); every robot that receives it forwards it at the next tick. Radios (``radio.range`` = 40 m
in every case, so the candidates are the same):

* ``off``     - no channel: every copy within 40 m arrives (the disk model);
* ``none``    - the channel without a MAC: path loss and shadowing only (generic preset: 0 dBm, n = 3,
  L0 = 40 dB, σ = 4 dB, noise −100 dBm, sensitivity −95 dBm, SINR 6 dB);
* ``aloha``, ``slotted``, ``csma`` - the same with contention. Forwarders react at once: each tick's frames are
  sent within its first ``window_s`` = 5 ms (a frame of the flood, 25 bytes of body, is 1.7 ms on the air at
  250 kbit/s).

Per (radio, N), over ``--seeds`` seeds: the delivery ratio (robots that received the message / (N − 1)), the
mean latency in ticks of those that did, and the copies dropped as collision and below sensitivity. Prints a
table and writes benchmarks/results/channel_density.json. Nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path

from swarmactors.runs.inprocess import run_inprocess

ROOT = Path(__file__).resolve().parent.parent
RADIOS = {"off": None, "none": {"mac": "none"}, "aloha": {"mac": "aloha", "window_s": 0.005},
          "slotted": {"mac": "slotted", "window_s": 0.005}, "csma": {"mac": "csma", "window_s": 0.005}}


def scenario(n: int, seed: int, channel: dict | None) -> dict:
    radio: dict = {"range": 40.0, "latency": 1}
    if channel is not None:
        radio["channel"] = channel
    return {
        "run": {"name": "channel-density", "seed": seed, "ticks": 24, "trace": False},
        "radio": radio,
        "world": {"bounds": [[0.0, 0.0], [100.0, 100.0]]},
        "robots": [{"count": n, "placement": "uniform", "connected": True,
                    "behaviors": [{"use": "flooding", "origin": 0, "at": 1, "expiry": 20}]}],
        "checks": [],
    }


def one(n: int, seed: int, channel: dict | None) -> dict:
    r = run_inprocess(scenario(n, seed, channel))
    got = [rob["flooding"]["received"]["0/0"] for rid, rob in r["robots"].items()
           if int(rid) != 0 and rob["flooding"]["received"].get("0/0")]
    dropped = r["world"]["dropped"]
    return {"ratio": len(got) / (n - 1), "latency": statistics.mean(e["tick"] - 1 for e in got) if got else None,
            "collision": dropped["collision"], "below_sensitivity": dropped["below_sensitivity"],
            "deferred_too_long": dropped["deferred_too_long"]}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--counts", type=int, nargs="+", default=[25, 50, 100, 200, 400])
    p.add_argument("--seeds", type=int, default=3)
    args = p.parse_args()
    table = []
    print(f"{'radio':8} {'N':>5} {'delivery':>9} {'latency':>8} {'collision':>10} {'below_sens':>10} {'deferred':>9}")
    for name, channel in RADIOS.items():
        for n in args.counts:
            runs = [one(n, seed, channel) for seed in range(1, args.seeds + 1)]
            lat = [x["latency"] for x in runs if x["latency"] is not None]
            row = {"radio": name, "robots": n, "delivery": round(statistics.mean(x["ratio"] for x in runs), 3),
                   "latency_ticks": round(statistics.mean(lat), 2) if lat else None,
                   **{k: round(statistics.mean(x[k] for x in runs), 1)
                      for k in ("collision", "below_sensitivity", "deferred_too_long")}}
            table.append(row)
            print(f"{name:8} {n:5d} {row['delivery']:9.3f} {row['latency_ticks'] or float('nan'):8.2f} "
                  f"{row['collision']:10.1f} {row['below_sensitivity']:10.1f} {row['deferred_too_long']:9.1f}")
    path = ROOT / "benchmarks" / "results" / "channel_density.json"
    path.write_text(json.dumps({"seeds": args.seeds, "rows": table}, indent=2) + "\n")
    print(f"wrote {path.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
