"""One definition of every wire message between the world, robot hosts and observers.

Each message is a msgspec ``Struct``: decoding is typed and validated in one pass, and a bad message
raises ``MalformedMessage`` naming the failing field (``$.r[0].frames[1].seq``). The world, the host,
the scenario's ``[[events]]``, the ``control`` queryable and the viewer all use these definitions; no
other module builds or takes a wire message apart by position.

Frame bodies stay the msgpack bytes the sending robot's host produced (``FrameOut.body``): the world routes
a frame by its header, counts the body's size in the bandwidth cap and the trace, and never decodes it.

Wire names are short (a step crosses Zenoh every tick); attribute names say what they hold.
"""

from __future__ import annotations

from itertools import pairwise
from typing import Annotated, Any, Literal

import msgspec
import numpy as np

from transport.codec import MalformedMessage
from transport.scenario import (  # noqa: F401 - re-exported: the world's actions are part of the scenario model
    ACTION_SHAPES,
    ACTIONS,
    INT64,
    MAX_PER_REQUEST,
    MAX_ROBOTS,
    MoveArgs,
    RobotId,
    action_problem,
)

PROTOCOL_VERSION = 3  # 3: lockstep steps are puts on up/{host}, inputs puts on down/{host}

# The last ``mal`` entry of a trace record whose tick had more malformed messages than were stored, then a count.
MORE_MALFORMED = "and more malformed messages, not stored:"


def malformed_count(mal: list[str]) -> int:
    """How many malformed messages a trace record's ``mal`` list stands for (stored samples plus the rest)."""
    if mal and isinstance(mal[-1], str) and mal[-1].startswith(MORE_MALFORMED):
        return len(mal) - 1 + int(mal[-1][len(MORE_MALFORMED):])
    return len(mal)

Seq = Annotated[int, msgspec.Meta(ge=0, le=INT64 - 1)]
Kind = Annotated[str, msgspec.Meta(min_length=1, max_length=64)]
HostName = Annotated[str, msgspec.Meta(min_length=1, max_length=64)]


class _Message(msgspec.Struct, forbid_unknown_fields=True, omit_defaults=True):
    """Base: unknown fields are errors; defaults are not sent."""


class _Row(msgspec.Struct, array_like=True, forbid_unknown_fields=True):
    """Base of the positional rows inside a message (one per robot or frame): compact on the wire."""


# ----------------------------------------------------------------- joining
class JoinRequest(_Message):
    """A host asks for robots: ``count`` of them (None: every unclaimed one)."""

    count: Annotated[int, msgspec.Meta(ge=1)] | None = None


class RobotDescr(_Message):
    """A robot handed to a host: its id, initial pose, behaviour specs and radio/sensing parameters."""

    id: RobotId
    pose: list[float]
    behaviors: list[dict[str, Any]]
    kind: str
    range: float
    sensing: float
    speed: float
    knows_map: bool = False  # the robot is given the run's static map (ctx.map)
    sensing_frame: Literal["global", "local"] = "global"  # local: range and bearing in its own frame
    clock_offset: float = 0.0  # the robot's clock offset (seconds) and drift (ppm): swarmactors/robot/robot_clock.py
    clock_drift: float = 0.0


class RunInfo(_Message):
    """What a host must know of the run: clock, tick length, seed, length, watchdog, current tick."""

    clock: str
    dt: float
    seed: int
    ticks: int
    watchdog_s: float
    tick: int
    map: dict[str, Any] | None = None  # the static map, for robots that know it: dims, obstacles, map (grid)


class JoinReply(_Message):
    """The world's answer to a join: the host's name and uplink key, its robots, the run."""

    host: HostName
    key: bytes
    version: int
    robots: list[RobotDescr]
    run: RunInfo


