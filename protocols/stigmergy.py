"""Virtual stigmergy: a replicated key -> value table shared through neighbour messages.

The semantics are those of the Buzz language's virtual stigmergy (Pinciroli &
Beltrame, reference [28] of Swarm Relays, 002 Sec. III-D), which Swarm Relays
uses to share task assignments, paths and election results. A robot may hold
several tables, one per stigmergy id (``sid``). An entry is ``(value,
timestamp, writer)``: the timestamp is a Lamport clock per key, the writer the
id of the robot that wrote that version. ``None`` is Buzz's nil.

Local operations
  W1 ``put(k, v)`` on a key with a local entry: timestamp = local + 1, writer =
     self; on an unknown key: timestamp 1. It queues a VS_PUT.
  W2 ``put(k, None)`` deletes: it stores a *tombstone* (nil value with the new
     timestamp and writer) and queues a VS_PUT carrying the nil. Buzz drops the
     entry instead, so that an older PUT still in flight brings the key back at
     the deleting robot (its neighbours keep the nil and diverge from it for
     ever); ``tombstones = False`` restores Buzz's behaviour. ``put(k, None)``
     on an unknown key does nothing (as in Buzz).
  W3 ``get(k)`` returns the local value at once (nil when missing or deleted)
     and queues a VS_QUERY carrying the local entry (timestamp 0 when there is
     none). ``peek(k)`` is the same read without the query (not in Buzz).

Receiving a VS_PUT (remote entry r, local entry l)
  P1 no local entry, or r newer (r.ts > l.ts): store r and relay it;
  P2 same timestamp, different writer: a conflict, resolved by the table's
     ``on_conflict(key, l, r)`` which returns the winning entry; the winner is
     stored and relayed; when the local entry was this robot's own write and
     it lost, ``on_conflict_lost(key, l)`` is called;
  P3 older, or the identical (timestamp, writer): ignore, do not relay - this
     is what stops the flood.

Receiving a VS_QUERY (r: the querier's entry, timestamp 0 when it has none)
  Q1 r.ts = 0 and no local entry: relay the query once per (sid, key,
     querier, query number) - Buzz relays it on every receipt, which keeps a
     query for a key that nobody holds bouncing for ever;
  Q2 r.ts = 0 and a local entry: answer with a VS_PUT of the local entry;
  Q3 r newer than the local entry (or no local entry): store r, relay a VS_PUT;
  Q4 local entry newer: answer with a VS_PUT of the local entry;
  Q5 same timestamp, different writer: conflict, as P2;
  Q6 identical: ignore.

Conflict rule (``conflict`` parameter, or any ``on_conflict`` callable)
  C1 default (Buzz): a non-nil value beats a nil one; otherwise the higher
     writer id wins. ``lower_value`` (elections) and ``higher_value`` compare
     the values (lists lexicographically), then the higher writer id. Every
     built-in rule picks the larger of the two entries under a total order,
     so all robots resolve the same set of concurrent writes to the same
     winner in any order of arrival. A custom handler must do the same;
     if it returns an entry that is neither argument, its value and writer
     are kept with the local timestamp (Buzz's rule).

Outgoing queue
  O1 at most one message per (sid, key) is queued per tick: a newer entry
     (higher timestamp) replaces the queued one; at equal timestamps a PUT
     outranks a QUERY and otherwise the later one (which reflects the local
     table after conflict resolution) replaces the earlier. The queue is sent
     in ``flush``, once per tick, in the order keys were first queued.

Anti-entropy (optional, not in Buzz)
  A1 every ``anti_entropy`` ticks a robot with a non-empty table broadcasts a
     VS_DIGEST (sid, [(key, ts, writer), ...]) of that table;
  A2 on a digest: for a key where the sender is newer (or that is unknown
     locally), send the sender an addressed VS_QUERY with the local entry (it
     answers by Q2/Q4); where the local entry is newer, or has the same
     timestamp and another writer, or the digest lacks the key, broadcast a
     VS_PUT of the local entry (a conflict is then resolved by P2 on the other
     side); identical entries: nothing.

Bad input: a body that is not the expected list, a sid or key that is not an
int or str, a timestamp that is not an integer (or < 1 in a PUT, < 0 in a
QUERY), a writer that is not a non-negative integer, or a malformed digest is
dropped and counted in ``malformed`` by reason. Timestamps are unbounded
Python integers (Buzz's wrap at 2^16).

Elections (Swarm Relays' "gradient" elections of the root and of one worker
per target): ``Election`` runs a lowest-bid-wins election over a table whose
conflict rule is ``lower_value``. While the election is open (``start`` to
``start + duration``) every robot whose bid ``[bid, id]`` beats the table's
current value puts it (E1); the conflict rule keeps the lowest ``[bid, id]``
(E2); at the close every robot reads the winner with ``get`` (E3). With
``exclusive`` elections run one after the other and a robot that won one does
not bid in the later ones (E4).

Keys appear in reports and result.json as strings: the keys 1 and "1" would
collide there (they are distinct in the table).
"""

