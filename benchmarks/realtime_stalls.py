#!/usr/bin/env python
"""Where do a long realtime run's late deliveries come from?

    SWARMACTORS_RT_STAMPS=1 python benchmarks/realtime_stalls.py [--seconds 120] [--processes 2]

The soak's beacon run (N = 100, dt = 50 ms, c = 10 ms: ``bench_measure.realtime_scenario``) with a probe that
keeps, for every delivery later than c + ``--late-ms``, when it arrived (``time.monotonic()``), its latency
and, with ``SWARMACTORS_RT_STAMPS=1``, the stage it spent its time in (uplink and scheduling, downlink, the
host's timer, the hand-over, the behaviour: ``latency_probe.LatencyProbe.parts``). Every process (the world's
and each host's) also logs its garbage collections longer than 0.2 ms (``gc.callbacks``), so that a stall can
be set beside a collection on the same clock.

Printed: the late deliveries grouped into stalls (late deliveries less than 20 ms apart), each with its
worst stage and any collection that overlapped it. Written: benchmarks/results/realtime_stalls.json.
Nothing is asserted.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import bench_measure as bench  # noqa: E402  (benchmarks/ is not a package)
from latency_probe import LatencyProbe  # noqa: E402

MAX_KEPT = 20_000  # late deliveries kept per robot
GC_MIN_S = 2e-4
GC_LOG: list[tuple[float, int, float, int]] = []  # (monotonic start, generation, seconds, pid) of this process
_gc_start = [0.0]


def _on_gc(phase: str, info: dict) -> None:
    if phase == "start":
        _gc_start[0] = time.monotonic()
    else:
        took = time.monotonic() - _gc_start[0]
        if took >= GC_MIN_S:
            GC_LOG.append((_gc_start[0], info["generation"], took, os.getpid()))


def log_collections() -> None:
    """Log this process's garbage collections (once per process)."""
    if _on_gc not in gc.callbacks:
        gc.callbacks.append(_on_gc)


class StallProbe(LatencyProbe):
    """LatencyProbe; keeps only the late deliveries, as (arrived, latency, parts...) on time.monotonic()."""

    name = "latency_probe"
    late_s = 0.002 + bench.REALTIME_C

    def __init__(self) -> None:
        super().__init__()
        log_collections()
        self.late: list[tuple] = []
        self.count = 0
        self.reports_gc = False

    def on_start(self, ctx) -> None:
        # the first robot of each process reports its process's collections
        if not getattr(StallProbe, "_claimed", False):
            StallProbe._claimed = True
            self.reports_gc = True

    def on_frame(self, ctx, frame) -> None:
        now = time.monotonic()
        self.count += 1
        lat = now - frame.body[1]
        if lat < self.late_s or len(self.late) >= MAX_KEPT:
            return
        before = len(self.parts[0])
        super().on_frame(ctx, frame)  # appends the stage stamps when SWARMACTORS_RT_STAMPS=1
        stages = [p[-1] for p in self.parts] if len(self.parts[0]) > before else []
        self.late.append((now, lat, frame.src, *stages))

    def report(self) -> dict:
        return {"count": self.count, "late": self.late, "gc": GC_LOG if self.reports_gc else []}


STAGES = ("scheduled", "arrived", "woke", "handed", "on_frame")


def stalls(late: list[tuple], gap_s: float = 0.02) -> list[dict]:
    """Late deliveries grouped into stalls (less than ``gap_s`` apart), with the stage that took longest."""
    out: list[dict] = []
    for row in sorted(late):
        if out and row[0] - out[-1]["end"] < gap_s:
            s = out[-1]
        else:
            s = {"start": row[0], "end": row[0], "n": 0, "worst_ms": 0.0, "stage_ms": {}}
            out.append(s)
        s["end"], s["n"] = row[0], s["n"] + 1
        s["worst_ms"] = max(s["worst_ms"], row[1] * 1e3)
        if len(row) > 3:
            marks = [0.0, *row[3:]]  # seconds after the broadcast call
            for name, a, b in zip(STAGES, marks, marks[1:], strict=False):
                s["stage_ms"][name] = max(s["stage_ms"].get(name, 0.0), (b - a) * 1e3)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=120.0)
    ap.add_argument("--processes", type=int, default=2)
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--late-ms", type=float, default=2.0)
    ap.add_argument("--out", default=str(HERE / "results" / "realtime_stalls.json"))
    args = ap.parse_args()
    StallProbe.late_s = args.late_ms / 1e3 + bench.REALTIME_C
    log_collections()
    sc = bench.realtime_scenario(args.n, args.seconds, "realtime_stalls:StallProbe")
    t0 = time.monotonic()
    data, _ = bench.run_emulator(sc, args.processes)
    late, collections, count = [], list(GC_LOG), 0
    for r in data["robots"].values():
        rep = r.get("latency_probe") or {}
        late += [tuple(x) for x in rep.get("late", [])]
        collections += [tuple(x) for x in rep.get("gc", [])]
        count += rep.get("count", 0)
    found = stalls(late)
    for s in found:
        s["gc"] = [(round(g[0] - t0, 3), g[1], round(g[2] * 1e3, 2), g[3]) for g in collections
                   if g[0] <= s["end"] and g[0] + g[2] >= s["start"] - 0.03]
    print(f"{count} deliveries, {len(late)} later than c + {args.late_ms} ms, {len(found)} stalls; "
          f"{len(collections)} collections >= {GC_MIN_S * 1e3} ms "
          f"(gen2: {sum(1 for g in collections if g[1] == 2)})")
    for s in sorted(found, key=lambda s: -s["worst_ms"])[:25]:
        stage = max(s["stage_ms"], key=s["stage_ms"].get) if s["stage_ms"] else "?"
        print(f"t={s['start'] - t0:8.3f}s n={s['n']:5d} worst {s['worst_ms'] - bench.REALTIME_C * 1e3:7.2f} ms "
              f"beyond c, longest stage {stage} "
              f"({ {k: round(v, 2) for k, v in s['stage_ms'].items()} }) gc {s['gc']}")
    Path(args.out).parent.mkdir(exist_ok=True)
    Path(args.out).write_text(json.dumps({
        "machine": bench.machine(), "n": args.n, "processes": args.processes, "seconds": args.seconds,
        "late_ms": args.late_ms, "deliveries": count, "late": len(late),
        "stalls": [{**s, "start": round(s["start"] - t0, 4), "end": round(s["end"] - t0, 4)} for s in found],
        "collections": [(round(g[0] - t0, 4), g[1], round(g[2] * 1e3, 3), g[3]) for g in collections]},
        indent=1) + "\n")


if __name__ == "__main__":
    main()