# ----------------------------------------------------------------- host -> world
class FrameOut(_Row):
    """A frame a robot radios: ``dst`` None is a broadcast (minus ``exclude``); ``body`` is packed msgpack."""

    dst: RobotId | None
    kind: Kind
    seq: Seq
    body: bytes
    exclude: list[RobotId]
    at: float | None = None  # realtime: the sender's wall time (time.time()) when the robot radioed it


class RobotOut(_Row):
    """One robot's outputs of a step: velocity command, frames, status changes, and its error if it crashed."""

    id: RobotId
    velocity: list[float] | None
    frames: list[FrameOut]
    status: dict[str, Any] | None
    error: str | None


class Uplink(_Message):
    """A host's message to the world (sealed with the host's key).

    In lockstep it is the step put of tick ``tick`` (-1: the registration query); in realtime a put of frames sent
    now. ``reports`` (robot id -> report) comes once, at the end.
    """

    host: HostName = msgspec.field(name="h")
    tick: int = msgspec.field(name="t")
    robots: list[RobotOut] = msgspec.field(name="r", default_factory=list)
    reports: dict[int, Any] | None = msgspec.field(name="rep", default=None)


# ----------------------------------------------------------------- world -> host
class FrameIn(_Row):
    """A delivered frame in a host's frame table: sender, kind, seq, packed body, send tick or time."""

    src: int
    kind: str
    seq: int
    body: bytes
    sent: float


class RobotIn(msgspec.Struct):
    """One robot's inputs of a tick, as ``Inputs.robots`` reads them (a view, not a wire message).

    Its pose, the robots it senses (ids and their positions, flattened), its inbox (indices into the host's
    frame table) and the names of the objects it knows (None: all of them).
    """

    id: int
    pose: list[float]
    sensed: tuple[list[int], list[float]]
    inbox: list[int]
    objects: list[str] | None = None
    rays: list[float] | None = None  # obstacle range rays (world/space.py), when the robot's group has them
    rab: list[float] | None = None  # (range, bearing) of each inbox frame, flattened (frame.rab)


# The numeric columns of ``Inputs``: little-endian, whatever the machine (hosts may run on other machines). Robot
# ids fit int32: a scenario may ask for at most 1,000,000 robots (transport/scenario.py, MAX_ROBOTS_LIMIT).
F64 = np.dtype("<f8")
I32 = np.dtype("<i4")


class Columns(msgspec.Struct):
    """An ``Inputs`` message's columns, checked and decoded (``Inputs.columns``); robot i is row i.

    ``ids``, ``sensed_ptr``, ``sensed_ids``, ``sensed_at``, ``inbox_ptr`` and ``refs`` are Python lists (what a
    robot is handed is made of Python numbers); ``poses`` is an (n, dims + 1) float array. Robot i senses
    ``sensed_ids[sensed_ptr[i]:sensed_ptr[i + 1]]`` at the ``dims`` numbers each of the same rows of
    ``sensed_at`` (flat) and receives ``frames[refs[k]]`` for k in ``inbox_ptr[i]:inbox_ptr[i + 1]``.
    """

    ids: list[int]
    poses: np.ndarray
    sensed_ptr: list[int]
    sensed_ids: list[int]
    sensed_at: list[float]
    inbox_ptr: list[int]
    refs: list[int]


def _column(data: bytes, dtype: np.dtype, name: str) -> np.ndarray:
    if len(data) % dtype.itemsize:
        raise ValueError(f"{name}: {len(data)} bytes is not a whole number of {dtype.itemsize}-byte items")
    return np.frombuffer(data, dtype=dtype)


def _offsets(data: bytes, n: int, total: int, name: str) -> np.ndarray:
    """Offsets (n + 1 of them, from 0, never decreasing, to ``total``) into a column; empty bytes: all 0."""
    if not data:
        if total:
            raise ValueError(f"{name}: no offsets for {total} items")
        return np.zeros(n + 1, dtype=I32)
    ptr = _column(data, I32, name)
    ok = len(ptr) == n + 1 and ptr[0] == 0 and ptr[-1] == total
    if ok and n > 1:  # a few offsets are checked faster in Python than through numpy's calls
        if n <= 64:
            ok = all(a <= b for a, b in pairwise(ptr.tolist()))
        else:
            ok = not (np.diff(ptr) < 0).any()
    if not ok:
        raise ValueError(f"{name}: not {n + 1} non-decreasing offsets from 0 to {total}")
    return ptr


