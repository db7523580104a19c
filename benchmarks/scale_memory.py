#!/usr/bin/env python
"""Resident memory of a long, large lockstep run: is it flat after warm-up?

    python benchmarks/scale_memory.py [--n 10000] [--ticks 1000] [--processes 2] [--trace off summary full]
                                      [--every 2] [--out benchmarks/results/scale_memory.json]

One lockstep beacon run (``scenarios/beacon.toml``: robots on a grid 0.5 m apart, range 0.75 m, one 20-byte
frame per robot per tick) per trace mode, the world in this process and the robots in ``--processes`` host
processes, through the Python API as ``benchmarks/bench.py`` runs it. A thread samples every ``--every``
seconds the resident set size (psutil) of this process (the world, plus the sampler) and of each host process,
with the tick the world has reached.

Reported per mode (JSON at ``--out``, picture ``docs/img/scale_memory.png``): ticks, wall time, robot-ticks/s,
deliveries; per process the RSS at the end of warm-up (the first ``--warmup`` of the ticks, default 20 %), the
peak, the last sample, the growth after warm-up and the least-squares slope in MB per 100 ticks after warm-up;
the trace file's size and bytes per robot-tick (``off``: no file); the trace hash (the same in every mode).
Nothing is asserted: this is a measurement, not a test.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import psutil

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import bench_measure as bench  # noqa: E402  (benchmarks/ is not a package)
from realtime_soak import Sampler as SoakSampler  # noqa: E402

from swarmactors.robot.hosting import Endpoints  # noqa: E402
from swarmactors.runs import launcher  # noqa: E402


class Sampler(SoakSampler):
    """realtime_soak's sampler (RSS of this process and of each spawned host), with the tick the world reached."""

    def __init__(self, every: float) -> None:
        super().__init__(every)
        self.tick = 0

    def run(self) -> None:
        while not self.stop.wait(self.every):
            rss = {"world": self.me.memory_info().rss / 1e6}
            for i, p in enumerate(sorted(self.hosts(), key=lambda p: p.pid)):
                try:
                    rss[f"host {i}"] = p.memory_info().rss / 1e6
                except psutil.Error:
                    pass
            self.samples.append({"t_s": round(time.monotonic() - self.t0, 2), "tick": self.tick,
                                 "load1": os.getloadavg()[0], "rss_mb": {k: round(v, 2) for k, v in rss.items()}})


def summarise(samples: list[dict], ticks: int, warmup: float) -> dict:
    """Per process: RSS at warm-up's end, peak, last, growth after warm-up and slope (MB per 100 ticks)."""
    out = {}
    start = warmup * ticks
    for name in sorted({k for s in samples for k in s["rss_mb"]}):
        pts = np.array([(s["tick"], s["rss_mb"][name]) for s in samples if name in s["rss_mb"]], dtype=float)
        late = pts[pts[:, 0] >= start] if len(pts) else pts
        row = {"samples": len(pts), "rss_peak_mb": float(pts[:, 1].max()) if len(pts) else None}
        if len(late) >= 3 and np.ptp(late[:, 0]) > 0:
            slope = np.polyfit(late[:, 0] / 100.0, late[:, 1], 1)[0]
            row |= {"samples_after_warmup": len(late), "rss_after_warmup_mb": float(late[0, 1]),
                    "rss_last_mb": float(late[-1, 1]),
                    "growth_after_warmup_mb": round(float(late[-1, 1] - late[0, 1]), 2),
                    "mb_per_100_ticks": round(float(slope), 3)}
        out[name] = row
    return out


