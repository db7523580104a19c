"""Beacons: every robot broadcasts one small frame per tick and counts what it hears.

The workload of the benchmarks and of the radio tests: it exercises the
medium (range, latency, loss, bandwidth) without any protocol logic of its own.
Parameters: ``every`` (ticks between beacons), ``size`` (payload bytes),
``until`` (last tick to send; none = always).
"""

from __future__ import annotations

from collections import Counter

from protocols.beacon.messages import BODIES, KIND, BeaconBody
from swarmactors import Behavior, Context, Frame


class Beacon(Behavior):
    """Broadcast a beacon every ``every`` ticks; count beacons heard per sender."""

    name = "beacon"
    kinds = (KIND,)

    def __init__(self, every: int = 1, size: int = 8, until: int | None = None):
        self.every, self.until = every, until
        self.payload = b"\x00" * size
        self.sent = 0
        self.heard: Counter = Counter()
        self.delay_sum = 0.0
        self.delay_min: float | None = None
        self.delay_max: float | None = None
        self.malformed: Counter = Counter()  # undecodable bodies by cause

    def on_tick(self, ctx: Context, sensed) -> None:
        if ctx.tick % self.every == 0 and (self.until is None or ctx.tick <= self.until):
            self.sent += 1
            BODIES.broadcast(ctx, BeaconBody(ctx.now, self.payload))

    def on_frame(self, ctx: Context, frame: Frame) -> None:
        body = BODIES.decode(frame, self.malformed)
        if not isinstance(body, BeaconBody):
            return
        self.heard[frame.src] += 1
        delay = ctx.now - body.sent
        self.delay_sum += delay
        if self.delay_min is None or delay < self.delay_min:
            self.delay_min = delay
        if self.delay_max is None or delay > self.delay_max:
            self.delay_max = delay

    def report(self) -> dict:
        n = sum(self.heard.values())
        rep = {"sent": self.sent, "heard": n, "senders": len(self.heard),
               "mean_delay": self.delay_sum / n if n else None, "min_delay": self.delay_min,
               "max_delay": self.delay_max}
        if self.malformed:
            rep["malformed"] = dict(self.malformed)
        return rep

    @classmethod
    def metrics(cls, reports: dict[int, dict]) -> dict:
        heard = [r["heard"] for r in reports.values()]
        return {"beacons_sent": sum(r["sent"] for r in reports.values()), "beacons_heard": sum(heard)}