from __future__ import annotations

import importlib
import math
from collections import Counter, OrderedDict
from collections.abc import Callable
from typing import Any, NamedTuple

import networkx as nx
import numpy as np

from swarmactors import Behavior, Context, Frame, Outcome, Result
from swarmactors.conformance import Case, Family, comb, line, random_geometric, ring

PUT = "VS_PUT"
QUERY = "VS_QUERY"
DIGEST = "VS_DIGEST"
KINDS = (PUT, QUERY, DIGEST)
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


CONFLICT_RULES: dict[str, Callable[[Any, Entry, Entry], Entry]] = {
    "higher_id": higher_id,
    "lower_value": lower_value,
    "higher_value": higher_value,
}


def conflict_rule(name: str | Callable) -> Callable[[Any, Entry, Entry], Entry]:
    """Return a built-in rule by name, a ``module:function`` path, or a callable."""
    if callable(name):
        return name
    if name in CONFLICT_RULES:
        return CONFLICT_RULES[name]
    module, sep, attr = str(name).partition(":")
    if not sep:
        raise ValueError(f"unknown conflict rule {name!r} (known: {', '.join(CONFLICT_RULES)}, or module:function)")
    fn = getattr(importlib.import_module(module), attr)
    if not callable(fn):
        raise ValueError(f"{name!r} is not callable")
    return fn


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_key(v: Any) -> bool:
    return isinstance(v, str) or _is_int(v)


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
                    ctx.broadcast(DIGEST, [sid, digest])
                    self.sent[DIGEST] += 1
        out, self._out = self._out, OrderedDict()
        for (sid, key), (kind, e, dst, qid) in out.items():
            body = [sid, key, e.value, e.ts, e.writer] if kind == PUT else [sid, key, e.value, e.ts, e.writer, qid]
            if dst is None:
                ctx.broadcast(kind, body)
            else:
                ctx.send(dst, kind, body)
            self.sent[kind] += 1

    # -- incoming
    def on_frame(self, ctx: Context, frame: Frame) -> bool:
        """Handle a VS_* frame; returns False when the kind is not a stigmergy kind."""
        if frame.kind not in KINDS:
            return False
        self.received[frame.kind] += 1
        if frame.kind == DIGEST:
            self._on_digest(frame)
            return True
        parsed = self._parse(frame)
        if parsed is None:
            return True
        sid, key, remote, qid = parsed
        table = self.tables.get(sid)
        if table is None:
            self.foreign += 1  # not a table of this robot: ignored
            return True
        local = table.entries.get(key)
        if frame.kind == PUT:
            self._on_put(table, key, local, remote)
        else:
            self._on_query(table, key, local, remote, qid)
        return True

    def _bad(self, reason: str) -> None:
        self.malformed[reason] += 1

    def _parse(self, frame: Frame) -> tuple | None:
        body = frame.body
        n = 5 if frame.kind == PUT else 6
        if not isinstance(body, list) or len(body) != n:
            return self._bad("shape")
        sid, key, value, ts, writer = body[:5]
        if not _is_key(sid):
            return self._bad("sid")
        if not _is_key(key):
            return self._bad("key")
        if not _is_int(ts) or ts < (1 if frame.kind == PUT else 0):
            return self._bad("timestamp")
        if not _is_int(writer) or writer < 0:
            return self._bad("writer")
        qid = body[5] if n == 6 else 0
        if n == 6 and (not _is_int(qid) or qid < 0):
            return self._bad("query_id")
        if ts == 0 and value is not None:
            return self._bad("timestamp")
        return sid, key, Entry(value, ts, writer), qid

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

    def _on_digest(self, frame: Frame) -> None:
        body = frame.body
        if not isinstance(body, list) or len(body) != 2 or not _is_key(body[0]) or not isinstance(body[1], list):
            return self._bad("digest")
        sid, items = body
        table = self.tables.get(sid)
        if table is None:
            self.foreign += 1
            return None
        remote: dict[Any, tuple[int, int]] = {}
        for item in items:
            if (not isinstance(item, list) or len(item) != 3 or not _is_key(item[0]) or not _is_int(item[1])
                    or item[1] < 1 or not _is_int(item[2]) or item[2] < 0):
                return self._bad("digest")
            remote[item[0]] = (item[1], item[2])
        for key, (ts, writer) in remote.items():
            local = table.entries.get(key)
            if local is None or ts > local.ts:  # A2: sender newer: ask it (addressed query)
                if local is None:
                    self.query_counter += 1
                    self.enqueue(QUERY, sid, key, Entry(None, 0, self.id), dst=frame.src, qid=self.query_counter)
                else:
                    self.enqueue(QUERY, sid, key, local, dst=frame.src)
            elif local.ts > ts or local.writer != writer:  # A2: local newer or concurrent: offer ours
                self.enqueue(PUT, sid, key, local)
        for key, local in table.entries.items():
            if key not in remote:  # A2: the sender lacks the key: offer ours
                self.enqueue(PUT, sid, key, local)
        return None

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