def one_run(n: int, ticks: int, k: int, mode: str, every: float, warmup: float) -> dict:
    sc = bench.load_beacon(n, ticks, extra=[f'run.trace="{mode}"'])
    sampler = Sampler(every)

    def on_tick(world) -> None:
        sampler.tick += 1

    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory(prefix="swarm-scale-mem-") as d:
        sampler.start()
        result = asyncio.run(launcher.run_world(
            sc, Path(d), Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]),
            launcher.new_run_id(f"scale-memory-{mode}"), processes=k, on_tick=on_tick))
        sampler.stop.set()
        sampler.join()
        trace = Path(d) / "trace.msgpack"
        trace_bytes = trace.stat().st_size if trace.exists() else 0
    data = result.data
    rt = n * data["ticks"]
    return {"mode": mode, "n": n, "k": k, "ticks": data["ticks"], "stop_reason": data["stop_reason"],
            "wall_s": data["wall_s"], "robot_ticks_per_s": rt / data["wall_s"],
            "deliveries": data["world"]["deliveries"], "dropped_total": data["world"]["dropped_total"],
            "trace_hash": data["trace_hash"], "trace_bytes": trace_bytes,
            "trace_bytes_per_robot_tick": trace_bytes / rt, "load1_start": load0, "load1_end": os.getloadavg()[0],
            "processes": summarise(sampler.samples, data["ticks"], warmup), "samples": sampler.samples}


def plot(runs: list[dict], path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(runs), figsize=(4.2 * len(runs), 3.2), squeeze=False, sharey=True)
    for ax, run in zip(axes[0], runs, strict=True):
        for name in dict.fromkeys(k for s in run["samples"] for k in s["rss_mb"]):
            pts = np.array([(s["tick"], s["rss_mb"][name]) for s in run["samples"] if name in s["rss_mb"]])
            ax.plot(pts[:, 0], pts[:, 1], lw=1.2, label=name)
        ax.set_title(f"trace {run['mode']}: N = {run['n']}, K = {run['k']}", fontsize=9)
        ax.set_xlabel("tick")
        ax.legend(fontsize=7)
    axes[0][0].set_ylabel("resident set (MB)")
    fig.tight_layout()
    path.parent.mkdir(exist_ok=True)
    fig.savefig(path, dpi=110)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=10_000)
    ap.add_argument("--ticks", type=int, default=1000)
    ap.add_argument("--processes", type=int, default=2)
    ap.add_argument("--trace", nargs="+", default=["off", "summary", "full"], choices=["off", "summary", "full"])
    ap.add_argument("--every", type=float, default=2.0)
    ap.add_argument("--warmup", type=float, default=0.2, help="share of the ticks counted as warm-up")
    ap.add_argument("--out", default=str(HERE / "results" / "scale_memory.json"))
    ap.add_argument("--plot", default=str(HERE.parent / "docs" / "img" / "scale_memory.png"))
    args = ap.parse_args(argv)
    out = {"machine": bench.machine(), "runs": []}
    for mode in args.trace:
        if len(args.trace) > 1:  # each mode in a fresh process, so that one run's memory does not carry over
            with tempfile.TemporaryDirectory() as d:
                subprocess.run([sys.executable, __file__, "--n", str(args.n), "--ticks", str(args.ticks),
                                "--processes", str(args.processes), "--trace", mode, "--every", str(args.every),
                                "--warmup", str(args.warmup), "--out", f"{d}/run.json", "--plot", f"{d}/run.png"],
                               check=True)
                run = json.loads(Path(f"{d}/run.json").read_text())["runs"][0]
            out["runs"].append(run)  # the child printed its own lines
            continue
        run = one_run(args.n, args.ticks, args.processes, mode, args.every, args.warmup)
        out["runs"].append(run)
        print(f"trace {mode}: {run['ticks']} ticks ({run['stop_reason']}) in {run['wall_s']:.0f} s, "
              f"{run['robot_ticks_per_s']:,.0f} robot-ticks/s, trace {run['trace_bytes'] / 1e6:,.1f} MB "
              f"({run['trace_bytes_per_robot_tick']:.1f} B/robot-tick), load {run['load1_start']:.1f}-"
              f"{run['load1_end']:.1f}, hash {run['trace_hash'][:12]}")
        for name, row in run["processes"].items():
            print(f"  {name:8s} {row}")
    Path(args.out).parent.mkdir(exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=1) + "\n")
    plot(out["runs"], Path(args.plot))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
