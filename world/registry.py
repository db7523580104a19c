"""The world's registry: every robot's true state and which host runs it."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np


@dataclass
class Death:
    tick: int
    cause: str  # "killed", "crashed", "watchdog", "host-lost"
    error: str | None = None


@dataclass
class HostEntry:
    name: str
    robots: set[int] = field(default_factory=set)
    alive: bool = True
    reported: bool = False  # final reports received
    registered: bool = False  # its registration step (tick -1) arrived (lockstep: once only)
    joined_at: float = 0.0  # time.monotonic() of its join: it must register within register_within_s
    last_down: float = 0.0  # time.monotonic() of its last downlink (World._keep_hosts_informed)
    key: bytes = b""  # per-host uplink authentication key (transport.auth)
    pending_dead: list[int] = field(default_factory=list)  # robots that died since its last inputs
    pending_new: list = field(default_factory=list)  # RobotDescr of robots given to it since then


class Robots:
    """Arrays of true state, indexed by robot id (ids are 0, 1, 2, ... in order of creation)."""

    def __init__(self, dims: int):
        self.dims = dims
        self.pos = np.zeros((0, dims))
        self.heading = np.zeros(0)
        self.vel = np.zeros((0, dims))
        self.alive = np.zeros(0, dtype=bool)
        self.died_at = np.zeros(0)  # wall-clock time of death (time.time()), inf while alive: realtime fates
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
        self.spec: list[dict] = []
        self.host: list[str | None] = []
        self.deaths: dict[int, Death] = {}
        self.status: list[dict] = []
        self.joined_at: list[int] = []

    def __len__(self) -> int:
        return len(self.spec)

    def add(self, specs: list[dict], tick: int) -> list[int]:
        """Append robots described by resolved robot specs; return their new ids."""
        start = len(self.spec)
        ids = list(range(start, start + len(specs)))

        def col(name, default):
            return np.array([float(s.get(name, default)) for s in specs])

        pos = np.array([list(s["pos"]) + [0.0] * (self.dims - len(s["pos"])) for s in specs], dtype=float)
        self.pos = np.vstack([self.pos, pos.reshape(len(specs), self.dims)])
        self.heading = np.concatenate([self.heading, col("heading", 0.0)])
        self.vel = np.vstack([self.vel, np.zeros((len(specs), self.dims))])
        self.alive = np.concatenate([self.alive, np.ones(len(specs), dtype=bool)])
        self.died_at = np.concatenate([self.died_at, np.full(len(specs), np.inf)])
        self.range = np.concatenate([self.range, col("range", 1.0)])
        self.sensing = np.concatenate([self.sensing, col("sensing", 1.0)])
        self.speed = np.concatenate([self.speed, col("speed", np.inf)])
        self.turn_rate = np.concatenate([self.turn_rate, col("turn_rate", np.inf)])
        self.noise = np.concatenate([self.noise, col("noise", 0.0)])
        self.body = np.concatenate([self.body, col("body_radius", 0.0)])
        self.ground = np.concatenate([self.ground, [s.get("kind", "ground") == "ground" for s in specs]]).astype(bool)
        alt = [s.get("altitude") or [0.0, np.inf] for s in specs]
        self.alt_lo = np.concatenate([self.alt_lo, [float(a[0]) for a in alt]])
        self.alt_hi = np.concatenate([self.alt_hi, [float(a[1]) for a in alt]])
        climb = [s.get("climb_rate") if s.get("climb_rate") is not None else s.get("speed", np.inf) for s in specs]
        self.climb = np.concatenate([self.climb, np.array(climb, dtype=float)])
        self.rays = np.concatenate([self.rays, [int(s.get("obstacle_rays", 0)) for s in specs]]).astype(np.int64)
        for rid, s in zip(ids, specs, strict=True):
            self.spec.append({**s, "id": rid})
            self.host.append(None)
            self.status.append({})
            self.joined_at.append(tick)
        return ids

    def kill(self, rid: int, tick: int, cause: str, error: str | None = None) -> bool:
        """Mark ``rid`` dead; False when it already was."""
        if not self.alive[rid]:
            return False
        self.alive[rid] = False
        self.died_at[rid] = time.time()
        self.vel[rid] = 0.0
        self.deaths[rid] = Death(tick, cause, error)
        return True

    def alive_ids(self) -> np.ndarray:
        return np.flatnonzero(self.alive)

    def pose(self, rid: int, digits: int) -> list[float]:
        return [round(float(v), digits) for v in self.pos[rid]] + [round(float(self.heading[rid]), digits)]
