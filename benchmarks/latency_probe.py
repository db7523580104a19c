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

With ``SWARMACTORS_RT_STAMPS=1`` in every process's environment (realtime hosts then keep stamps,
``swarmactors.robot.host.RT_STAMPS`` and ``RT_BATCH``) it also records, per delivery, the wall times
(``time.time()``, seconds after the broadcast call) at which the world scheduled it (``frame.sent``), its
downlink reached the receiving host's loop, the host's timer woke for it, the loop began handing it over, and
``on_frame`` was called: ``parts``.

``spread`` (a fraction of a tick, default 0): each robot broadcasts at its own phase in the tick, drawn once
from its RNG in ``[0, spread * dt)``, on a timer, instead of every robot at the start of its step; with 0 every
robot of a host broadcasts within the same few milliseconds (the worst burst for the receiving hosts).

Used by ``benchmarks/bench.py`` as ``use = "latency_probe:LatencyProbe"`` with
``benchmarks/`` on ``sys.path``.
"""

from __future__ import annotations

import time
from array import array

from swarmactors import Behavior
from swarmactors.robot import host as _host

KIND = "PROBE"
# resolved once: a tree without the stamps (an A/B baseline) must not pay a failing getattr per frame
_STAMPS = getattr(_host, "RT_STAMPS", None)


class LatencyProbe(Behavior):
    """Broadcast ``[ctx.now]`` each tick; record every received frame's latency."""

    name = "latency_probe"
    kinds = (KIND,)

    def __init__(self, spread: float = 0.0) -> None:
        if not 0.0 <= spread <= 1.0:
            raise ValueError(f"latency_probe: spread = {spread!r} is not a fraction of a tick in [0, 1]")
        self.spread = float(spread)
        self.phase = 0.0
        self.sent = 0
        self.delays: list[float] = []
        self.uplink: list[float] = []
        self.delays_mono: list[float] = []  # from the broadcast call to on_frame, on time.monotonic()
        # per delivery with stamps: scheduled, arrived, woke, handed, on_frame (flat arrays: no object per sample,
        # so that the garbage collector, which would then have more to scan, does not change what is measured)
        self.parts = tuple(array("d") for _ in range(5))

    def on_start(self, ctx) -> None:
        self.phase = float(ctx.rng.uniform(0.0, self.spread * ctx.dt)) if self.spread else 0.0

    def on_tick(self, ctx, sensed) -> None:
        if self.phase:
            ctx.after(self.phase, lambda: self._beacon(ctx))
        else:
            self._beacon(ctx)

    def _beacon(self, ctx) -> None:
        self.sent += 1
        ctx.broadcast(KIND, [ctx.now, time.monotonic(), time.time()])

    def on_frame(self, ctx, frame) -> None:
        sent = frame.body[0]
        self.delays.append(ctx.now - sent)
        self.uplink.append(frame.sent - sent)
        if len(frame.body) > 1:
            self.delays_mono.append(time.monotonic() - frame.body[1])
        if _STAMPS is not None and len(frame.body) > 2:
            arrived = _STAMPS.get((frame.src << 32) | frame.seq)
            if arrived is not None:
                woke, handed, epoch = _host.RT_BATCH
                call = frame.body[2]
                sched, arr, wk, hand, called = self.parts
                sched.append(epoch + frame.sent - call)
                arr.append(arrived - call)
                wk.append((woke or handed) - call)
                hand.append(handed - call)
                called.append(time.time() - call)

    def report(self) -> dict:
        return {
            "sent": self.sent,
            "delays": [round(d, 7) for d in self.delays],
            "uplink": [round(d, 7) for d in self.uplink],
            "delays_mono": [round(d, 7) for d in self.delays_mono],
            "parts": [[round(x, 7) for x in row] for row in zip(*self.parts, strict=True)],
        }
