"""The Behavior API: what a protocol writes, and the narrow context it gets.

A robot is composed of behaviours. Each hook may be a plain method or a
coroutine; the same code runs under both clocks, in one process or many. A
behaviour sees only its robot's context (ARGoS's rule): its pose, what it
sensed, what it received, and the actuators below. It never touches Zenoh, the
world, or another robot.

Time: ``ctx.now`` is in the clock's unit, ticks in lockstep and seconds since
the run started in realtime; ``ctx.tick`` is the world's tick in both. Both are
read-only: only the robot's host advances them. A robot with a clock offset or drift (its group's
``clock_offset``, ``clock_drift``) reads its own clock in ``ctx.now`` and its timers
(swarmactors/robot/robot_clock.py); ``ctx.tick`` stays the world's.

What a robot knows of the world: its own pose, the robots it senses each tick,
the frames it receives, the objects it is told about (an object's ``known_by``),
and its own parameters from the scenario (``ctx.dt``, ``ctx.range``,
``ctx.sensing``, ``ctx.clock``). Nothing else: no other robot's state and no
shared object (each robot has its own context, its own ``objects`` and its own
copy of every frame body it receives).
"""

from __future__ import annotations

import inspect
import math
import time
from collections.abc import Callable, Sequence
from typing import Any, ClassVar

import msgspec
import numpy as np

from transport.codec import pack
from transport.messages import FrameOut


class Frame(msgspec.Struct, frozen=True):
    """A frame as a receiving robot sees it (its body is this robot's own copy).

    ``rab``: under local sensing or ``radio.rab = true``, the (range, bearing) at which this robot heard the
    frame (send-tick positions, its own body frame, its own noise); None otherwise.
    """

    src: int
    kind: str
    body: Any
    seq: int
    sent: float  # send tick (lockstep) or send time in seconds (realtime)
    rab: tuple[float, float] | None = None


class Sensed(msgspec.Struct, frozen=True):
    """A robot within sensing range: its id and (possibly noisy) position.

    Global sensing: ``pos`` is the world position (of the closest point of its body with
    ``sensing_to = "surface"``). Local sensing: ``range`` and ``bearing`` (radians, 0 ahead, positive to the
    left) in this robot's body frame, and ``pos`` the same vector in Cartesian form (x ahead, y left).
    """

    id: int
    pos: np.ndarray
    range: float | None = None
    bearing: float | None = None


