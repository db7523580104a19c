#!/usr/bin/env python
"""A long realtime run: is the resident memory of the world and of the hosts flat?

    python benchmarks/realtime_soak.py [--seconds 600] [--processes 2] [--every 5]

Beacon robots as ``benchmarks/realtime_latency.py`` runs them (N = 100, realtime clock, dt = 50 ms,
c = 10 ms: ``bench_measure.realtime_scenario``), for ``--seconds``, the world in this process and the
robots in ``--processes`` host processes. A thread samples every ``--every`` seconds the resident set size
(psutil) of this process (the world, plus this sampler) and of each host process, and the load average.

Reported (benchmarks/results/realtime_soak.json, docs/img/realtime_soak.png): the samples; per process the
slope of RSS over time in MB per minute after a 60 s warm-up (least squares, ``numpy.polyfit``) and the growth
from the first sample after warm-up to the last; the run's frames, deliveries and drops by cause (only the
radio's causes are expected: anything else is listed under ``unexpected_drops``); latency - c from the
``ctx.broadcast`` call to the ``on_frame`` call on ``time.monotonic()``, as realtime_latency.py measures it, but
counted into a fixed histogram of 10 us bins per robot (``SoakProbe``) so that the probe itself does not grow.
Nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import threading
import time
from pathlib import Path

import numpy as np
import psutil

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import bench_measure as bench  # noqa: E402  (benchmarks/ is not a package)
from latency_probe import LatencyProbe  # noqa: E402

RADIO_CAUSES = {"range", "loss", "occluded", "cut", "bandwidth"}
BIN_S = 1e-5  # histogram bin of the probe: 10 us
BINS = 10_000  # up to 100 ms; later deliveries go to the last bin
WARMUP_S = 60.0


class SoakProbe(LatencyProbe):
    """LatencyProbe's broadcast; on a frame, count (on_frame - broadcast call) on time.monotonic() in a bin.

    Constant memory: a list of BINS + 1 counters per robot instead of one float per delivery.
    """

    name = "latency_probe"

    def __init__(self) -> None:
        super().__init__()
        self.hist = [0] * (BINS + 1)

    def on_frame(self, ctx, frame) -> None:
        self.hist[min(int((time.monotonic() - frame.body[1]) / BIN_S), BINS)] += 1

    def report(self) -> dict:
        return {"sent": self.sent, "hist": {i: n for i, n in enumerate(self.hist) if n}}


class Sampler(threading.Thread):
    """Every ``every`` seconds: RSS (MB) of this process and of each host process (``spawn_main`` children)."""

    def __init__(self, every: float) -> None:
        super().__init__(daemon=True)
        self.every, self.samples, self.stop = every, [], threading.Event()
        self.me, self.t0 = psutil.Process(), time.monotonic()

    def hosts(self) -> list[psutil.Process]:
        found = []
        for p in self.me.children():
            try:
                if "spawn_main" in " ".join(p.cmdline()):
                    found.append(p)
            except psutil.Error:
                pass
        return found

    def run(self) -> None:
        while not self.stop.wait(self.every):
            rss = {"world": self.me.memory_info().rss / 1e6}
            for p in self.hosts():
                try:
                    rss[f"host {p.pid}"] = p.memory_info().rss / 1e6
                except psutil.Error:
                    pass
            self.samples.append({"t_s": round(time.monotonic() - self.t0, 2), "load1": os.getloadavg()[0],
                                 "rss_mb": {k: round(v, 2) for k, v in rss.items()}})


def slopes(samples: list[dict]) -> dict:
    """Per process: least-squares slope of RSS (MB/min) over the samples after the warm-up, and the growth."""
    out = {}
    for name in sorted({k for s in samples for k in s["rss_mb"]}):
        pts = np.array([(s["t_s"], s["rss_mb"][name]) for s in samples if name in s["rss_mb"]])
        late = pts[pts[:, 0] >= WARMUP_S]
        if len(late) < 3:
            out[name] = {"samples": len(pts)}
            continue
        slope = np.polyfit(late[:, 0] / 60.0, late[:, 1], 1)[0]
        out[name] = {"samples_after_warmup": len(late), "mb_per_min": round(float(slope), 4),
                     "rss_after_warmup_mb": float(late[0, 1]), "rss_last_mb": float(late[-1, 1]),
                     "growth_after_warmup_mb": round(float(late[-1, 1] - late[0, 1]), 2),
                     "rss_max_mb": float(pts[:, 1].max())}
    return out


def latency(data: dict, c: float) -> dict:
    """Percentiles of latency - c (ms) from the probes' merged histograms (bin centres)."""
    hist = np.zeros(BINS + 1, dtype=np.int64)
    for r in data["robots"].values():
        for i, n in ((r.get("latency_probe") or {}).get("hist") or {}).items():
            hist[int(i)] += n
    if not hist.sum():
        return {}
    cum = np.cumsum(hist) / hist.sum()
    ms = ((np.arange(BINS + 1) + 0.5) * BIN_S - c) * 1e3
    out = {f"p{q}": round(float(ms[np.searchsorted(cum, q / 100)]), 3) for q in (50, 90, 99, 99.9)}
    first = int(np.nonzero(hist)[0][0])
    out |= {"samples": int(hist.sum()), "min_bin_ms": round((first * BIN_S - c) * 1e3, 3),
            "beyond_100ms": int(hist[BINS]), "never_early": first * BIN_S >= c - BIN_S}
    return out


