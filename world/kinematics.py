"""Motion: single integrator with speed limits, optional unicycle turn rate.

Velocities are commanded in length units per second; one tick lasts ``dt``
seconds. A robot moves ``v * dt`` clipped to ``speed * dt``. A robot with a
finite ``turn_rate`` (rad per second) is a unicycle: its heading turns towards
the commanded direction by at most ``turn_rate * dt`` and it advances along the
new heading by ``|v| * dt * max(0, cos(remaining error))``, so it never drives
away from where it was told to go (Kobayashi et al. cap 0.03 units and 0.15 rad
per timestep); in 3-D the unicycle turns and advances in the plane and keeps the step's vertical part. A robot
that moves is kept inside the world's bounds (one that does not move is left where it is).

Limits: a velocity command must be finite and at most ``MAX_SPEED`` length units per second
(whether or not its group has a cap; above the group's ``speed`` it is clipped to it); a position must stay
finite and within ``MAX_COORD`` of the origin. The world crashes a robot that breaks either rule
(``invalid_velocity``, ``invalid_position``) and the run goes on.
"""

from __future__ import annotations

import math

import numpy as np

from transport.scenario import MAX_COORD, MAX_SPEED  # the limits of a position and a speed


def velocity_problem(vel: list[float], dims: int) -> str | None:
    """Why a commanded velocity cannot be integrated (None if it can): 1..dims finite components, |v| <= MAX_SPEED."""
    if not 1 <= len(vel) <= dims:
        return f"has {len(vel)} components (1 to {dims})"
    if not all(math.isfinite(v) for v in vel):
        return "is not finite"
    if math.hypot(*vel) > MAX_SPEED:
        return f"exceeds the world's limit of {MAX_SPEED:g} length units per second"
    return None


def bad_positions(pos: np.ndarray, alive: np.ndarray) -> np.ndarray:
    """Ids of alive robots whose position is not finite or beyond MAX_COORD."""
    ok = np.isfinite(pos).all(axis=1) & (np.abs(pos) <= MAX_COORD).all(axis=1)
    return np.flatnonzero(alive & ~ok)


def integrate(
    pos: np.ndarray,
    heading: np.ndarray,
    vel: np.ndarray,
    speed: np.ndarray,
    turn_rate: np.ndarray,
    alive: np.ndarray,
    dt: float,
    bounds: np.ndarray | None,
) -> None:
    """Advance ``pos`` and ``heading`` in place by one tick."""
    moving = alive & np.any(vel != 0.0, axis=1)
    if not moving.any():
        return
    v = vel[moving]
    norm = np.linalg.norm(v, axis=1)
    cap = speed[moving]
    scale = np.where(norm > cap, cap / np.maximum(norm, 1e-300), 1.0)
    step = v * scale[:, None] * dt
    unicycle = np.isfinite(turn_rate[moving])
    if unicycle.any():
        idx = np.flatnonzero(moving)[unicycle]
        s = step[unicycle]
        want = np.arctan2(s[:, 1], s[:, 0])
        err = np.angle(np.exp(1j * (want - heading[idx])))
        max_turn = turn_rate[idx] * dt
        turn = np.clip(err, -max_turn, max_turn)
        turn[~np.any(s[:, :2] != 0.0, axis=1)] = 0.0  # a purely vertical step (3-D) does not turn the robot
        heading[idx] = np.angle(np.exp(1j * (heading[idx] + turn)))
        # the turn and the advance are in the plane; a 3-D step keeps its vertical part, so |step| stays capped
        length = np.linalg.norm(s[:, :2], axis=1) * np.maximum(0.0, np.cos(err - turn))
        s = s.copy()
        s[:, 0] = length * np.cos(heading[idx])
        s[:, 1] = length * np.sin(heading[idx])
        step[unicycle] = s
    holonomic = ~unicycle
    if holonomic.any():
        idx = np.flatnonzero(moving)[holonomic]
        h = step[holonomic]
        nz = np.any(h[:, :2] != 0.0, axis=1)
        heading[idx[nz]] = np.arctan2(h[nz, 1], h[nz, 0])
    moved = pos[moving] + step
    if bounds is not None:  # only robots that move are kept inside: a robot standing still stays where it is
        np.clip(moved, bounds[0], bounds[1], out=moved)
    pos[moving] = moved
