"""A robot's own clock: an offset and a drift from the world's true time.

A robot's clock reads ``local = (1 + drift * 1e-6) * now + offset``, ``now`` being the world's time in the
clock's unit (ticks in lockstep, seconds in realtime) and ``offset`` given in seconds (so ``offset / dt`` ticks
in lockstep). ``ctx.now``, the due times of ``ctx.after`` and every deadline a behaviour compares with
``ctx.now`` run on it; in lockstep the timers fire at the first tick whose local time reaches their due
time, so a run stays a pure function of the scenario and seed. In realtime a delay of ``d`` local seconds
lasts ``d / (1 + drift * 1e-6)`` true seconds. The world's own time (``ctx.tick``, ``frame.sent``, the trace)
stays true. The offset and drift of each robot are drawn by the world (world/situated.py).
"""

from __future__ import annotations


class RobotClock:
    """Maps the world's time to one robot's local time."""

    __slots__ = ("offset", "rate")

    def __init__(self, offset_s: float, drift_ppm: float, clock: str, dt: float):
        self.offset = offset_s / dt if clock == "lockstep" else offset_s
        self.rate = 1.0 + drift_ppm * 1e-6

    def local(self, now: float) -> float:
        """The robot's reading when the world's clock reads ``now``."""
        return self.rate * now + self.offset

    def true_delay(self, delay: float) -> float:
        """How long, on the world's clock, ``delay`` units of the robot's clock last."""
        return delay / self.rate


def robot_clock(offset_s: float, drift_ppm: float, clock: str, dt: float) -> RobotClock | None:
    """The robot's clock, or None when it keeps the world's time (no offset, no drift)."""
    if not offset_s and not drift_ppm:
        return None
    return RobotClock(offset_s, drift_ppm, clock, dt)
