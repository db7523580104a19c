"""The Behavior API: what a protocol writes, and the narrow context it gets.

A robot is composed of behaviours. Each hook may be a plain method or a
coroutine; the same code runs under both clocks, in one process or many. A
behaviour sees only its robot's context (ARGoS's rule): its pose, what it
sensed, what it received, and the actuators below. It never touches Zenoh, the
world, or another robot.

Time: ``ctx.now`` is in the clock's unit, ticks in lockstep and seconds since
the run started in realtime; ``ctx.tick`` is the world's tick in both.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np


@dataclass(frozen=True, slots=True)
class Frame:
    """A frame as a receiving robot sees it."""

    src: int
    kind: str
    body: Any
    seq: int
    sent: float  # send tick (lockstep) or send time in seconds (realtime)


@dataclass(frozen=True, slots=True)
class Sensed:
    """A robot within sensing range: its id and (possibly noisy) position."""

    id: int
    pos: np.ndarray


class Behavior:
    """Base class of robot behaviours.

    Subclasses take their scenario parameters as keyword arguments of
    ``__init__`` (unknown or missing ones are scenario errors) and override the
    hooks they need. ``kinds`` lists the message kinds this behaviour handles
    (empty: all of them).
    """

    name: ClassVar[str] = ""
    kinds: ClassVar[tuple[str, ...]] = ()
    plot_field: ClassVar[str | None] = None  # status field that colours robots in the run plot

    def on_start(self, ctx: Context) -> Any:
        """Called once, at the robot's first tick, before anything else."""

    def on_frame(self, ctx: Context, frame: Frame) -> Any:
        """Called for each received frame of a kind this behaviour handles."""

    def on_tick(self, ctx: Context, sensed: list[Sensed]) -> Any:
        """Called once per tick, after the tick's frames were handled."""

    def report(self) -> dict:
        """The protocol state that checks and result.json read (msgpack/JSON-able)."""
        return {}

    @classmethod
    def metrics(cls, reports: dict[int, dict]) -> dict:
        """Run-level metrics from every robot's ``report()`` (id -> report)."""
        return {}


class Context:
    """What a behaviour may see and do. One per robot."""

    def __init__(self, robot_id: int, rng: np.random.Generator, clock: str):
        self.id = robot_id
        self.rng = rng
        self.clock = clock
        self.now: float = 0
        self.tick = 0
        self.pose = np.zeros(3)  # x, y, heading (x, y, z, heading in 3-D)
        self.objects: dict[str, list[float]] = {}
        self._outbox: list[list] = []
        self._velocity: list[float] | None = None
        self._status: dict[str, Any] = {}
        self._timers: list[tuple[float, int, Callable[[], Any]]] = []
        self._timer_seq = 0
        self._seq = 0
        self.logs: list[str] = []
        self._encode: Callable[[Any], bytes] | None = None

    @property
    def position(self) -> np.ndarray:
        return self.pose[:-1]

    def broadcast(self, kind: str, body: Any = None, exclude: tuple[int, ...] | list[int] = ()) -> None:
        """Radio ``body`` to every robot in range, except the ids in ``exclude``."""
        self._queue(None, kind, body, list(exclude))

    def send(self, dst: int, kind: str, body: Any = None) -> None:
        """Radio ``body`` to robot ``dst``; delivered only if ``dst`` is in range."""
        self._queue(int(dst), kind, body, [])

    def _queue(self, dst: int | None, kind: str, body: Any, exclude: list[int]) -> None:
        self._seq += 1
        self._outbox.append([dst, kind, self._seq, self._encode(body), exclude])

    def move(self, velocity) -> None:
        """Command a velocity (length units per second), kept until changed."""
        self._velocity = [float(v) for v in velocity]

    def after(self, delay: float, fn: Callable[[], Any]) -> None:
        """Call ``fn()`` once ``delay`` clock units from now (at a tick boundary in lockstep)."""
        self._timer_seq += 1
        self._timers.append((self.now + delay, self._timer_seq, fn))

    def set_status(self, **fields: Any) -> None:
        """Publish per-tick fields (role, verdicts, ...) for checks, traces and viewers."""
        self._status.update(fields)

    def log(self, message: str) -> None:
        """A log line kept with the robot's report (the last 200)."""
        self.logs.append(f"[{self.tick}] {message}")
        del self.logs[:-200]


def check_params(cls: type, params: dict) -> str | None:
    """Why ``cls(**params)`` would not bind, or None when it would."""
    try:
        inspect.signature(cls).bind(**params)
    except TypeError as exc:
        return str(exc)
    return None