def plot(samples: list[dict], path: Path, title: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.2))
    names = list(dict.fromkeys(k for s in samples for k in s["rss_mb"]))  # world, then hosts as they appeared
    for i, name in enumerate(names):
        pts = np.array([(s["t_s"], s["rss_mb"][name]) for s in samples if name in s["rss_mb"]])
        ax.plot(pts[:, 0], pts[:, 1], lw=1.2, label=name if name == "world" else f"host {i} (pid {name[5:]})")
    ax.axvline(WARMUP_S, color="0.6", ls=":", lw=1)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("resident set (MB)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(exist_ok=True)
    fig.savefig(path, dpi=110)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=600.0)
    ap.add_argument("--processes", type=int, default=2)
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--every", type=float, default=5.0)
    ap.add_argument("--out", default=str(HERE / "results" / "realtime_soak.json"))
    ap.add_argument("--plot", default=str(HERE.parent / "docs" / "img" / "realtime_soak.png"))
    args = ap.parse_args()
    dt, c = bench.REALTIME_DT, bench.REALTIME_C
    sc = bench.realtime_scenario(args.n, args.seconds, "realtime_soak:SoakProbe")
    machine = bench.machine()
    sampler = Sampler(args.every)
    sampler.start()
    data, _ = bench.run_emulator(sc, args.processes)
    sampler.stop.set()
    sampler.join()
    w = data["world"]
    drops = {k: v for k, v in w["dropped"].items() if v}
    out = {"machine": machine, "loadavg_end": list(os.getloadavg()), "n": args.n, "processes": args.processes,
           "dt_s": dt, "c_s": c, "seconds": args.seconds, "warmup_s": WARMUP_S, "every_s": args.every,
           "ticks": data["ticks"], "stop_reason": data["stop_reason"], "wall_s": data["wall_s"],
           "frames": w["frames_sent"], "deliveries": w["deliveries"], "refused": w["refused"],
           "dropped": drops, "unexpected_drops": {k: v for k, v in drops.items() if k not in RADIO_CAUSES},
           "failed_robots": sum(1 for r in data["robots"].values() if r["failed"]),
           "load1_mean": round(float(np.mean([s["load1"] for s in sampler.samples] or [0.0])), 2),
           "slopes": slopes(sampler.samples), "latency_minus_c_ms": latency(data, c), "samples": sampler.samples}
    Path(args.out).parent.mkdir(exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=1) + "\n")
    plot(sampler.samples, Path(args.plot),
         f"realtime N = {args.n}, K = {args.processes}, dt = {dt * 1e3:.0f} ms, c = {c * 1e3:.0f} ms, "
         f"{args.seconds:.0f} s (load1 mean {out['load1_mean']})")
    print(f"ticks {data['ticks']} ({data['stop_reason']}), frames {out['frames']}, deliveries {w['deliveries']}, "
          f"drops {drops or 'none'}, unexpected {out['unexpected_drops'] or 'none'}, load1 mean {out['load1_mean']}")
    for name, s in out["slopes"].items():
        print(f"{name:12s} {s}")
    print("latency - c (ms):", out["latency_minus_c_ms"])


if __name__ == "__main__":
    main()