class Behavior:
    """Base class of robot behaviours.

    Subclasses take their scenario parameters as keyword arguments of
    ``__init__`` (unknown or missing ones are scenario errors) and override the
    hooks they need. ``kinds`` lists the message kinds this behaviour handles
    (empty: all of them).
    """

    name: ClassVar[str] = ""
    kinds: ClassVar[tuple[str, ...]] = ()
    frames: ClassVar[tuple[str, ...]] = ("global",)  # the sensing frames it supports ("global", "local")
    plot_field: ClassVar[str | None] = None  # status field that colours robots in the run plot

    def on_start(self, ctx: Context) -> Any:
        """Called once, at the robot's first tick, before anything else."""

    def on_frame(self, ctx: Context, frame: Frame) -> Any:
        """Called for each received frame of a kind this behaviour handles."""

    def on_batch(self, ctx: Context) -> Any:
        """Called once after each batch of frames delivered together.

        Realtime: after every delivery batch, so a relay goes out at once rather than at the next tick.
        Lockstep: after the tick's frames, before due timers and ``on_tick``.
        """

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
    """What a behaviour may see and do. One per robot.

    Besides the behaviour, only the robot runtime (``swarmactors.robot``) touches a context: it builds it with
    the robot's fixed inputs (the keyword arguments) and uses the methods under "the runtime's side" below,
    whose names start with an underscore so that behaviours leave them alone: ``_set_inputs`` (a tick's pose,
    objects, rays and time), ``_set_time`` (the time alone), ``_due_timers`` (lockstep timers),
    ``_schedule_with`` (realtime timers), ``_has_outputs`` and ``_take_outputs`` (what the robot did).
    """

    def __init__(self, robot_id: int, rng: np.random.Generator, clock: str, *, dt: float = 1.0,
                 radio_range: float = 1.0, sensing_range: float = 1.0, kind: str = "ground",
                 pose: Any = None, known_map: Any = None, own_clock: Any = None, sensing_frame: str = "global",
                 encode: Callable[[Any], bytes] = pack):
        """``known_map``: a ``KnownMap`` for a robot given the map; ``own_clock``: a ``RobotClock`` when skewed.

        ``pose`` defaults to the origin (x, y, heading); ``encode`` packs a frame body (msgpack).
        """
        self.id = robot_id
        self.rng = rng
        self._clock = clock
        self._dt = float(dt)
        self._range = float(radio_range)
        self._sensing = float(sensing_range)
        self._kind = kind
        self._map = known_map
        self._rays: tuple[float, ...] | None = None
        self._now: float = 0
        self._tick = 0
        # x, y, heading (x, y, z, heading in 3-D); local sensing: odometry from its start
        self.pose = np.zeros(3) if pose is None else np.array(pose, dtype=float)
        self.objects: dict[str, list[float]] = {}  # the objects this robot knows (its own dict)
        self._outbox: list[FrameOut] = []
        self._velocity: list[float] | None = None
        self._status: dict[str, Any] = {}
        self._timers: list[tuple[float, int, Callable[[], Any]]] = []
        self._timer_seq = 0
        self._on_timer: Callable[[float, Callable[[], Any]], None] | None = None  # realtime: schedule at once
        self._seq = 0
        self.logs: list[str] = []
        self._encode = encode
        self._own_clock = own_clock
        self._sensing_frame = sensing_frame

    @property
    def now(self) -> float:
        """The clock's time: ticks in lockstep, seconds since the run started in realtime."""
        return self._now

    @property
    def tick(self) -> int:
        """The world's current tick."""
        return self._tick

    @property
    def clock(self) -> str:
        """``"lockstep"`` or ``"realtime"`` (the scenario's ``run.clock``)."""
        return self._clock

    @property
    def dt(self) -> float:
        """The length of a tick in seconds (the scenario's ``run.dt``)."""
        return self._dt

    @property
    def range(self) -> float:
        """This robot's radio range (its group's ``range``)."""
        return self._range

    @property
    def sensing(self) -> float:
        """This robot's sensing range (its group's ``sensing``)."""
        return self._sensing

    @property
    def kind(self) -> str:
        """``"ground"`` or ``"flying"``: its group's ``kind`` (what obstacles stop it; docs/scenarios.md)."""
        return self._kind

    @property
    def map(self):
        """The run's static obstacles as prior knowledge (``KnownMap``; its group's ``knows_map``), else None."""
        return self._map

    @property
    def rays(self) -> tuple[float, ...] | None:
        """Distances to the nearest obstacle along this robot's range rays (its group's ``obstacle_rays``).

        Ray k points at ``heading + 2*pi*k/n``; ``inf`` when no obstacle lies within the sensing range.
        None when the robot has no rays.
        """
        return self._rays

    @property
    def sensing_frame(self) -> str:
        """``"global"`` or ``"local"`` (its group's ``sensing_frame``): what ``pose`` and ``sensed`` mean."""
        return self._sensing_frame

    @property
    def position(self) -> np.ndarray:
        return self.pose[:-1]

    def broadcast(self, kind: str, body: Any = None, exclude: tuple[int, ...] | list[int] = ()) -> None:
        """Radio ``body`` to every robot in range, except the ids in ``exclude``."""
        self._queue(None, kind, body, [int(x) for x in exclude] if exclude else [])

    def send(self, dst: int, kind: str, body: Any = None) -> None:
        """Radio ``body`` to robot ``dst``; delivered only if ``dst`` is in range."""
        self._queue(int(dst), kind, body, [])

    def _queue(self, dst: int | None, kind: str, body: Any, exclude: list[int]) -> None:
        self._seq += 1
        # realtime: the radio's latency runs from this call (the world dates the frame by it, within limits)
        at = time.time() if self._clock == "realtime" else None
        self._outbox.append(FrameOut(dst, kind, self._seq, self._encode(body), exclude, at))

    def move(self, velocity) -> None:
        """Command a velocity (length units per second), kept until changed."""
        self._velocity = [float(v) for v in velocity]

    def after(self, delay: float, fn: Callable[[], Any]) -> None:
        """Call ``fn()`` once ``delay`` clock units from now.

        Lockstep: at the first tick boundary at or after the due time. Realtime: at the due time itself.
        """
        if self._on_timer is not None:
            self._on_timer(float(delay) if self._own_clock is None else self._own_clock.true_delay(delay), fn)
            return
        self._timer_seq += 1
        self._timers.append((self.now + delay, self._timer_seq, fn))

    def set_status(self, **fields: Any) -> None:
        """Publish per-tick fields (role, verdicts, ...) for checks, traces and viewers."""
        self._status.update(fields)

    def log(self, message: str) -> None:
        """A log line kept with the robot's report (the last 200)."""
        self.logs.append(f"[{self.tick}] {message}")
        del self.logs[:-200]

    # -- the runtime's side (swarmactors.robot; never called by a behaviour) --------------------------------
    def _set_inputs(self, tick: int, now: float, pose: Any, objects: dict[str, list[float]],
                    known: list[str] | None, rays: list[float] | None) -> None:
        """A tick's inputs: time, pose (copied), the objects it knows (``known``: their names; None: all), rays."""
        self._rays = None if rays is None else tuple(rays)
        self.pose = pose.copy() if type(pose) is np.ndarray else np.array(pose, dtype=float)  # its own array
        self._tick = tick
        self._now = now if self._own_clock is None else self._own_clock.local(now)
        # its own dict, with the objects it knows (an empty one left empty is kept)
        if objects:
            self.objects = {name: list(pos) for name, pos in objects.items() if known is None or name in known}
        elif self.objects:
            self.objects = {}

    def _set_time(self, tick: int, now: float) -> None:
        """Advance the robot's time (the runtime is the only writer), on the robot's own clock if skewed."""
        self._tick = tick
        self._now = now if self._own_clock is None else self._own_clock.local(now)

    def _due_timers(self) -> Sequence[Callable[[], Any]]:
        """Lockstep: remove and return the timers due at ``now``, by due time then order of ``after`` calls."""
        timers = self._timers
        if not timers:
            return ()
        now = self._now
        due = sorted(t for t in timers if t[0] <= now)
        self._timers = [t for t in timers if t[0] > now]
        return [fn for _, _, fn in due]

    def _schedule_with(self, schedule: Callable[[float, Callable[[], Any]], None]) -> None:
        """Realtime: ``after`` hands each timer to ``schedule(true delay in seconds, fn)`` at once."""
        self._on_timer = schedule

    def _has_outputs(self) -> bool:
        """Whether the robot queued frames, commanded a velocity or holds status fields."""
        return bool(self._outbox) or self._velocity is not None or bool(self._status)

    def _take_outputs(self) -> tuple[list[FrameOut], list[float] | None, dict[str, Any]]:
        """The frames queued and the velocity commanded since the last call (both reset), and the status fields."""
        frames, self._outbox = self._outbox, []
        vel, self._velocity = self._velocity, None
        return frames, vel, self._status