# ------------------------------------------------------------------ scripted writes
def _check_list(params: dict, name: str, fields: dict[str, Callable[[Any], bool]], required: tuple) -> str | None:
    items = params.get(name, [])
    if not isinstance(items, list):
        return f"{name} must be a list of tables"
    for i, item in enumerate(items):
        if not isinstance(item, dict):
            return f"{name}[{i}] must be a table"
        for key in required:
            if key not in item:
                return f"{name}[{i}] lacks {key!r}"
        for key, value in item.items():
            if key not in fields:
                return f"{name}[{i}].{key}: unknown key (known: {', '.join(fields)})"
            if not fields[key](value):
                return f"{name}[{i}].{key} = {value!r} is not valid"
    return None


def _non_negative_int(v: Any) -> bool:
    return _is_int(v) and v >= 0


def _validate_common(params: dict) -> str | None:
    ae = params.get("anti_entropy", 0)
    if not _non_negative_int(ae):
        return f"anti_entropy = {ae!r} must be a non-negative integer (ticks; 0 = off)"
    rule = params.get("conflict", "higher_id")
    if not isinstance(rule, str) or (rule not in CONFLICT_RULES and ":" not in rule):
        return f"conflict = {rule!r} must be one of {', '.join(CONFLICT_RULES)} or module:function"
    if not isinstance(params.get("tombstones", True), bool):
        return "tombstones must be true or false"
    sid = params.get("sid", 0)
    if not _is_key(sid):
        return f"sid = {sid!r} must be an integer or a string"
    return None


