"""Test-only behaviours for situated sensing, robot clocks and bursty loss (issue 15).

Importable by spawned host processes (tests/ is on their sys.path).
"""

from __future__ import annotations

import math

from swarmactors import Behavior

HELLO = "HELLO"


class Lead(Behavior):
    """Drive at a constant world velocity and say hello every tick (global sensing)."""

    name = "lead"
    kinds = (HELLO,)

    def __init__(self, vx: float = 0.05, vy: float = 0.02):
        self.v = (vx, vy)

    def on_tick(self, ctx, sensed) -> None:
        ctx.move(self.v)
        ctx.broadcast(HELLO, ctx.tick)


class Align(Behavior):
    """Follow a neighbour at ``gap`` using only ``frame.rab`` and sensed bearings (local sensing only).

    Each tick: the bearing to the neighbour is the circular mean of the sensed bearing and the bearing of its
    last frame (frame.rab); the range is the frame's. The robot moves along that bearing, in its own frame
    (heading + bearing), at ``gain * (range - gap)``. It records what it sensed for the test to compare.
    """

    name = "align"
    kinds = (HELLO,)
    frames = ("local",)

    def __init__(self, follow: int = 0, gap: float = 0.3, gain: float = 0.5):
        self.follow, self.gap, self.gain = follow, gap, gain
        self.rab = None
        self.first_pose = None
        self.log: list[list] = []  # [tick, sensed range, sensed bearing, rab range, rab bearing]

    def on_frame(self, ctx, frame) -> None:
        if frame.src == self.follow:
            self.rab = frame.rab

    def on_tick(self, ctx, sensed) -> None:
        if self.first_pose is None:
            self.first_pose = ctx.pose.tolist()
        seen = [s for s in sensed if s.id == self.follow]
        if not seen or self.rab is None:
            return
        s = seen[0]
        r, rb = self.rab
        b = math.atan2(math.sin(s.bearing) + math.sin(rb), math.cos(s.bearing) + math.cos(rb))
        self.log.append([ctx.tick, s.range, s.bearing, r, rb])
        heading = ctx.pose[-1]
        speed = self.gain * (r - self.gap)
        ctx.move([speed * math.cos(heading + b), speed * math.sin(heading + b)])

    def report(self) -> dict:
        return {"first_pose": self.first_pose, "log": self.log}


class Wander(Behavior):
    """Any frame: drift towards the nearest sensed robot's (closest point), say hello every ``every`` clock units.

    The hello goes out from a timer (``ctx.after``), so a skewed clock shifts it; heard frames' ``rab`` and the
    local clock readings are reported.
    """

    name = "wander"
    kinds = (HELLO,)
    frames = ("global", "local")

    def __init__(self, every: float = 2.5):
        self.every = every
        self.heard: list[list] = []
        self.nows: list[float] = []

    def on_start(self, ctx) -> None:
        ctx.after(self.every, lambda: self._hello(ctx))

    def _hello(self, ctx) -> None:
        ctx.broadcast(HELLO, ctx.now)
        ctx.after(self.every, lambda: self._hello(ctx))

    def on_frame(self, ctx, frame) -> None:
        self.heard.append([ctx.tick, frame.src, None if frame.rab is None else list(frame.rab)])

    def on_tick(self, ctx, sensed) -> None:
        self.nows.append(ctx.now)
        if len(sensed):
            pts = sensed.positions()
            here = pts * 0 if ctx.sensing_frame == "local" else pts * 0 + ctx.position
            d = ((pts - here) ** 2).sum(axis=1)
            k = int(d.argmin())
            step = (pts[k] - here[k]) * 0.1 + ctx.rng.normal(scale=0.05, size=2)
            if ctx.sensing_frame == "local":  # body frame -> the robot's own frame
                c, s = math.cos(ctx.pose[-1]), math.sin(ctx.pose[-1])
                step = [c * step[0] - s * step[1], s * step[0] + c * step[1]]
            ctx.move(step)

    def report(self) -> dict:
        return {"heard": self.heard, "nows": self.nows}