def is_int(v: Any) -> bool:
    """Whether ``v`` is an integer parameter value (a bool is not)."""
    return isinstance(v, int) and not isinstance(v, bool)


def is_num(v: Any) -> bool:
    """Whether ``v`` is a finite number (an int or a float; a bool is not)."""
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def check_params(cls: type, params: dict) -> str | None:
    """Why ``cls(**params)`` would not bind, or None when it would."""
    try:
        inspect.signature(cls).bind(**params)
    except TypeError as exc:
        return str(exc)
    return None


def params_problem(cls: type, params: dict, group: dict | None = None) -> str | None:
    """Why ``cls(**params)`` must not be built: the parameters do not bind, or ``cls.validate`` refuses them.

    The scenario loader passes the robot group as resolved; a robot host, which builds behaviours from specs
    that came over the wire, passes none and skips a ``validate`` that needs one. Either way a spec is checked
    before the class is called, so a parameter never reaches a constructor unvalidated.
    """
    problem = check_params(cls, params)
    if problem:
        return problem
    validate = getattr(cls, "validate", None)
    if validate is None:
        return None
    group_param = inspect.signature(validate).parameters.get("group")
    if group_param is None:
        return validate(params)
    if group is None and group_param.default is inspect.Parameter.empty:
        return None  # a rule tied to the group as resolved: checked where the group is known (the scenario)
    return validate(params, group=group)
