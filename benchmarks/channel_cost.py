#!/usr/bin/env python
"""The cost of the shared channel (``[radio.channel]``) on the world's tick, A/B in one run.

    python benchmarks/channel_cost.py [--robots 1000] [--ticks 20] [--repeats 3]

The beacon workload (scenarios/beacon.toml: every robot broadcasts one small frame per tick, a grid of
spacing 0.5 and range 0.75, about six neighbours each) with ``--robots`` robots, run in process (lockstep, no
Zenoh, trace off) under four radios:

* ``off``     - no channel: the built-in rules only (the pinned behaviour);
* ``none``    - the channel without a MAC: path loss, shadowing and noise (``mac = "none"``);
* ``aloha``   - pure ALOHA: airtime, interference, SINR, half duplex;
* ``csma``    - carrier sense with backoff (a loop over the tick's frames in time order).

The channel uses one length unit = 10 m (``unit_m``), so neighbours are 5 m apart and the range is 7.5 m.
For each configuration the script measures the CPU time (``time.process_time``) of a whole run per tick (the
world's tick and the robots' steps, all in this process) and, inside it, the time of the radio's decisions
(``Medium.decide_batch``), the configurations interleaved ``--repeats`` times; it prints medians and ratios to
``off`` and writes benchmarks/results/channel_cost.json. Nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
import tomllib
from pathlib import Path

from swarmactors.runs.inprocess import run_inprocess
from world.radio import Medium

ROOT = Path(__file__).resolve().parent.parent
CHANNELS = {"off": None, "none": {"mac": "none", "unit_m": 10.0}, "aloha": {"mac": "aloha", "unit_m": 10.0},
            "csma": {"mac": "csma", "unit_m": 10.0}}


class RadioTimer:
    """Adds up the CPU time of every ``Medium.decide_batch`` call while it is active."""

    def __init__(self):
        self.seconds = 0.0
        self._original = Medium.decide_batch

    def __enter__(self):
        timer, original = self, self._original

        def timed(medium, *args, **kwargs):
            t = time.process_time()
            try:
                return original(medium, *args, **kwargs)
            finally:
                timer.seconds += time.process_time() - t

        Medium.decide_batch = timed
        return self

    def __exit__(self, *exc):
        Medium.decide_batch = self._original


def scenario(robots: int, ticks: int, channel: dict | None) -> dict:
    raw = tomllib.loads((ROOT / "scenarios" / "beacon.toml").read_text())
    raw["run"].update(ticks=ticks, trace=False)
    raw["robots"][0]["count"] = robots
    if channel is not None:
        raw["radio"]["channel"] = channel
    return raw


def measure(robots: int, ticks: int, channel: dict | None) -> dict:
    with RadioTimer() as radio:
        t = time.process_time()
        result = run_inprocess(scenario(robots, ticks, channel))
        total = time.process_time() - t
    w = result["world"]
    return {"tick_ms": 1000 * total / ticks, "radio_ms": 1000 * radio.seconds / ticks,
            "deliveries": w["deliveries"], "dropped": {k: v for k, v in w["dropped"].items() if v}}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--robots", type=int, default=1000)
    p.add_argument("--ticks", type=int, default=20)
    p.add_argument("--repeats", type=int, default=3)
    args = p.parse_args()
    runs: dict[str, list[dict]] = {name: [] for name in CHANNELS}
    for _ in range(args.repeats):
        for name, channel in CHANNELS.items():
            runs[name].append(measure(args.robots, args.ticks, channel))
    base_tick = statistics.median(r["tick_ms"] for r in runs["off"])
    base_radio = statistics.median(r["radio_ms"] for r in runs["off"])
    out = {"robots": args.robots, "ticks": args.ticks, "repeats": args.repeats, "configs": {}}
    print(f"{'radio':8} {'tick ms':>9} {'x off':>7} {'radio ms':>9} {'x off':>7}  deliveries  drops")
    for name, rs in runs.items():
        tick = statistics.median(r["tick_ms"] for r in rs)
        radio = statistics.median(r["radio_ms"] for r in rs)
        row = {"tick_ms": round(tick, 2), "tick_ratio": round(tick / base_tick, 3), "radio_ms": round(radio, 2),
               "radio_ratio": round(radio / base_radio, 3), "deliveries": rs[-1]["deliveries"],
               "dropped": rs[-1]["dropped"]}
        out["configs"][name] = row
        print(f"{name:8} {tick:9.1f} {row['tick_ratio']:7.2f} {radio:9.1f} {row['radio_ratio']:7.2f}  "
              f"{row['deliveries']:10d}  {row['dropped']}")
    path = ROOT / "benchmarks" / "results" / "channel_cost.json"
    path.write_text(json.dumps(out, indent=2) + "\n")
    print(f"wrote {path.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
