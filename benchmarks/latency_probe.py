"""A benchmark behaviour: beacons that measure their own delivery latency.

Every tick each robot broadcasts ``[ctx.now]``; every robot that hears one
records ``ctx.now - frame.body[0]``, the latency from the sender's clock
reading to the receiver's handler (the same clock: seconds since the run
started in realtime, ticks in lockstep). ``report()`` returns every sample, so
the benchmark can compute the distribution rather than a mean.

``delays_mono`` is the latency as the realtime target defines it: from the moment of the ``ctx.broadcast`` call
to the moment of the ``on_frame`` call, both read on ``time.monotonic()`` (one clock for every process of the
machine); ``ctx.now`` is fixed for a whole step or batch, so ``delays`` also counts the time a host spends on
the robots stepped before the sender and on the frames handed over before this one.

It also records ``frame.sent - frame.body[0]``, the part of each latency spent
before the world scheduled the delivery (the robot host's flush and the uplink
to the world); the rest is the radio's latency c plus the world's timer
lateness and the downlink.

Used by ``benchmarks/bench.py`` as ``use = "latency_probe:LatencyProbe"`` with
``benchmarks/`` on ``sys.path``.
"""

from __future__ import annotations

import time

from swarmactors import Behavior

KIND = "PROBE"


class LatencyProbe(Behavior):
    """Broadcast ``[ctx.now]`` each tick; record every received frame's latency."""

    name = "latency_probe"
    kinds = (KIND,)

    def __init__(self) -> None:
        self.sent = 0
        self.delays: list[float] = []
        self.uplink: list[float] = []
        self.delays_mono: list[float] = []  # from the broadcast call to on_frame, on time.monotonic()

    def on_tick(self, ctx, sensed) -> None:
        self.sent += 1
        ctx.broadcast(KIND, [ctx.now, time.monotonic()])

    def on_frame(self, ctx, frame) -> None:
        sent = frame.body[0]
        self.delays.append(ctx.now - sent)
        self.uplink.append(frame.sent - sent)
        if len(frame.body) > 1:
            self.delays_mono.append(time.monotonic() - frame.body[1])

    def report(self) -> dict:
        return {
            "sent": self.sent,
            "delays": [round(d, 7) for d in self.delays],
            "uplink": [round(d, 7) for d in self.uplink],
            "delays_mono": [round(d, 7) for d in self.delays_mono],
        }