class StigmergyScript(Behavior):
    """Scripted writes, deletes and reads on one stigmergy table (for scenarios and tests).

    Parameters: ``writes`` = [{at, robot, key, value} or {at, robot, key,
    delete = true}], ``reads`` = [{at, robot, key}] (a ``get``, which sends a
    VS_QUERY), ``sid``, ``conflict`` (``higher_id`` | ``lower_value`` |
    ``higher_value`` | ``module:function``), ``tombstones``, ``anti_entropy``
    (ticks between digests; 0 = off).
    """

    name = "stigmergy"
    kinds = KINDS
    plot_field = "keys"

    def __init__(self, writes: list | None = None, reads: list | None = None, sid: int | str = 0,
                 conflict: str = "higher_id", tombstones: bool = True, anti_entropy: int = 0):
        self.script = sorted((w for w in (writes or [])), key=lambda w: w["at"])
        self.reads = list(reads or [])
        self.node = Stigmergy(tombstones=tombstones, anti_entropy=anti_entropy)
        self.table = self.node.create(sid, on_conflict=conflict)
        self.sid = sid
        self.read_log: list[list] = []
        self.lost: list[list] = []
        self.table.on_conflict_lost = lambda key, entry: self.lost.append([self.node.tick, key, entry.value, entry.ts])

    @staticmethod
    def validate(params: dict) -> str | None:
        problem = _validate_common(params)
        if problem:
            return problem
        fields = {"at": _non_negative_int, "robot": _non_negative_int, "key": _is_key,
                  "value": lambda v: True, "delete": lambda v: v is True}
        problem = _check_list(params, "writes", fields, ("at", "robot", "key"))
        if problem:
            return problem
        for i, w in enumerate(params.get("writes", [])):
            if ("value" in w) == ("delete" in w):
                return f"writes[{i}]: give exactly one of value or delete = true"
        return _check_list(params, "reads", {"at": _non_negative_int, "robot": _non_negative_int, "key": _is_key},
                           ("at", "robot", "key"))

    def on_start(self, ctx: Context) -> None:
        self.node.attach(ctx)

    def on_frame(self, ctx: Context, frame: Frame) -> None:
        self.node.on_frame(ctx, frame)

    def on_tick(self, ctx: Context, sensed) -> None:
        while self.script and self.script[0]["at"] <= ctx.tick:
            w = self.script.pop(0)
            if w["robot"] == ctx.id:
                self.table.put(w["key"], None if w.get("delete") else w["value"])
        for r in self.reads:
            if r["at"] == ctx.tick and r["robot"] == ctx.id:
                self.read_log.append([ctx.tick, r["key"], self.table.get(r["key"])])
        ctx.set_status(keys=self.table.size())
        self.node.flush(ctx)

    def report(self) -> dict:
        return {
            "sid": self.sid,
            "table": self.table.snapshot(),
            "changed_at": dict(self.table.changed_at),
            "writes": self.table.writes,
            "reads": self.read_log,
            "lost": self.lost,
            **self.node.counters(),
        }

    @classmethod
    def metrics(cls, reports: dict[int, dict]) -> dict:
        return stigmergy_metrics(reports)


def stigmergy_metrics(reports: dict[int, dict]) -> dict:
    """Run-level numbers: messages by kind, distinct tables, last write and last change."""
    sent: Counter = Counter()
    malformed: Counter = Counter()
    for r in reports.values():
        sent.update(r.get("sent", {}))
        malformed.update(r.get("malformed", {}))
    writes = [w[0] for r in reports.values() for w in r.get("writes", [])]
    changes = [t for r in reports.values() for t in r.get("changed_at", {}).values()]
    tables = {repr(sorted((str(k), v) for k, v in r.get("table", {}).items())) for r in reports.values()}
    n = len(reports)
    return {
        "robots": n,
        "messages": dict(sent),
        "messages_per_robot": sum(sent.values()) / n if n else 0.0,
        "distinct_tables": len(tables),
        "last_write": max(writes, default=None),
        "last_change": max(changes, default=None),
        "conflicts": sum(r.get("conflicts", 0) for r in reports.values()),
        "malformed": dict(malformed),
    }


