"""Virtual stigmergy: entries, conflict rules and the replicated table (robot side, no I/O)."""

from __future__ import annotations

import math
from collections import Counter, OrderedDict
from collections.abc import Callable
from typing import Any, NamedTuple

from protocols.stigmergy.messages import BODIES, DIGEST, KINDS, PUT, QUERY, Digest, Put, Query
from swarmactors import Context, Frame
from swarmactors.robot.behavior import is_int
from swarmactors.robot.plugins import Rules

SEEN_QUERIES = 4096  # unknown-key queries remembered for Q1


class Entry(NamedTuple):
    """One version of a key: its value (None = nil), Lamport timestamp and writer id."""

    value: Any
    ts: int
    writer: int


# ------------------------------------------------------------------ conflict rules
def sortable(value: Any) -> tuple:
    """Return a total-order key for msgpack-able values (nil < numbers < strings < lists < maps < other)."""
    if value is None:
        return (0,)
    if isinstance(value, (bool, int, float)):
        v = float(value)
        return (1, v if not math.isnan(v) else math.inf)
    if isinstance(value, str):
        return (2, value)
    if isinstance(value, (list, tuple)):
        return (3, tuple(sortable(v) for v in value))
    if isinstance(value, dict):
        return (4, tuple(sorted((repr(k), sortable(v)) for k, v in value.items())))
    if isinstance(value, bytes):
        return (5, value)
    return (6, repr(value))


def higher_id(key: Any, local: Entry, remote: Entry) -> Entry:
    """Buzz's default: a non-nil value beats nil; otherwise the higher writer id wins."""
    a = (local.value is not None, local.writer)
    b = (remote.value is not None, remote.writer)
    return local if a > b else remote


def lower_value(key: Any, local: Entry, remote: Entry) -> Entry:
    """Non-nil beats nil; then the lower value (lists lexicographically); then the higher writer id."""
    if (local.value is None) != (remote.value is None):
        return remote if local.value is None else local
    a, b = sortable(local.value), sortable(remote.value)
    if a != b:
        return local if a < b else remote
    return local if local.writer > remote.writer else remote


def higher_value(key: Any, local: Entry, remote: Entry) -> Entry:
    """Non-nil beats nil; then the higher value; then the higher writer id."""
    if (local.value is None) != (remote.value is None):
        return remote if local.value is None else local
    a, b = sortable(local.value), sortable(remote.value)
    if a != b:
        return local if a > b else remote
    return local if local.writer > remote.writer else remote


CONFLICT_RULES = Rules("conflict rule", "swarmactors.stigmergy.conflict_rules", {
    "higher_id": higher_id,
    "lower_value": lower_value,
    "higher_value": higher_value,
})
"""C1's rules by name; a third-party rule ``fn(key, local, remote) -> Entry`` registers under the group."""


def conflict_rule(name: str | Callable) -> Callable[[Any, Entry, Entry], Entry]:
    """Return the conflict rule registered as ``name`` (or ``name`` itself when it is a callable)."""
    return CONFLICT_RULES.get(name)


def _is_key(v: Any) -> bool:
    return isinstance(v, str) or is_int(v)


# ------------------------------------------------------------------ the replicated table
class Table:
    """One stigmergy id on one robot. Create it with ``Stigmergy.create``."""

    def __init__(self, node: Stigmergy, sid: int | str, on_conflict: Callable | None = None,
                 on_conflict_lost: Callable[[Any, Entry], Any] | None = None):
        self.node = node
        self.sid = sid
        self.entries: dict[Any, Entry] = {}
        self.changed_at: dict[Any, int] = {}
        self.writes: list[list] = []  # [tick, key, value, ts] of this robot's own writes
        self.on_conflict = on_conflict or higher_id
        self.on_conflict_lost = on_conflict_lost

    # -- the API a behaviour uses
    def put(self, key: Any, value: Any) -> None:
        """Write ``value`` under ``key`` (``None`` deletes) and queue a VS_PUT."""
        if not _is_key(key):
            raise TypeError(f"a stigmergy key must be an int or a str, not {type(key).__name__}")
        node = self.node
        local = self.entries.get(key)
        if local is None and value is None:  # W2: deleting an unknown key does nothing
            return
        entry = Entry(value, 1 if local is None else local.ts + 1, node.id)  # W1
        if value is None and not node.tombstones:  # W2 (Buzz): drop the entry
            del self.entries[key]
            self.changed_at[key] = node.tick
        else:
            self._store(key, entry)
        self.writes.append([node.tick, key, value, entry.ts])
        node.enqueue(PUT, self.sid, key, entry)

    def get(self, key: Any) -> Any:
        """Return the local value (None when missing or deleted) and queue a VS_QUERY with the local entry (W3)."""
        local = self.entries.get(key)
        if local is None:
            self.node.query_counter += 1
            self.node.enqueue(QUERY, self.sid, key, Entry(None, 0, self.node.id), qid=self.node.query_counter)
            return None
        self.node.enqueue(QUERY, self.sid, key, local)
        return local.value

    def peek(self, key: Any) -> Any:
        """Return the local value, without any message."""
        e = self.entries.get(key)
        return None if e is None else e.value

    def entry(self, key: Any) -> Entry | None:
        return self.entries.get(key)

    def size(self) -> int:
        """Return the number of keys with a non-nil value (Buzz's ``size``)."""
        return sum(1 for e in self.entries.values() if e.value is not None)

    def items(self) -> list[tuple[Any, Entry]]:
        return list(self.entries.items())

    # -- internals
    def _store(self, key: Any, entry: Entry) -> None:
        if self.entries.get(key) != entry:
            self.entries[key] = entry
            self.changed_at[key] = self.node.tick

    def snapshot(self) -> dict:
        return {key: [e.value, e.ts, e.writer] for key, e in self.entries.items()}


