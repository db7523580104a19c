#!/usr/bin/env python
"""Realtime relay delay: how long a frame waits in a relaying robot before it goes on.

    python benchmarks/relay_delay.py [--dt 0.1] [--latency 0.01] [--hops 6] [--messages 20]

A line of ``hops + 1`` robots (each hears only its neighbours) in the realtime clock; robot 0 originates a
numbered message every 0.37 s (a timer) and every other robot relays each new message once. Each robot notes
``ctx.now`` when a message first arrives. The per-hop time minus the radio latency c is what the relaying
costs. Two ways to relay, same run length:

* ``on_tick`` (before Core v2 the only choice): remember the message in ``on_frame``, send it in the next
  ``on_tick``: up to one ``dt`` later;
* ``on_batch`` (Core v2): send it in ``on_batch``, right after the delivery batch is handled.

Nothing is asserted; the script prints the p50/p99 of (hop time - c) per mode and writes a JSON file.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
from pathlib import Path

from swarmactors import Behavior
from swarmactors.runs.launcher import run

ROOT = Path(__file__).resolve().parent.parent
ORIGIN_EVERY_S = 0.37


class Relay(Behavior):
    """Robot 0 originates ``RELAY`` messages; the others relay each new one once (in on_tick or on_batch)."""

    name = "relay"
    kinds = ("RELAY",)

    def __init__(self, mode: str = "on_batch", messages: int = 20):
        self.mode, self.messages = mode, messages
        self.first_seen: dict[int, float] = {}
        self.pending: list[int] = []
        self.sent = 0

    def on_start(self, ctx):
        if ctx.id == 0:
            ctx.after(0.2, lambda: self._originate(ctx))

    def _originate(self, ctx):
        if self.sent < self.messages:
            self.first_seen[self.sent] = ctx.now
            ctx.broadcast("RELAY", self.sent)
            self.sent += 1
            ctx.after(ORIGIN_EVERY_S, lambda: self._originate(ctx))

    def on_frame(self, ctx, frame):
        m = frame.body
        if ctx.id != 0 and m not in self.first_seen:
            self.first_seen[m] = ctx.now
            self.pending.append(m)

    def _flush(self, ctx):
        for m in self.pending:
            ctx.broadcast("RELAY", m)
        self.pending = []

    def on_batch(self, ctx):
        if self.mode == "on_batch":
            self._flush(ctx)

    def on_tick(self, ctx, sensed):
        if self.mode == "on_tick":
            self._flush(ctx)

    def report(self):
        return {"first_seen": {str(k): v for k, v in self.first_seen.items()}}


def relay_run(mode: str, dt: float, latency: float, hops: int, messages: int) -> list[float]:
    ticks = int((0.5 + messages * ORIGIN_EVERY_S + hops * (dt + latency) + 1.0) / dt)
    sc = {"run": {"name": f"relay-{mode}", "seed": 1, "ticks": ticks, "dt": dt, "clock": "realtime", "trace": False},
          "radio": {"range": 1.0, "latency_s": latency},
          "robots": [{"count": hops + 1, "placement": "line", "spacing": 0.9,
                      "behaviors": [{"use": "relay_delay:Relay", "mode": mode, "messages": messages}]}]}
    with tempfile.TemporaryDirectory() as out:
        result = run(sc, out=out)
    seen = {rid: r["relay"]["first_seen"] for rid, r in result.robots.items()}
    extra = []
    for m in map(str, range(messages)):
        for k in range(hops):
            if m in seen[k] and m in seen[k + 1]:
                extra.append(seen[k + 1][m] - seen[k][m] - latency)
    return extra


def pct(xs: list[float], q: float) -> float:
    return statistics.quantiles(xs, n=100)[q - 1] if len(xs) > 1 else xs[0]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dt", type=float, default=0.1)
    ap.add_argument("--latency", type=float, default=0.01)
    ap.add_argument("--hops", type=int, default=6)
    ap.add_argument("--messages", type=int, default=20)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "relay_delay.json")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    res = {"dt": args.dt, "latency": args.latency, "hops": args.hops, "messages": args.messages}
    for mode in ("on_tick", "on_batch"):
        extra = relay_run(mode, args.dt, args.latency, args.hops, args.messages)
        res[mode] = {"hops_measured": len(extra), "p50_ms": 1e3 * pct(extra, 50), "p99_ms": 1e3 * pct(extra, 99),
                     "max_ms": 1e3 * max(extra), "min_ms": 1e3 * min(extra)}
        print(f"{mode:8s} hop time - c: p50 {res[mode]['p50_ms']:.2f} ms  p99 {res[mode]['p99_ms']:.2f} ms  "
              f"(n = {len(extra)})", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(res, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