class Inputs(msgspec.Struct, tag="in", forbid_unknown_fields=True, omit_defaults=True, dict=True):
    """A tick's inputs for one host, as columns (one row per robot, in ``ids`` order).

    ``ids`` are the robots; ``poses`` (float64) one row of ``dims`` + 1 numbers per robot (position, heading);
    ``sensed`` (offsets into ``sensed_ids``) and ``sensed_ids`` the robots each senses, with ``dims`` numbers each
    in ``sensed_at`` (float64); ``inbox`` (offsets into ``refs``) and ``refs`` (indices into ``frames``) each
    robot's inbox in delivery order. Integers are int32, every number little-endian. Each frame
    body travels once per host (``frames``), however many of its robots receive it. ``known`` (the object names
    each robot knows; None: every robot knows every object), ``rays`` and ``rab`` are per robot when present.
    ``dead`` and ``new`` change the host's robots; ``epoch`` is the realtime clock's start (wall time).

    Decoding checks that the columns fit together (lengths, offsets, references), so a host never indexes
    out of them; ``columns()`` gives them decoded and ``robots`` as one ``RobotIn`` per robot.
    """

    tick: int = msgspec.field(name="t")
    now: float = 0.0
    dims: Annotated[int, msgspec.Meta(ge=1, le=3)] = 2
    ids: bytes = b""
    poses: bytes = b""
    sensed: bytes = b""
    sensed_ids: bytes = msgspec.field(name="si", default=b"")
    sensed_at: bytes = msgspec.field(name="sx", default=b"")
    inbox: bytes = b""
    refs: bytes = b""
    frames: list[FrameIn] = msgspec.field(default_factory=list)
    known: list[list[str] | None] | None = None
    rays: list[list[float] | None] | None = None
    rab: list[list[float] | None] | None = None
    objects: dict[str, list[float]] = msgspec.field(default_factory=dict)
    epoch: float | None = None
    dead: list[int] = msgspec.field(default_factory=list)
    new: list[RobotDescr] = msgspec.field(default_factory=list)

    def __post_init__(self) -> None:
        ids = _column(self.ids, I32, "ids")
        n = len(ids)
        if n and ids.min() < 0:
            raise ValueError("ids: a negative robot id")
        w = self.dims + 1
        poses = _column(self.poses, F64, "poses")
        if len(poses) != n * w:
            raise ValueError(f"poses: {len(poses)} numbers for {n} robots of {w}")
        sids = _column(self.sensed_ids, I32, "si")
        sat = _column(self.sensed_at, F64, "sx")
        if len(sat) != len(sids) * self.dims:
            raise ValueError(f"sx: {len(sat)} numbers for {len(sids)} sensed robots of {self.dims}")
        sptr = _offsets(self.sensed, n, len(sids), "sensed")
        refs = _column(self.refs, I32, "refs")
        iptr = _offsets(self.inbox, n, len(refs), "inbox")
        if len(refs) and (refs.min() < 0 or refs.max() >= len(self.frames)):
            raise ValueError(f"refs: an index outside the {len(self.frames)} frames")
        for name in ("known", "rays", "rab"):
            col = getattr(self, name)
            if col is not None and len(col) != n:
                raise ValueError(f"{name}: {len(col)} rows for {n} robots")
        if self.rab is not None:
            counts = np.diff(iptr).tolist()
            for k, (row, c) in enumerate(zip(self.rab, counts, strict=True)):
                if row is not None and len(row) != 2 * c:
                    raise ValueError(f"rab[{k}]: {len(row)} numbers for {c} frames")
        self.__dict__["_cols"] = (ids, poses.reshape(n, w), sptr, sids, sat, iptr, refs)

    def columns(self) -> Columns:
        """The columns, decoded (Python lists, and the poses as an array)."""
        cols = self.__dict__.get("_decoded")
        if cols is None:
            ids, poses, sptr, sids, sat, iptr, refs = self.__dict__["_cols"]
            cols = self.__dict__["_decoded"] = Columns(ids.tolist(), poses, sptr.tolist(), sids.tolist(),
                                                       sat.tolist(), iptr.tolist(), refs.tolist())
        return cols

    @property
    def robots(self) -> list[RobotIn]:
        """One ``RobotIn`` per robot (built once, on first use)."""
        rows = self.__dict__.get("_robots")
        if rows is None:
            c, d = self.columns(), self.dims
            poses = c.poses.tolist()
            sp, ip = c.sensed_ptr, c.inbox_ptr
            rows = [RobotIn(rid, poses[i], (c.sensed_ids[sp[i]:sp[i + 1]], c.sensed_at[sp[i] * d:sp[i + 1] * d]),
                            c.refs[ip[i]:ip[i + 1]], None if self.known is None else self.known[i],
                            None if self.rays is None else self.rays[i], None if self.rab is None else self.rab[i])
                    for i, rid in enumerate(c.ids)]
            self.__dict__["_robots"] = rows
        return rows

    @classmethod
    def from_rows(cls, tick: int, now: float, rows: list[RobotIn], frames: list[FrameIn] = (),
                  objects: dict | None = None, dims: int | None = None, **more: Any) -> Inputs:
        """The message for robots given row by row (tests and benchmarks; the world builds the columns)."""
        if dims is None:
            dims = len(rows[0].pose) - 1 if rows else 2
        sn = [len(r.sensed[0]) for r in rows]
        bn = [len(r.inbox) for r in rows]
        opt = {name: [getattr(r, attr) for r in rows] if any(getattr(r, attr) is not None for r in rows) else None
               for name, attr in (("known", "objects"), ("rays", "rays"), ("rab", "rab"))}
        return cls(tick, now, dims,
                   ids=np.array([r.id for r in rows], dtype=I32).tobytes(),
                   poses=np.array([r.pose for r in rows], dtype=F64).tobytes(),
                   sensed=np.concatenate([[0], np.cumsum(sn)]).astype(I32).tobytes() if sum(sn) else b"",
                   sensed_ids=np.array([i for r in rows for i in r.sensed[0]], dtype=I32).tobytes(),
                   sensed_at=np.array([v for r in rows for v in r.sensed[1]], dtype=F64).tobytes(),
                   inbox=np.concatenate([[0], np.cumsum(bn)]).astype(I32).tobytes() if sum(bn) else b"",
                   refs=np.array([k for r in rows for k in r.inbox], dtype=I32).tobytes(),
                   frames=list(frames), objects=dict(objects or {}), **opt, **more)


