"""What the world counts and records: frame counters by robot and by drop cause, and each tick's record.

``Counters`` is what result.json reports; ``TickRecord`` is the trace record of the tick being built
(docs/trace.md: ``sent``, ``del``, ``ovh``, ``drop``, ``mal``, ``ev``, ``status``, ``pos``). Both only collect
values; they decide nothing.
"""

from __future__ import annotations

import logging
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from transport.messages import MORE_MALFORMED
from transport.rows import IntRows
from world.linkrules import DROP_CAUSES, cause_name

log = logging.getLogger("world")

MALFORMED_EXAMPLES = 100  # reasons kept for result.json (every one is counted)
SAMPLES_PER_TICK = 20  # reasons kept in a tick's trace record and logged, per cause (every one is counted)


class PerRobot:
    """A count per robot id: a growing int64 array that reads like a dict of counts (``get``, ``[]``)."""

    __slots__ = ("counts",)

    def __init__(self) -> None:
        self.counts = np.zeros(0, dtype=np.int64)

    def _fit(self, n: int) -> None:
        if n > len(self.counts):
            self.counts = np.concatenate([self.counts, np.zeros(max(n, 2 * len(self.counts)) - len(self.counts),
                                                                dtype=np.int64)])

    def add(self, ids: np.ndarray) -> None:
        """One more for every entry of ``ids`` (robot ids)."""
        if len(ids):
            c = np.bincount(ids)
            self._fit(len(c))
            self.counts[: len(c)] += c

    def get(self, rid: int, default: int = 0) -> int:
        return int(self.counts[rid]) if 0 <= rid < len(self.counts) else default

    def __getitem__(self, rid: int) -> int:
        return self.get(rid)

    def __setitem__(self, rid: int, value: int) -> None:
        self._fit(rid + 1)
        self.counts[rid] = value


@dataclass
class Counters:
    """Frames sent, delivered, overheard and dropped (by cause), in total and per robot.

    ``overheard`` counts copies of broadcasts that reached a robot on the frame's ``exclude`` list (the radio
    carried them; the robot discarded them: world/radio.py); ``delivered`` counts the copies handed over.
    """

    sent: int = 0
    delivered: int = 0
    overheard: int = 0
    dropped: dict[str, int] = field(default_factory=lambda: dict.fromkeys(DROP_CAUSES, 0))
    sent_by: PerRobot = field(default_factory=PerRobot)
    received_by: PerRobot = field(default_factory=PerRobot)
    overheard_by: PerRobot = field(default_factory=PerRobot)
    dropped_by: dict[int, dict[str, int]] = field(default_factory=lambda: defaultdict(lambda: defaultdict(int)))
    malformed: list[str] = field(default_factory=list)  # first reasons, for the result
    refused: dict[str, int] = field(default_factory=lambda: defaultdict(int))  # refused requests by named cause

    def drop(self, src: int | None, cause: str, n: int = 1) -> None:
        self.dropped[cause] = self.dropped.get(cause, 0) + n  # a scenario's own radio rules add causes
        if src is not None and src >= 0:
            self.dropped_by[src][cause] += n

    def drops(self, src: np.ndarray, cause: np.ndarray) -> None:
        """Count drops given as arrays: sender ids and cause numbers (``world.linkrules.cause_name``)."""
        keys, counts = np.unique(np.column_stack([src, cause]), axis=0, return_counts=True)
        for (s, c), k in zip(keys.tolist(), counts.tolist(), strict=True):
            self.drop(s, cause_name(c), k)

    def as_dict(self) -> dict:
        return {
            "frames_sent": self.sent,
            "deliveries": self.delivered,
            "overheard": self.overheard,
            "dropped": dict(self.dropped),
            "dropped_total": sum(self.dropped.values()),
            "malformed_examples": self.malformed[:20],
            "refused": dict(sorted(self.refused.items())),
        }

    def per_robot(self, n: int) -> dict[int, dict]:
        return {rid: {"sent": self.sent_by.get(rid, 0), "received": self.received_by.get(rid, 0),
                      "overheard": self.overheard_by.get(rid, 0), "dropped": dict(self.dropped_by.get(rid, {}))}
                for rid in range(n)}


class Sink(Protocol):
    """Receives one record per tick (the trace writer is one)."""

    def record(self, rec: dict) -> None: ...