# ------------------------------------------------------------------ elections
class Election:
    """Lowest bid wins, over a stigmergy table whose conflict rule is ``lower_value``.

    ``bid(ctx)`` returns this robot's bid (a number) or None to abstain. Call
    ``step(ctx)`` every tick (before the node's ``flush``). The table value
    under ``key`` is ``[bid, robot id]``.
    """

    def __init__(self, table: Table, key: str, bid: Callable[[Context], float | None], start: int, duration: int):
        self.table, self.key, self.bid_fn = table, key, bid
        self.start, self.duration = start, duration
        self.bid: float | None = None
        self.puts = 0
        self.winner: int | None = None
        self.winning_bid: float | None = None
        self.elected_at: int | None = None
        self.abstain = False

    @property
    def end(self) -> int:
        return self.start + self.duration

    def step(self, ctx: Context) -> None:
        if self.elected_at is not None or ctx.tick < self.start:
            return
        if ctx.tick < self.end:
            if self.abstain:
                return
            self.bid = self.bid_fn(ctx)
            if self.bid is None:
                return
            mine = [self.bid, ctx.id]
            current = self.table.peek(self.key)
            if current is None or sortable(mine) < sortable(current):  # E1: my bid beats the current value
                self.table.put(self.key, mine)
                self.puts += 1
            return
        value = self.table.get(self.key)  # E3: the close: read the winner
        self.elected_at = ctx.tick
        if isinstance(value, list) and len(value) == 2:
            self.winning_bid, self.winner = value[0], value[1]