class Deliveries(msgspec.Struct, tag="d", forbid_unknown_fields=True, omit_defaults=True, dict=True):
    """Realtime: the copies the radio decided to deliver to this host's robots, as columns (one row per copy).

    Copy i goes to robot ``dst[i]``: frame ``frames[refs[i]]``, handed over at wall time ``due[i]``
    (``time.time()``; at once when it has passed). Each frame body travels once per host, however many of its
    robots receive it. ``rab`` (runs with ``frame.rab``): per copy the (range, bearing) at which the receiver
    heard it, or None. Integers are int32, times float64, little-endian. Decoding checks that the columns fit
    together; ``arrays()`` gives them decoded.
    """

    frames: list[FrameIn] = msgspec.field(default_factory=list)
    dst: bytes = b""
    refs: bytes = b""
    due: bytes = b""
    rab: list[list[float] | None] | None = None

    def __post_init__(self) -> None:
        dst = _column(self.dst, I32, "dst")
        refs = _column(self.refs, I32, "refs")
        due = _column(self.due, F64, "due")
        n = len(dst)
        if len(refs) != n or len(due) != n:
            raise ValueError(f"dst, refs, due: {n}, {len(refs)} and {len(due)} copies")
        if n and dst.min() < 0:
            raise ValueError("dst: a negative robot id")
        if n and (refs.min() < 0 or refs.max() >= len(self.frames)):
            raise ValueError(f"refs: an index outside the {len(self.frames)} frames")
        if n and not np.isfinite(due).all():
            raise ValueError("due: a time that is not a finite number")
        if self.rab is not None:
            if len(self.rab) != n:
                raise ValueError(f"rab: {len(self.rab)} rows for {n} copies")
            if any(row is not None and len(row) != 2 for row in self.rab):
                raise ValueError("rab: a row that is not (range, bearing)")
        self.__dict__["_cols"] = (dst, refs, due)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The checked columns: receivers, frame indices and due times, as arrays."""
        return self.__dict__["_cols"]

    @classmethod
    def of(cls, frames: list[FrameIn], dst: Any, refs: Any, due: Any, rab: list | None = None) -> Deliveries:
        """The message for copies given as sequences (the world, tests and benchmarks)."""
        return cls(list(frames), np.asarray(dst, dtype=I32).tobytes(), np.asarray(refs, dtype=I32).tobytes(),
                   np.asarray(due, dtype=F64).tobytes(), rab)


class Stop(msgspec.Struct, tag="stop", forbid_unknown_fields=True, omit_defaults=True):
    """The run is over: send the final reports (``gone``: this host was declared lost; ``bye``: nothing more)."""

    tick: int = msgspec.field(name="t", default=0)
    gone: bool = False
    bye: bool = False


class Ack(msgspec.Struct, tag="ack", forbid_unknown_fields=True):
    """Realtime: the world took an uplink; ``epoch`` is the clock's start (0 before the run starts)."""

    epoch: float


