"""Random waypoint and reflecting random walk: the mobility models users reach for first.

A robot knows only its own pose, so each model takes the ``area`` it moves in as a parameter (normally the
scenario's ``world.bounds``); the world clips positions to its bounds in any case. Velocities are in length
units per second, as ``ctx.move`` takes them; a robot moves ``speed · dt`` per tick (the robot group's
``speed`` caps it further). Neither model sends or receives frames. Randomness comes from ``ctx.rng``, so a
run stays a function of (scenario, seed).

* ``RandomWaypoint`` (Johnson & Maltz 1996; Bettstetter et al. 2003): pick a waypoint uniformly in ``area``, go
  there in a straight line at a speed drawn uniformly in [``speed_min``, ``speed``], stay ``pause`` ticks,
  repeat. The last step of a leg lands on the waypoint exactly.
* ``RandomWalk``: every ``turn_every`` ticks draw a heading uniformly in [0, 2π) and move ``speed · dt`` per
  tick along it; a step that would leave ``area`` is folded back into it (mirror reflection, coordinate by
  coordinate) and the heading is mirrored too. A robot that knows the map (its group's ``knows_map``, so
  ``ctx.map``) also reflects off obstacles: a step that would cross one is not taken; the heading's x (y)
  component is mirrored when the step's x (y) part alone would cross it (both when only the diagonal
  would: a corner), and the robot steps along the mirrored heading if that is clear, else stays. Against
  walls parallel to the axes (grid maps, upright rectangles) this is the mirror reflection; against slanted
  walls it approximates it.
"""

from __future__ import annotations

import math

from swarmactors import Behavior, Context

NO_FRAMES = ("MOBILITY",)  # a kind nothing sends: with no kinds, on_frame would be called for every frame


def _area_problem(area) -> str | None:
    try:
        (x0, y0), (x1, y1) = ((float(c) for c in corner[:2]) for corner in area)
    except (TypeError, ValueError):
        return f"area {area!r}: give [[xmin, ymin], [xmax, ymax]]"
    if not (x1 >= x0 and y1 >= y0 and (x1 > x0 or y1 > y0)):
        return f"area {area!r}: max must be >= min on both axes, and the area not a single point"
    return None


def fold(v: float, lo: float, hi: float) -> tuple[float, bool]:
    """Mirror ``v`` into [lo, hi] (repeatedly if needed); also whether it was reflected an odd number of times."""
    if hi <= lo:
        return lo, False
    width = hi - lo
    u = (v - lo) % (2 * width)
    if u <= width:
        return lo + u, False
    return lo + 2 * width - u, True


class _Mobility(Behavior):
    kinds = NO_FRAMES

    def __init__(self, area, speed: float):
        (x0, y0), (x1, y1) = ((float(c) for c in corner[:2]) for corner in area)
        self.lo, self.hi = (x0, y0), (x1, y1)
        self.speed = float(speed)
        self.travelled = 0.0
        self._last = None

    @staticmethod
    def validate(params: dict) -> str | None:
        if "area" in params and (problem := _area_problem(params["area"])):
            return problem
        if "speed" in params and not (isinstance(params["speed"], (int, float)) and params["speed"] > 0):
            return f"speed {params['speed']!r}: must be a number > 0"
        return None

    def _odometer(self, ctx: Context) -> tuple[float, float]:
        x, y = float(ctx.pose[0]), float(ctx.pose[1])
        if self._last is not None:
            self.travelled += math.hypot(x - self._last[0], y - self._last[1])
        self._last = (x, y)
        return x, y

    def report(self) -> dict:
        return {"travelled": round(self.travelled, 6)}