class StigmergyElection(Behavior):
    """Swarm Relays' elections: the root and one worker per target, lowest distance wins.

    Parameters: ``elections`` = [{key, target = [x, y]}] (the bid is the
    robot's distance to ``target``), ``start`` (tick the first election
    opens), ``duration`` (ticks each stays open), ``exclusive`` (run them one
    after the other; a winner does not bid again), ``sid``, ``anti_entropy``.
    """

    name = "election"
    kinds = KINDS
    plot_field = "elected"

    def __init__(self, elections: list, start: int = 1, duration: int = 20, exclusive: bool = True,
                 sid: int | str = 1, anti_entropy: int = 0, tombstones: bool = True):
        self.specs = elections
        self.exclusive = exclusive
        self.node = Stigmergy(tombstones=tombstones, anti_entropy=anti_entropy)
        self.table = self.node.create(sid, on_conflict=lower_value)  # E2
        self.elections: list[Election] = []
        for i, spec in enumerate(elections):
            s = start + (i * duration if exclusive else 0)
            self.elections.append(Election(self.table, spec["key"], self._distance_to(spec["target"]), s, duration))
        self.role = "free"

    @staticmethod
    def _distance_to(target: list) -> Callable[[Context], float]:
        def bid(ctx: Context) -> float:
            p = list(ctx.position)
            t = list(target) + [0.0] * (len(p) - len(target))
            return round(math.dist(p, t[: len(p)]), 9)

        return bid

    @staticmethod
    def validate(params: dict) -> str | None:
        problem = _validate_common({k: v for k, v in params.items() if k != "conflict"})
        if problem:
            return problem
        el = params.get("elections")
        if not isinstance(el, list) or not el:
            return "elections must be a non-empty list of {key, target = [x, y]}"
        keys = set()
        for i, e in enumerate(el):
            if not isinstance(e, dict) or set(e) != {"key", "target"}:
                return f"elections[{i}] must be {{key = \"...\", target = [x, y]}}"
            if not isinstance(e["key"], str) or e["key"] in keys:
                return f"elections[{i}].key must be a unique string"
            keys.add(e["key"])
            t = e["target"]
            if (not isinstance(t, list) or len(t) not in (2, 3)
                    or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in t)):
                return f"elections[{i}].target must be [x, y] or [x, y, z]"
        for key in ("start", "duration"):
            v = params.get(key, 1)
            if not _non_negative_int(v) or (key == "duration" and v < 1):
                return f"{key} = {v!r} must be a {'positive' if key == 'duration' else 'non-negative'} integer"
        if not isinstance(params.get("exclusive", True), bool):
            return "exclusive must be true or false"
        return None

    def on_start(self, ctx: Context) -> None:
        self.node.attach(ctx)
        ctx.set_status(elected=0, role="free")

    def on_frame(self, ctx: Context, frame: Frame) -> None:
        self.node.on_frame(ctx, frame)

    def on_tick(self, ctx: Context, sensed) -> None:
        for i, e in enumerate(self.elections):
            if self.exclusive and ctx.tick == e.start:  # E4: a robot already elected does not bid again
                e.abstain = any(p.winner == ctx.id for p in self.elections[:i])
            was = e.elected_at
            e.step(ctx)
            if was is None and e.elected_at is not None and e.winner == ctx.id and self.role == "free":
                self.role = e.key
                ctx.set_status(elected=i + 1, role=e.key)
        self.node.flush(ctx)

    def report(self) -> dict:
        return {
            "elected": {e.key: e.winner for e in self.elections},
            "elected_at": {e.key: e.elected_at for e in self.elections},
            "winning_bid": {e.key: e.winning_bid for e in self.elections},
            "agreed_at": {e.key: self.table.changed_at.get(e.key) for e in self.elections},
            "bids": {e.key: e.bid for e in self.elections},
            "puts": {e.key: e.puts for e in self.elections},
            "windows": {e.key: [e.start, e.end] for e in self.elections},
            "role": self.role,
            "table": self.table.snapshot(),
            "changed_at": dict(self.table.changed_at),
            "writes": self.table.writes,
            **self.node.counters(),
        }

    @classmethod
    def metrics(cls, reports: dict[int, dict]) -> dict:
        out = stigmergy_metrics(reports)
        winners: dict[str, Counter] = {}
        for r in reports.values():
            for key, w in r.get("elected", {}).items():
                winners.setdefault(key, Counter())[w] += 1
        out["elected"] = {k: c.most_common(1)[0][0] for k, c in winners.items()}
        out["unanimous"] = {k: len(c) == 1 for k, c in winners.items()}
        return out


# ------------------------------------------------------------------ oracle checks
def _last_tick(result: Result) -> int:
    return result.trace[-1]["t"]


def oracle_tables(result: Result, behavior: str = "stigmergy", graph: nx.Graph | None = None) -> dict[int, dict]:
    """Robot -> {str(key): [value, ts, writer]} that the write log implies for its component.

    For each key: among the writes by robots of the component, the highest
    timestamp; among those, the winner of the conflict rule (folded pairwise).
    """
    params = result.behavior_params(behavior)
    rule = conflict_rule(params.get("conflict", "higher_id"))
    reports = result.reports(behavior)
    g = graph if graph is not None else result.graph_at(_last_tick(result))
    out: dict[int, dict] = {}
    for comp in nx.connected_components(g):
        best: dict[str, Entry] = {}
        for rid in sorted(comp):
            for _tick, key, value, ts in reports.get(rid, {}).get("writes", []):
                e = Entry(value, ts, rid)
                k = str(key)
                cur = best.get(k)
                if cur is None or e.ts > cur.ts:
                    best[k] = e
                elif e.ts == cur.ts and e.writer != cur.writer:
                    best[k] = Entry(*rule(key, cur, e))
        table = {k: [e.value, e.ts, e.writer] for k, e in best.items()}
        for rid in comp:
            out[rid] = table
    return out