Downlink = Inputs | Deliveries | Stop | Ack


# ----------------------------------------------------------------- observers
class State(_Message):
    """A snapshot on the ``state`` stream (observers may miss some)."""

    tick: int = msgspec.field(name="t")
    pos: list[list[float]]
    status: dict[int, dict[str, Any]]
    ranges: list[float]
    objects: dict[str, list[float]]
    dropped: dict[str, int]
    sent: int


# ----------------------------------------------------------------- control and events
class ControlCommand(_Message):
    """A command on the ``control`` queryable: a clock command, ``status``, or an action (see ``ACTIONS``)."""

    cmd: str
    args: Any = True
    tick: Any = None


CLOCK_COMMANDS = ("status", "pause", "resume", "step", "run_to")
# The world's actions (kill, add, cut, ...: a scenario's [[events]] and these commands) and their rules are part
# of the scenario model (transport/scenario.py): ACTIONS, action_problem, MAX_PER_REQUEST and MAX_ROBOTS.


# ----------------------------------------------------------------- encoding
_encoder = msgspec.msgpack.Encoder()
_decoders: dict[Any, msgspec.msgpack.Decoder] = {}


def encode(msg: msgspec.Struct) -> bytes:
    """A message as msgpack bytes."""
    return _encoder.encode(msg)


def decode(data: bytes, kind: Any, *, what: str) -> Any:
    """Decode and validate ``data`` as ``kind`` (a message type or union); ``MalformedMessage`` names the field."""
    dec = _decoders.get(kind)
    if dec is None:
        dec = _decoders[kind] = msgspec.msgpack.Decoder(kind)
    try:
        return dec.decode(data)
    except msgspec.DecodeError as exc:
        raise MalformedMessage(f"bad {what}: {exc}") from None
    except RecursionError:  # e.g. a value nested 200,000 levels deep
        raise MalformedMessage(f"bad {what}: nested too deeply") from None