class Stigmergy:
    """A robot's virtual-stigmergy node: its tables, outgoing queue, counters.

    Owned by a behaviour, which must (1) call ``attach(ctx)`` in ``on_start``,
    (2) pass the VS_* frames it receives to ``on_frame`` (list ``KINDS`` in the
    behaviour's ``kinds``) and (3) call ``flush(ctx)`` at the end of its
    ``on_tick``. Tables: ``node.create(sid, on_conflict=..., on_conflict_lost=...)``.
    """

    def __init__(self, tombstones: bool = True, anti_entropy: int = 0):
        self.tombstones = tombstones
        self.anti_entropy = anti_entropy
        self.tables: dict[int | str, Table] = {}
        self.id = -1
        self._ctx: Context | None = None
        self.query_counter = 0
        self._out: OrderedDict[tuple, list] = OrderedDict()
        self._seen: OrderedDict[tuple, None] = OrderedDict()
        self._phase = 0
        self.sent: Counter = Counter()
        self.received: Counter = Counter()
        self.malformed: Counter = Counter()
        self.foreign = 0
        self.conflicts = 0
        self.conflicts_lost = 0
        self.ignored = 0

    def attach(self, ctx: Context) -> None:
        """Bind the node to its robot (call from ``on_start``)."""
        self.id = ctx.id
        self._ctx = ctx
        self._phase = ctx.id % self.anti_entropy if self.anti_entropy else 0

    def create(self, sid: int | str = 0, on_conflict: Callable | str | None = None,
               on_conflict_lost: Callable | None = None) -> Table:
        """Create (or replace) the table ``sid``."""
        rule = conflict_rule(on_conflict) if on_conflict is not None else higher_id
        table = Table(self, sid, rule, on_conflict_lost)
        self.tables[sid] = table
        return table

    def table(self, sid: int | str = 0) -> Table:
        return self.tables[sid]

    @property
    def tick(self) -> int:
        """The robot's current tick (0 before ``attach``)."""
        return self._ctx.tick if self._ctx is not None else 0

    # -- outgoing
    def enqueue(self, kind: str, sid: Any, key: Any, entry: Entry, dst: int | None = None, qid: int = 0) -> None:
        slot = (sid, key)
        old = self._out.get(slot)
        if old is not None:
            okind, oentry = old[0], old[1]
            if oentry.ts > entry.ts:  # O1: keep the newer queued message
                return
            if oentry.ts == entry.ts and okind == PUT and kind == QUERY:  # O1: a PUT outranks a QUERY
                return
        self._out[slot] = [kind, entry, dst, qid]  # O1: newer, or same age and later

    def flush(self, ctx: Context) -> None:
        """Send the queued messages and, when due, the anti-entropy digests. Call once per tick."""
        if self.anti_entropy and (ctx.tick + self._phase) % self.anti_entropy == 0:
            for sid, table in self.tables.items():
                if table.entries:  # A1
                    digest = [[k, e.ts, e.writer] for k, e in table.entries.items()]
                    BODIES.broadcast(ctx, Digest(sid, digest))
                    self.sent[DIGEST] += 1
        out, self._out = self._out, OrderedDict()
        for (sid, key), (kind, e, dst, qid) in out.items():
            body = Put(sid, key, e.value, e.ts, e.writer) if kind == PUT else \
                Query(sid, key, e.value, e.ts, e.writer, qid)
            if dst is None:
                BODIES.broadcast(ctx, body)
            else:
                BODIES.send(ctx, dst, body)
            self.sent[kind] += 1

    # -- incoming
    def on_frame(self, ctx: Context, frame: Frame) -> bool:
        """Handle a VS_* frame; returns False when the kind is not a stigmergy kind."""
        if frame.kind not in KINDS:
            return False
        self.received[frame.kind] += 1
        body = BODIES.decode(frame, self.malformed)
        if body is None:
            return True
        table = self.tables.get(body.sid)
        if table is None:
            self.foreign += 1  # not a table of this robot: ignored
            return True
        if isinstance(body, Digest):
            self._on_digest(frame.src, table, body)
            return True
        local = table.entries.get(body.key)
        remote = Entry(body.value, body.ts, body.writer)
        if isinstance(body, Put):
            self._on_put(table, body.key, local, remote)
        else:
            self._on_query(table, body.key, local, remote, body.qid)
        return True

    def _on_put(self, table: Table, key: Any, local: Entry | None, remote: Entry) -> None:
        if local is None or remote.ts > local.ts:  # P1: unknown key or newer: store and relay
            table._store(key, remote)
            self.enqueue(PUT, table.sid, key, remote)
        elif remote.ts == local.ts and remote.writer != local.writer:  # P2: conflict: resolve, store, relay
            self._conflict(table, key, local, remote)
        else:  # P3: older or identical: ignore, no relay
            self.ignored += 1

    def _on_query(self, table: Table, key: Any, local: Entry | None, remote: Entry, qid: int) -> None:
        if remote.ts == 0:
            if local is None:  # Q1: nobody here knows the key: relay the query once
                tag = (table.sid, key, remote.writer, qid)
                if remote.writer != self.id and tag not in self._seen:
                    self._seen[tag] = None
                    if len(self._seen) > SEEN_QUERIES:
                        self._seen.popitem(last=False)
                    self.enqueue(QUERY, table.sid, key, remote, qid=qid)
            else:  # Q2: the querier has nothing: answer with the local entry
                self.enqueue(PUT, table.sid, key, local)
        elif local is None or remote.ts > local.ts:  # Q3: querier newer: take it and relay a PUT
            table._store(key, remote)
            self.enqueue(PUT, table.sid, key, remote)
        elif local.ts > remote.ts:  # Q4: local newer: answer with a PUT
            self.enqueue(PUT, table.sid, key, local)
        elif local.writer != remote.writer:  # Q5: same timestamp, other writer: conflict
            self._conflict(table, key, local, remote)
        else:  # Q6: identical: ignore
            self.ignored += 1

    def _conflict(self, table: Table, key: Any, local: Entry, remote: Entry) -> None:
        self.conflicts += 1
        won = table.on_conflict(key, local, remote)
        if won is not local and won is not remote and won != local and won != remote:  # C1: Buzz keeps local ts
            won = Entry(won[0], local.ts, int(won[2]))
        won = Entry(*won)
        table._store(key, won)
        if won.writer != self.id and local.writer == self.id:  # P2: our own write lost
            self.conflicts_lost += 1
            if table.on_conflict_lost is not None:
                table.on_conflict_lost(key, local)
        self.enqueue(PUT, table.sid, key, won)  # P2: propagate the resolution

    def _on_digest(self, src: int, table: Table, digest: Digest) -> None:
        sid = table.sid
        remote: dict[Any, tuple[int, int]] = {key: (ts, writer) for key, ts, writer in digest.items}
        for key, (ts, writer) in remote.items():
            local = table.entries.get(key)
            if local is None or ts > local.ts:  # A2: sender newer: ask it (addressed query)
                if local is None:
                    self.query_counter += 1
                    self.enqueue(QUERY, sid, key, Entry(None, 0, self.id), dst=src, qid=self.query_counter)
                else:
                    self.enqueue(QUERY, sid, key, local, dst=src)
            elif local.ts > ts or local.writer != writer:  # A2: local newer or concurrent: offer ours
                self.enqueue(PUT, sid, key, local)
        for key, local in table.entries.items():
            if key not in remote:  # A2: the sender lacks the key: offer ours
                self.enqueue(PUT, sid, key, local)

    # -- reporting
    def counters(self) -> dict:
        return {
            "sent": dict(self.sent),
            "received": dict(self.received),
            "malformed": dict(self.malformed),
            "foreign": self.foreign,
            "conflicts": self.conflicts,
            "conflicts_lost": self.conflicts_lost,
            "ignored": self.ignored,
        }
