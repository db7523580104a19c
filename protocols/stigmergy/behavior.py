"""Virtual stigmergy: the behaviours (scripted writes, elections). Imports no oracle."""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable
from typing import Any

from protocols.stigmergy.table import CONFLICT_RULES, KINDS, Stigmergy, Table, _is_key, lower_value, sortable
from swarmactors import Behavior, Context, Frame
from swarmactors.robot.behavior import is_int


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
    return is_int(v) and v >= 0


def _validate_common(params: dict) -> str | None:
    ae = params.get("anti_entropy", 0)
    if not _non_negative_int(ae):
        return f"anti_entropy = {ae!r} must be a non-negative integer (ticks; 0 = off)"
    problem = CONFLICT_RULES.problem(params.get("conflict", "higher_id"))
    if problem:
        return f"conflict: {problem}"
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
    ``higher_value`` | a rule registered under
    ``swarmactors.stigmergy.conflict_rules``), ``tombstones``, ``anti_entropy``
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