def consistent(result: Result, behavior: str = "stigmergy", within: int | None = None) -> Outcome:
    """Every robot holds exactly the oracle's table of its component (last-tick graph).

    With ``within``, also: every robot's last change is no later than ``within`` ticks after its component's
    last write.
    """
    oracle = oracle_tables(result, behavior)
    reports = result.reports(behavior)
    wrong = sorted(rid for rid, rep in reports.items() if rid in oracle and rep["table"] != oracle[rid])
    late: list[int] = []
    if within is not None:
        g = result.graph_at(_last_tick(result))
        for comp in nx.connected_components(g):
            last_write = max((w[0] for r in comp for w in reports.get(r, {}).get("writes", [])), default=None)
            if last_write is None:
                continue
            late += [r for r in comp if max(reports[r]["changed_at"].values(), default=0) > last_write + within]
    ok = not wrong and not late
    detail = ""
    if wrong:
        r = wrong[0]
        detail = f"robots with a wrong table {wrong[:10]}; robot {r} has {reports[r]['table']} != {oracle[r]}"
    elif late:
        detail = f"robots that changed later than {within} ticks after the last write: {sorted(late)[:10]}"
    return Outcome("stigmergy.consistent", ok, value=len(reports) - len(wrong), bound=len(reports), detail=detail)


def latency(result: Result, behavior: str = "stigmergy") -> Outcome:
    """Lockstep, no loss: robot r holds each key's final entry by t_w + c * hops(writer, r)."""
    c = result["scenario"]["radio"]["latency"]
    reports = result.reports(behavior)
    g = result.graph_at(_last_tick(result))
    oracle = oracle_tables(result, behavior, g)
    write_tick = {(rid, str(w[1]), w[3]): w[0] for rid, r in reports.items() for w in r["writes"]}
    late = []
    for rid, rep in reports.items():
        for key, (_v, ts, writer) in oracle.get(rid, {}).items():
            bound = write_tick[(writer, key, ts)] + c * nx.shortest_path_length(g, writer, rid)
            got = rep["changed_at"].get(key)
            if got is None or got > bound:
                late.append((rid, key, got, bound))
    return Outcome("stigmergy.latency", not late, value=len(late), bound=0,
                   detail="" if not late else f"(robot, key, changed at, bound): {late[:5]}")


def oracle_elections(result: Result, behavior: str = "election") -> dict[int, dict[str, int]]:
    """Robot -> {key: winner}: per component, the lowest (distance to target, id) at each election's opening.

    With ``exclusive``, one election after the other, without the earlier winners.
    """
    params = result.behavior_params(behavior)
    start, duration = params.get("start", 1), params.get("duration", 20)
    exclusive = params.get("exclusive", True)
    specs = params["elections"]
    g = result.graph_at(start)
    out: dict[int, dict[str, int]] = {}
    for comp in nx.connected_components(g):
        taken: set[int] = set()
        winners: dict[str, int] = {}
        for i, spec in enumerate(specs):
            t = start + (i * duration if exclusive else 0)
            pos = {row[0]: row[1:] for row in result.record(t)["pos"]}
            target = list(spec["target"])
            cands = []
            for r in comp:
                if exclusive and r in taken or r not in pos:
                    continue
                p = pos[r]
                d = round(math.dist(p, (target + [0.0] * len(p))[: len(p)]), 9)
                cands.append((d, r))
            if cands:
                winners[spec["key"]] = min(cands)[1]
                taken.add(winners[spec["key"]])
        for r in comp:
            out[r] = winners
    return out


def election(result: Result, behavior: str = "election") -> Outcome:
    """Every robot read the oracle's winner of every election (lowest distance, then lowest id)."""
    oracle = oracle_elections(result, behavior)
    reports = result.reports(behavior)
    wrong = sorted(r for r, rep in reports.items() if r in oracle and rep["elected"] != oracle[r])
    detail = ""
    if wrong:
        r = wrong[0]
        detail = f"robots with a wrong winner {wrong[:10]}; robot {r} read {reports[r]['elected']} != {oracle[r]}"
    return Outcome("stigmergy.election", not wrong, value=len(reports) - len(wrong), bound=len(reports),
                   detail=detail)


