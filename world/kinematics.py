"""Motion: single integrator with speed limits, optional unicycle turn rate.

Velocities are commanded in length units per second; one tick lasts ``dt``
seconds. A robot moves ``v * dt`` clipped to ``speed * dt``. A robot with a
finite ``turn_rate`` (rad per second) is a unicycle: its heading turns towards
the commanded direction by at most ``turn_rate * dt`` and it advances along the
new heading by ``|v| * dt * max(0, cos(remaining error))``, so it never drives
away from where it was told to go (Kobayashi et al. cap 0.03 units and 0.15 rad
per timestep). Positions are kept inside the world's bounds.
"""

from __future__ import annotations

import numpy as np


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
        heading[idx] = np.angle(np.exp(1j * (heading[idx] + turn)))
        length = np.linalg.norm(s, axis=1) * np.maximum(0.0, np.cos(err - turn))
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
    pos[moving] += step
    if bounds is not None:
        np.clip(pos, bounds[0], bounds[1], out=pos)
