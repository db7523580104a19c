"""The tables a trace holds, built row by row from tick records as they stream by.

Poses: a row per tick and alive robot. Frames: a row per frame sent and per (frame, receiver) outcome.
swarmactors/tools/export.py writes them to files; ``Result.poses_table`` and ``frames_table`` make DataFrames of them.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Iterable, Iterator

TABLES = ("poses", "frames")
FRAME_COLUMNS = ("tick", "src", "seq", "kind", "dst", "size", "outcome", "sent_tick")
PANDAS_MISSING = "this needs pandas, which is not installed: pip install pandas"


def initial_headings(scenario: dict) -> dict[int, float]:
    """Robot id -> heading at the start, from the resolved scenario's groups (robots in id order)."""
    out: dict[int, float] = {}
    for g in scenario.get("robots", []):
        for _ in g.get("positions") or []:
            out[len(out)] = float(g.get("heading") or 0.0)
    return out


class Headings:
    """Each robot's heading as far as the trace determines it, fed one tick record at a time.

    The world turns a holonomic robot to the direction of each step it takes, and a unicycle advances along its
    new heading (world/kinematics.py); the record of tick t holds the positions before tick t's step. So the
    heading at tick t is the direction (atan2 in the xy plane) of the last recorded move before it, and the
    scenario's ``heading`` before any move (``start``; None for a robot added during the run, whose heading the
    trace does not hold). It differs from the world's heading when that move was cut (the world's bounds, a
    wall, ``world.blocking``), for a unicycle that turned without advancing (a turn of more than 90° to go), and
    by up to ~1e-6 / step length rad from the positions' rounding.
    """

    def __init__(self, start: dict[int, float] | None = None):
        self.heading: dict[int, float | None] = dict(start or {})
        self.last: dict[int, tuple[float, float]] = {}

    def feed(self, rec: dict) -> dict[int, float | None]:
        """The headings of the robots alive at this record's tick."""
        for row in rec.get("pos", ()):
            rid, xy = row[0], (row[1], row[2])
            before = self.last.get(rid)
            if before is not None and xy != before:
                self.heading[rid] = math.atan2(xy[1] - before[1], xy[0] - before[0])
            self.last[rid] = xy
        return {row[0]: self.heading.get(row[0]) for row in rec.get("pos", ())}


def pose_columns(records: Iterable[dict]) -> tuple[list[str], dict[str, set]]:
    """The poses table's columns, in order, and the Python types each one holds (one pass over the records)."""
    kinds: dict[str, set] = {}
    dims = 2
    for rec in records:
        for changed in rec.get("status", {}).values():
            for k, v in changed.items():
                kinds.setdefault(k, set()).add(type(v))
        for row in rec.get("pos", ()):
            dims = max(dims, len(row) - 1)
    fields = [f for f in sorted(kinds) if f not in ("tick", "id", "x", "y", "z", "heading")]
    return ["tick", "id", "x", "y"] + (["z"] if dims > 2 else []) + ["heading"] + fields, kinds


def iter_pose_rows(records: Iterable[dict], start: dict[int, float] | None = None) -> Iterator[dict]:
    """Per-tick per-robot rows (heading derived, status fields carried forward), streamed."""
    status: dict[int, dict] = {}
    heads = Headings(start)
    for rec in records:
        heading = heads.feed(rec)
        for rid, changed in rec.get("status", {}).items():
            status.setdefault(int(rid), {}).update(changed)
        for row in rec.get("pos", ()):
            out = {"tick": rec["t"], "id": row[0], "x": row[1], "y": row[2]}
            if len(row) > 3:
                out["z"] = row[3]
            out["heading"] = heading[row[0]]
            out.update(status.get(row[0], {}))
            yield out


def pose_rows(records: list[dict], start: dict[int, float] | None = None) -> tuple[list[str], list[dict]]:
    """The poses table in memory: its columns and rows (small runs and tests; ``export`` streams)."""
    return pose_columns(records)[0], list(iter_pose_rows(records, start))