class TickRecord:
    """The trace record of the current tick, and the counters it feeds.

    Whatever happens between two ticks (a malformed message, a host lost) goes into the next tick's record.
    ``publish_event`` sends each event to observers as it happens.
    """

    def __init__(self, counters: Counters, publish_event: Callable[[dict], None]):
        self.counters = counters
        self.publish_event = publish_event
        self.rec: dict[str, Any] = {}
        self._mal_this_tick = 0
        self._refused_this_tick: dict[str, int] = {}

    def take(self) -> dict:
        """The finished record; a new one begins."""
        rec, self.rec = self.rec, {}
        self._mal_this_tick = 0
        self._refused_this_tick = {}
        return rec

    def malformed(self, src: int | None, reason: str) -> None:
        """A message (or part of one) the world could not use: counted, recorded, logged."""
        self.counters.drop(src, "malformed")
        if len(self.counters.malformed) < MALFORMED_EXAMPLES:
            self.counters.malformed.append(reason)
        mal = self.rec.setdefault("mal", [])
        self._mal_this_tick += 1
        if self._mal_this_tick <= SAMPLES_PER_TICK:  # a flood is counted exactly, but stored and logged only so far
            mal.append(reason)
            log.warning("malformed: %s", reason)
        else:  # the last entry says how many more there were
            if self._mal_this_tick > SAMPLES_PER_TICK + 1:
                mal.pop()
            else:
                log.warning("malformed: more than %d messages this tick; only counted from now", SAMPLES_PER_TICK)
            mal.append(f"{MORE_MALFORMED} {self._mal_this_tick - SAMPLES_PER_TICK}")

    def refused(self, tick: int, cause: str, reason: str) -> None:
        """A request refused under a named cause: counted; the first of each tick recorded (an event) and logged."""
        self.counters.refused[cause] += 1
        seen = self._refused_this_tick
        seen[cause] = seen.get(cause, 0) + 1
        if seen[cause] <= SAMPLES_PER_TICK:
            self.event(tick, {"refused": cause, "reason": reason})
            log.warning("refused (%s): %s", cause, reason)

    def event(self, tick: int, ev: dict) -> None:
        """A world event (fault applied, robot failed or added, host lost)."""
        ev = {"t": tick, **ev}
        self.rec.setdefault("ev", []).append(ev)
        self.publish_event(ev)

    def status(self, rid: int, changes: dict) -> None:
        self.rec.setdefault("status", {})[rid] = changes

    def sent(self, frames: list) -> None:
        c = self.counters
        c.sent += len(frames)
        rows = [[f.src, f.seq, f.kind, f.dst, len(f.body)] for f in frames]
        c.sent_by.add(np.fromiter((row[0] for row in rows), np.int64, len(rows)))
        self.rec.setdefault("sent", []).extend(rows)

    def dropped(self, drops: list) -> None:
        """``drops``: (src, seq, dst, kind, cause) as the radio decided them."""
        rec_drops = self.rec.setdefault("drop", [])
        for src, seq, dst, _kind, cause in drops:
            self.counters.drop(src, cause)
            rec_drops.append([src, seq, dst, cause])

    def dropped_arrays(self, src: np.ndarray, seq: np.ndarray, dst: np.ndarray, cause: np.ndarray) -> None:
        """Drops as arrays (``cause``: cause numbers), the way ``dropped`` records them."""
        if not len(src):
            return
        self.counters.drops(src, cause)
        names = [cause_name(c) for c in cause.tolist()]
        rows = np.column_stack([src, seq, dst]).tolist()
        for row, name in zip(rows, names, strict=True):
            row.append(name)
        self.rec.setdefault("drop", []).extend(rows)

    def delivered_arrays(self, src: np.ndarray, seq: np.ndarray, dst: np.ndarray, sent_tick: np.ndarray) -> None:
        """Deliveries as arrays, in the order given (the trace's ``del`` order)."""
        if len(src):
            self.counters.delivered += len(src)
            self._rows("del", self.counters.received_by, src, seq, dst, sent_tick)

    def overheard_arrays(self, src: np.ndarray, seq: np.ndarray, dst: np.ndarray, sent_tick: np.ndarray) -> None:
        """Overheard copies as arrays, in the order given (the trace's ``ovh`` order)."""
        if len(src):
            self.counters.overheard += len(src)
            self._rows("ovh", self.counters.overheard_by, src, seq, dst, sent_tick)

    def _rows(self, key: str, per_robot: PerRobot, src, seq, dst, sent_tick) -> None:
        """Append ``[src, seq, dst, sent_tick]`` rows to the record's list ``key``; count them per receiver."""
        per_robot.add(dst)
        rows = IntRows(np.column_stack([src, seq, dst, sent_tick]))  # packs like the list of rows (transport/rows.py)
        have = self.rec.get(key)
        if have:
            rows = (have if isinstance(have, IntRows) else IntRows(np.reshape(have, (-1, 4)))).extend(rows)
        self.rec[key] = rows

    def dead(self, src: int, seq: int, dst: int) -> None:
        """A frame whose receiver died while it was in the air."""
        self.counters.drop(src, "dead")
        self.rec.setdefault("drop", []).append([src, seq, dst, "dead"])

    def delivered(self, src: int, seq: int, dst: int, sent_tick: int) -> None:
        self.counters.delivered += 1
        self.counters.received_by[dst] += 1
        self._row("del", [src, seq, dst, sent_tick])

    def overheard(self, src: int, seq: int, dst: int, sent_tick: int) -> None:
        self.counters.overheard += 1
        self.counters.overheard_by[dst] += 1
        self._row("ovh", [src, seq, dst, sent_tick])

    def _row(self, key: str, row: list[int]) -> None:
        rows = self.rec.setdefault(key, [])
        if isinstance(rows, IntRows):
            self.rec[key] = rows.extend([row])
        else:
            rows.append(row)
