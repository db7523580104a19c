"""The world's registry: every robot's true state and which host runs it."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from transport.scenario import RobotSpec


@dataclass
class Death:
    tick: int
    cause: str  # "killed", "crashed", "watchdog", "host-lost"
    error: str | None = None


@dataclass
class HostEntry:
    """A host as the simulation sees it: the robots it runs and what it must be told of them."""

    name: str
    robots: set[int] = field(default_factory=set)
    alive: bool = True
    pending_dead: list[int] = field(default_factory=list)  # robots that died since its last inputs
    pending_new: list = field(default_factory=list)  # RobotDescr of robots given to it since then


class Robots:
    """Arrays of true state, indexed by robot id (ids are 0, 1, 2, ... in order of creation)."""

    def __init__(self, dims: int, now: Callable[[], float] = time.time):
        """``now``: the simulation's time, for ``died_at`` (ticks in lockstep, wall-clock seconds in realtime)."""
        self.dims = dims
        self.now = now
        self.pos = np.zeros((0, dims))
        self.heading = np.zeros(0)
        self.vel = np.zeros((0, dims))
        self.alive = np.zeros(0, dtype=bool)
        self.died_at = np.zeros(0)  # the simulation's time of death (``now``), inf while alive: fates of copies
        self.range = np.zeros(0)
        self.sensing = np.zeros(0)
        self.speed = np.zeros(0)
        self.turn_rate = np.zeros(0)
        self.noise = np.zeros(0)
        self.body = np.zeros(0)  # body radius (0: a point)
        self.ground = np.zeros(0, dtype=bool)  # kind = "ground" (else flying)
        self.alt_lo = np.zeros(0)  # a flying robot's altitude limits (3-D)
        self.alt_hi = np.zeros(0)
        self.climb = np.zeros(0)  # a flying robot's vertical speed cap
        self.rays = np.zeros(0, dtype=np.int64)  # obstacle range rays
        self.tx_power = np.zeros(0)  # the shared channel's transmit power, dBm (nan: the channel's)
        self.spec: list[RobotSpec] = []  # robot i's resolved spec
        self.host: list[str | None] = []
        self.deaths: dict[int, Death] = {}
        self.status: list[dict] = []
        self.joined_at: list[int] = []

    def __len__(self) -> int:
        return len(self.spec)

    def add(self, specs: list[RobotSpec], tick: int) -> list[int]:
        """Append robots described by resolved robot specs (transport.scenario.RobotSpec); return their new ids."""
        start = len(self.spec)
        ids = list(range(start, start + len(specs)))

        def col(values) -> np.ndarray:
            return np.array(list(values), dtype=float)

        pos = np.array([list(s.pos) + [0.0] * (self.dims - len(s.pos)) for s in specs], dtype=float)
        self.pos = np.vstack([self.pos, pos.reshape(len(specs), self.dims)])
        self.heading = np.concatenate([self.heading, col(s.heading for s in specs)])
        self.vel = np.vstack([self.vel, np.zeros((len(specs), self.dims))])
        self.alive = np.concatenate([self.alive, np.ones(len(specs), dtype=bool)])
        self.died_at = np.concatenate([self.died_at, np.full(len(specs), np.inf)])
        self.range = np.concatenate([self.range, col(s.range for s in specs)])
        self.sensing = np.concatenate([self.sensing, col(s.sensing for s in specs)])
        self.speed = np.concatenate([self.speed, col(s.speed_cap for s in specs)])
        self.turn_rate = np.concatenate([self.turn_rate, col(s.turn_cap for s in specs)])
        self.noise = np.concatenate([self.noise, col(s.noise for s in specs)])
        self.body = np.concatenate([self.body, col(s.body_radius for s in specs)])
        self.ground = np.concatenate([self.ground, [s.kind == "ground" for s in specs]]).astype(bool)
        alt = [s.altitude_limits for s in specs]
        self.alt_lo = np.concatenate([self.alt_lo, col(a[0] for a in alt)])
        self.alt_hi = np.concatenate([self.alt_hi, col(a[1] for a in alt)])
        self.climb = np.concatenate([self.climb, col(s.climb_cap for s in specs)])
        self.rays = np.concatenate([self.rays, [s.obstacle_rays for s in specs]]).astype(np.int64)
        self.tx_power = np.concatenate([self.tx_power, col(np.nan if s.tx_power_dbm is None else s.tx_power_dbm
                                                           for s in specs)])
        for s in specs:
            self.spec.append(s)
            self.host.append(None)
            self.status.append({})
            self.joined_at.append(tick)
        return ids

    def kill(self, rid: int, tick: int, cause: str, error: str | None = None) -> bool:
        """Mark ``rid`` dead; False when it already was."""
        if not self.alive[rid]:
            return False
        self.alive[rid] = False
        self.died_at[rid] = self.now()
        self.vel[rid] = 0.0
        self.deaths[rid] = Death(tick, cause, error)
        return True

    def alive_ids(self) -> np.ndarray:
        return np.flatnonzero(self.alive)

    def pose(self, rid: int, digits: int) -> list[float]:
        return [round(float(v), digits) for v in self.pos[rid]] + [round(float(self.heading[rid]), digits)]