def iter_frame_rows(records: Iterable[dict], within: int | None = None) -> Iterator[dict]:
    """Rows of every frame sent, delivered and dropped (see the module's docstring), streamed.

    A delivery or drop names its frame by (src, seq) only, so the kind, size and send tick of each frame sent
    are kept until no row can name it any more: ``within`` ticks after its send (lockstep: ``radio.latency``;
    deliveries, and drops of receivers that died meanwhile, come exactly that many ticks after the send, other
    drops at it), or to the end of the run when ``within`` is None (realtime). A tick's frames sent are known
    before its deliveries are written: in realtime a frame is often delivered within the tick it was sent.
    """
    meta: dict[tuple[int, int], tuple] = {}
    sent_at: deque = deque()  # (send tick, [(src, seq), ...]) oldest first, when frames are forgotten
    for rec in records:
        t = rec["t"]
        while within is not None and sent_at and sent_at[0][0] < t - within:
            for key in sent_at.popleft()[1]:
                meta.pop(key, None)
        for src, seq, kind, _dst, size in rec.get("sent", ()):
            meta[src, seq] = (kind, size, t)
        for src, seq, dst, sent_tick in rec.get("del", ()):
            kind, size, _ = meta.get((src, seq), (None, None, None))
            yield {"tick": t, "src": src, "seq": seq, "kind": kind, "dst": dst, "size": size,
                   "outcome": "delivered", "sent_tick": sent_tick}
        for src, seq, dst, sent_tick in rec.get("ovh", ()):
            kind, size, _ = meta.get((src, seq), (None, None, None))
            yield {"tick": t, "src": src, "seq": seq, "kind": kind, "dst": dst, "size": size,
                   "outcome": "overheard", "sent_tick": sent_tick}
        for src, seq, kind, dst, size in rec.get("sent", ()):
            yield {"tick": t, "src": src, "seq": seq, "kind": kind, "dst": dst, "size": size,
                   "outcome": "sent", "sent_tick": t}
        if within is not None and rec.get("sent"):
            sent_at.append((t, [(row[0], row[1]) for row in rec["sent"]]))
        for src, seq, dst, cause in rec.get("drop", ()):
            kind, size, sent_tick = meta.get((src, seq), (None, None, None))
            yield {"tick": t, "src": src, "seq": seq, "kind": kind, "dst": dst, "size": size,
                   "outcome": cause, "sent_tick": sent_tick}


def frame_window(scenario: dict) -> int | None:
    """How long after its send a frame can still be named by a trace row (``iter_frame_rows``'s ``within``)."""
    run, radio = scenario.get("run") or {}, scenario.get("radio") or {}
    latency = radio.get("latency")
    if run.get("clock", "lockstep") == "lockstep" and isinstance(latency, int) and not isinstance(latency, bool):
        return latency
    return None


def frame_rows(records: list[dict]) -> list[dict]:
    """The frames table's rows in memory (small runs and tests; ``export`` streams)."""
    return list(iter_frame_rows(records))


FRAME_KINDS = {"tick": {int}, "src": {int}, "seq": {int}, "kind": {str}, "dst": {int}, "size": {int},
               "outcome": {str}, "sent_tick": {int}}


def table(name: str, scenario: dict, records: Callable[[], Iterator[dict]]):
    """(columns, {column: Python types}, rows iterator) of one table; the poses' columns take a first pass.

    ``records()`` streams the run's tick records afresh at each call.
    """
    if name == "poses":
        columns, kinds = pose_columns(records())
        kinds = kinds | {"tick": {int}, "id": {int}, "x": {float}, "y": {float}, "z": {float}, "heading": {float}}
        return columns, kinds, iter_pose_rows(records(), initial_headings(scenario))
    return list(FRAME_COLUMNS), FRAME_KINDS, iter_frame_rows(records(), frame_window(scenario))


def table_frame(name: str, scenario: dict, records: Callable[[], Iterator[dict]]):
    """Table ``name`` as a pandas DataFrame (ImportError naming the fix when pandas is missing)."""
    try:
        import pandas
    except ImportError:
        raise ImportError(PANDAS_MISSING) from None
    columns, _, rows = table(name, scenario, records)
    return pandas.DataFrame.from_records(rows, columns=columns)