# ------------------------------------------------------------------ conformance suite
def _vs_case(name: str, positions: list, writes: list, *, checks: list[dict], clock="lockstep", loss=0.0, seed=1,
             anti_entropy=0, ticks=60) -> Case:
    run = {"seed": seed, "clock": clock, "ticks": ticks}
    radio = {"range": 1.0, "latency": 1, "loss": loss}
    if clock == "realtime":
        run.update(dt=0.05)
        radio.update(latency_s=0.02, latency_min_s=0.005)
    beh = {"use": "stigmergy", "writes": writes, "anti_entropy": anti_entropy}
    scenario = {"run": run, "radio": radio, "robots": [{"positions": positions, "behaviors": [beh]}]}
    return Case(f"stigmergy/{name}", scenario, checks)


def _writes(n: int, seed: int, count: int = 6) -> list[dict]:
    """Concurrent writes: two robots write one key in the same tick (a conflict), others write and delete."""
    rng = np.random.default_rng([seed, n, 11])
    a, b = (int(x) for x in rng.choice(n, 2, replace=False))
    out = [{"at": 2, "robot": a, "key": "k0", "value": a}, {"at": 2, "robot": b, "key": "k0", "value": b}]
    for i in range(count - 2):
        out.append({"at": 2 + i, "robot": int(rng.integers(n)), "key": f"k{1 + i % 3}", "value": i})
    out.append({"at": 3 + count, "robot": int(rng.integers(n)), "key": "k1", "delete": True})
    return out


def suite(mode: str) -> list[Case]:
    """Writes, conflicts and deletes on several graphs; loss with anti-entropy; two components; both clocks."""
    exact = [{"use": "stigmergy.consistent", "within": 40}, {"use": "stigmergy.latency"}]
    repaired = [{"use": "stigmergy.consistent"}]
    two_components = line(5) + [[x + 20.0, y] for x, y in line(5)]
    cases = [
        _vs_case("ring-10", ring(10), _writes(10, 1), checks=exact),
        _vs_case("rgg-20-s1", random_geometric(20, 1), _writes(20, 1), checks=exact),
        _vs_case("two-components", two_components, _writes(10, 2), checks=exact),
        _vs_case("rgg-20-s2-loss-0.2-anti-entropy", random_geometric(20, 2), _writes(20, 2), checks=repaired,
                 loss=0.2, anti_entropy=5, ticks=120),
        _vs_case("rgg-12-s3-realtime", random_geometric(12, 3), _writes(12, 3), checks=repaired, clock="realtime",
                 ticks=40),
    ]
    if mode == "full":
        for n, seed in ((10, 4), (40, 5), (80, 6)):
            cases.append(_vs_case(f"rgg-{n}-s{seed}", random_geometric(n, seed), _writes(n, seed, 10), checks=exact,
                                  seed=seed, ticks=80))
        cases.append(_vs_case("comb-15", comb(15), _writes(15, 7), checks=exact))
        for loss in (0.1, 0.3):
            cases.append(_vs_case(f"rgg-30-s8-loss-{loss}-anti-entropy", random_geometric(30, 8), _writes(30, 8),
                                  checks=repaired, loss=loss, anti_entropy=5, ticks=200, seed=8))
        cases.append(_vs_case("rgg-20-s9-realtime-loss-0.1", random_geometric(20, 9), _writes(20, 9),
                              checks=repaired, clock="realtime", loss=0.1, anti_entropy=3, ticks=60))
    return cases


FAMILY = Family(name="stigmergy", behavior="stigmergy", report={"table": dict, "writes": list, "changed_at": dict},
                suite=suite)