class RandomWaypoint(_Mobility):
    """Random waypoint: uniform waypoints in ``area``, straight legs, speed uniform in [speed_min, speed]."""

    name = "random_waypoint"

    def __init__(self, area, speed: float = 1.0, speed_min: float | None = None, pause: int = 0):
        super().__init__(area, speed)
        self.speed_min = self.speed if speed_min is None else float(speed_min)
        self.pause = int(pause)
        self.waypoint: tuple[float, float] | None = None
        self.leg_speed = self.speed
        self.resting = 0
        self.legs = 0

    @staticmethod
    def validate(params: dict) -> str | None:
        if problem := _Mobility.validate(params):
            return problem
        lo = params.get("speed_min")
        if lo is not None and not (isinstance(lo, (int, float)) and 0 < lo <= params.get("speed", 1.0)):
            return f"speed_min {lo!r}: must be > 0 and <= speed"
        if not (isinstance(params.get("pause", 0), int) and params.get("pause", 0) >= 0):
            return f"pause {params.get('pause')!r}: must be an integer >= 0 (ticks)"
        return None

    def _draw(self, ctx: Context) -> None:
        self.waypoint = (float(ctx.rng.uniform(self.lo[0], self.hi[0])), float(ctx.rng.uniform(self.lo[1], self.hi[1])))
        self.leg_speed = float(ctx.rng.uniform(self.speed_min, self.speed)) if self.speed_min < self.speed \
            else self.speed

    def on_tick(self, ctx: Context, sensed) -> None:
        x, y = self._odometer(ctx)
        if self.resting > 0:
            self.resting -= 1
            ctx.move((0.0, 0.0))
            return
        if self.waypoint is None:
            self._draw(ctx)
        dx, dy = self.waypoint[0] - x, self.waypoint[1] - y
        dist = math.hypot(dx, dy)
        step = self.leg_speed * ctx.dt
        if dist <= step:  # arrive this tick, exactly on the waypoint
            ctx.move((dx / ctx.dt, dy / ctx.dt))
            self.legs += 1
            self.waypoint = None
            self.resting = self.pause
        else:
            ctx.move((dx / dist * self.leg_speed, dy / dist * self.leg_speed))

    def report(self) -> dict:
        return super().report() | {"legs": self.legs}


class RandomWalk(_Mobility):
    """Random walk at constant speed, new uniform heading every ``turn_every`` ticks, reflecting off ``area``."""

    name = "random_walk"

    def __init__(self, area, speed: float = 1.0, turn_every: int = 1):
        super().__init__(area, speed)
        self.turn_every = int(turn_every)
        self.heading = 0.0
        self.reflections = 0

    @staticmethod
    def validate(params: dict) -> str | None:
        if problem := _Mobility.validate(params):
            return problem
        if not (isinstance(params.get("turn_every", 1), int) and params.get("turn_every", 1) >= 1):
            return f"turn_every {params.get('turn_every')!r}: must be an integer >= 1 (ticks)"
        return None

    def on_tick(self, ctx: Context, sensed) -> None:
        x, y = self._odometer(ctx)
        if ctx.tick % self.turn_every == 0:
            self.heading = float(ctx.rng.uniform(0.0, 2 * math.pi))
        step = self.speed * ctx.dt
        nx_, fx = fold(x + step * math.cos(self.heading), self.lo[0], self.hi[0])
        ny_, fy = fold(y + step * math.sin(self.heading), self.lo[1], self.hi[1])
        if fx or fy:
            self.reflections += 1
            cx, cy = math.cos(self.heading) * (-1 if fx else 1), math.sin(self.heading) * (-1 if fy else 1)
            self.heading = math.atan2(cy, cx)
        known = ctx.map
        if known is not None and not known.clear((x, y), (nx_, ny_), ctx.kind == "ground"):
            nx_, ny_ = self._off_obstacle(known, x, y, nx_ - x, ny_ - y, ctx.kind == "ground")
        ctx.move(((nx_ - x) / ctx.dt, (ny_ - y) / ctx.dt))

    def _off_obstacle(self, known, x: float, y: float, dx: float, dy: float, ground: bool) -> tuple[float, float]:
        """Mirror the heading off the obstacle that the step (dx, dy) would cross; where the robot goes instead."""
        fx = not known.clear((x, y), (x + dx, y), ground)
        fy = not known.clear((x, y), (x, y + dy), ground)
        if not (fx or fy):
            fx = fy = True  # only the diagonal crosses: a corner, back the way it came
        self.reflections += 1
        sin, cos = math.sin(self.heading), math.cos(self.heading)
        self.heading = math.atan2(-sin if fy else sin, -cos if fx else cos)
        dx, dy = -dx if fx else dx, -dy if fy else dy
        if known.clear((x, y), (x + dx, y + dy), ground) and self.lo[0] <= x + dx <= self.hi[0] \
                and self.lo[1] <= y + dy <= self.hi[1]:
            return x + dx, y + dy
        return x, y

    def report(self) -> dict:
        return super().report() | {"reflections": self.reflections}
