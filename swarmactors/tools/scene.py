"""What a viewer draws: the swarm at one tick, built from trace records or the live streams.

A ``Scene`` is fed either with tick records in the trace format
(``feed_record``: exact, from the world's own sink in the world's process or
from a trace file) or with the world's observer streams (``feed_state`` /
``feed_event``: the ``state`` and ``events`` keys over Zenoh, best-effort).
``frame()`` gives the JSON document the web page draws; ``robot(rid)`` the
details of one robot; ``control_events()`` the actions applied through the
world's ``control`` queryable, which ``events_toml`` turns into ``[[events]]``
tables that reproduce them.

Feeding happens on every tick (in the world's loop for a live run), so it only
updates counters and keeps references; anything costly waits for ``frame()``,
which viewers call at their own pace.
"""

from __future__ import annotations

import re
from collections import Counter, deque
from typing import Any

import tomli_w

from swarmactors.oracle.result import to_jsonable
from transport import unpack
from transport.messages import malformed_count
from world.linkrules import DROP_CAUSES

ACTIVITY_TICKS = 3  # a robot "is talking" when it sent frames in the last ACTIVITY_TICKS ticks
RECENT_TICKS = 50  # per-robot frame history kept for the detail panel
EVENTS_SHOWN = 40
_LOG_TICK = re.compile(r"^\[(-?\d+)\]")


def initial_ranges(scenario: dict) -> dict[int, float]:
    """Robot id -> radio range for the robots of a resolved scenario (in id order)."""
    out: dict[int, float] = {}
    default = float(scenario.get("radio", {}).get("range", 1.0))
    for g in scenario.get("robots", []):
        r = g.get("range")
        for _ in range(len(g.get("positions") or []) or int(g.get("count") or 0)):
            out[len(out)] = float(r if r is not None else default)
    return out


def initial_positions(scenario: dict) -> dict[int, list[float]]:
    out: dict[int, list[float]] = {}
    for g in scenario.get("robots", []):
        for p in g.get("positions") or []:
            out[len(out)] = list(p)
    return out


def space_document(sc: dict) -> dict | None:
    """What the page draws of the world's space, sent once (``/api/space``).

    Obstacles, the grid map as one plane (``@`` blocked at every height, ``+`` at some heights, ``W`` water),
    body radii and flying robots.
    """
    world = sc.get("world", {}) if sc else {}
    specs = [g for g in sc.get("robots", [])] if sc else []
    radius, flying, rid = {}, [], 0
    for g in specs:
        for _ in range(g.get("count") or len(g.get("positions") or [])):
            if g.get("body_radius"):
                radius[str(rid)] = g["body_radius"]
            if g.get("kind") == "flying":
                flying.append(rid)
            rid += 1
    if not (world.get("obstacles") or world.get("map") or radius or flying):
        return None
    grid = None
    m = world.get("map")
    if m:
        layers = m["layers"]
        rows = []
        for r in range(len(layers[0]["rows"])):
            cells = []
            for c in range(len(layers[0]["rows"][0])):
                hits = [layer["rows"][r][c] == "@" for layer in layers]
                wet = bool(m.get("water")) and m["water"][r][c] == "W"
                cells.append("@" if all(hits) or (hits[0] and len(hits) == 1) else "+" if any(hits)
                             else "W" if wet else ".")
            rows.append("".join(cells))
        grid = {"cell": m["cell"], "origin": m["origin"], "rows": rows}
    return {"obstacles": world.get("obstacles") or [], "map": grid, "radius": radius, "flying": flying}


class Scene:
    """The swarm as last seen: positions, status, failures, objects, counters, recent frames."""

    def __init__(self, *, run_id: str = "", clock: str = "lockstep", ticks: int | None = None,
                 scenario: dict | None = None, mode: str = "live", frames_available: bool = True):
        sc = scenario or {}
        self.run_id = run_id
        self.clock = clock
        self.ticks = ticks
        self.mode = mode
        self.frames_available = frames_available
        world = sc.get("world", {})
        self.bounds = world.get("bounds")
        self.space = space_document(sc)  # static: obstacles, map, bodies, flying robots (None: nothing to draw)
        self.objects: dict[str, list[float]] = {o["name"]: list(o["pos"]) for o in world.get("objects", [])}
        self.field = _plot_field(sc)
        self.ranges: dict[int, float] = initial_ranges(sc) if sc else {}
        self.default_range = float(sc.get("radio", {}).get("range", 1.0)) if sc else 1.0
        self.t: int | None = None
        self.pos: list[list] = []  # [[id, x, y(, z)], ...] of alive robots at tick t (shared, not copied)
        self._start_pos = initial_positions(sc) if sc else {}
        self.status: dict[int, dict] = {}
        self.dead: dict[int, dict] = {}  # id -> {"pos", "cause", "t"}
        self.events: list[dict] = []
        self.dropped = {c: 0 for c in DROP_CAUSES}
        self.sent = 0
        self.deliveries = 0
        self.overheard = 0  # copies robots on a broadcast's exclude list overheard (world/radio.py)
        self.recent: deque = deque(maxlen=RECENT_TICKS)  # tick records with frames, newest last
        self.logs: dict[int, list[str]] = {}
        self.finished = False
        self._raw_state: bytes | None = None  # latest undecoded state message (live over Zenoh)
        self._last_pos: dict[int, list] = {}

    # ------------------------------------------------------------ feeding
    def feed_record(self, rec: dict) -> None:
        """One tick record in the trace format (exact)."""
        for ev in rec.get("ev", ()):
            self._event(ev, prev=self.pos)
        self.t = rec["t"]
        self.pos = rec.get("pos", [])
        for rid, changes in rec.get("status", {}).items():
            self.status.setdefault(rid, {}).update(changes)
        sent = rec.get("sent")
        delivered = rec.get("del")
        drops = rec.get("drop")
        if sent:
            self.sent += len(sent)
        if delivered:
            self.deliveries += len(delivered)
        if rec.get("ovh"):
            self.overheard += len(rec["ovh"])
        if drops:
            for d in drops:
                self.dropped[d[3]] = self.dropped.get(d[3], 0) + 1
        if rec.get("mal"):
            self.dropped["malformed"] += malformed_count(rec["mal"])
        if sent or delivered or drops:
            self.recent.append(rec)

    def feed_state(self, payload: bytes) -> None:
        """A ``state`` message from the world (kept raw; decoded when a frame is built)."""
        self._raw_state = payload

    def feed_event(self, payload: bytes | dict) -> None:
        """An ``events`` message from the world."""
        ev = unpack(payload, what="event") if isinstance(payload, bytes) else payload
        if isinstance(ev, dict):
            self._event(ev, prev=None)

    def sync(self) -> None:
        """Take in the newest ``state`` message, if one came since (``feed_state`` only keeps it)."""
        self._decode_state()

    def _decode_state(self) -> None:
        raw, self._raw_state = self._raw_state, None
        if raw is None:
            return
        msg = unpack(raw, what="state")
        if not isinstance(msg, dict) or not isinstance(msg.get("t"), int):
            return
        self.t = msg["t"]
        self.pos = msg.get("pos", [])
        self.status = {int(k): v for k, v in msg.get("status", {}).items()}
        for row, r in zip(self.pos, msg.get("ranges", []), strict=False):
            self.ranges[row[0]] = r
        if isinstance(msg.get("objects"), dict):
            self.objects = msg["objects"]
        self.dropped.update(msg.get("dropped", {}))
        self.sent = msg.get("sent", self.sent)

    def _event(self, ev: dict, prev: list | None) -> None:
        self.events.append(ev)
        if "failed" in ev and isinstance(ev.get("robot"), int):
            rid = ev["robot"]
            where = None
            if prev is not None:
                where = next((row[1:] for row in prev if row[0] == rid), None)
            if where is None:
                where = self._last_pos.get(rid) or self._start_pos.get(rid)
            self.dead[rid] = {"pos": where, "cause": ev["failed"], "t": ev.get("t")}
        elif "move" in ev and isinstance(ev["move"], dict):
            self.objects[ev["move"]["object"]] = list(ev["move"]["pos"])

    def copy(self) -> Scene:
        """An independent copy (for replay checkpoints); tick records are shared, never changed."""
        other = object.__new__(Scene)
        other.__dict__.update(self.__dict__)
        other.objects = dict(self.objects)
        other.ranges = dict(self.ranges)
        other.status = {k: dict(v) for k, v in self.status.items()}
        other.dead = dict(self.dead)
        other.events = list(self.events)
        other.dropped = dict(self.dropped)
        other.recent = deque(self.recent, maxlen=RECENT_TICKS)
        other._last_pos = dict(self._last_pos)
        return other

    # ------------------------------------------------------------ reading
    def frame(self, extra: dict | None = None) -> dict:
        """The document the page draws (JSON-able)."""
        self._decode_state()
        alive = {row[0] for row in self.pos}
        if not self.frames_available:  # events are best-effort here: a robot that vanished has failed
            for rid, where in self._last_pos.items():
                if rid not in alive and rid not in self.dead:
                    self.dead[rid] = {"pos": where, "cause": "failed", "t": None}
        for row in self.pos:
            self._last_pos[row[0]] = row[1:]
        dead = []
        for rid, d in sorted(self.dead.items()):
            if rid not in alive and d["pos"] is not None:
                dead.append([rid, d["pos"][0], d["pos"][1], d["cause"], d["t"]])
        robots = [[row[0], row[1], row[2], self.ranges.get(row[0], self.default_range), *row[3:4]]
                  for row in self.pos]  # [id, x, y, range(, z)]
        doc = {
            "type": "frame",
            "mode": self.mode,
            "run_id": self.run_id,
            "clock": self.clock,
            "t": self.t,
            "ticks": self.ticks,
            "bounds": self.bounds,
            "space": self.space is not None,  # the page fetches /api/space once
            "field": self.field,
            "robots": robots,
            "status": {str(rid): to_jsonable(self.status.get(rid, {})) for rid in sorted(alive)},
            "dead": dead,
            "objects": self.objects,
            "dropped": self.dropped,
            "sent": self.sent,
            "deliveries": self.deliveries if self.frames_available else None,
            "overheard": self.overheard if self.frames_available else None,
            "activity": self.activity(),
            "events": to_jsonable(self.events[-EVENTS_SHOWN:]),
            "frames_available": self.frames_available,
            "finished": self.finished,
        }
        if extra:
            doc.update(extra)
        return doc

    def activity(self) -> dict[str, int]:
        """Robot id -> frames it sent in the last ``ACTIVITY_TICKS`` ticks."""
        if self.t is None:
            return {}
        count: Counter = Counter()
        for rec in reversed(self.recent):
            if rec["t"] <= self.t - ACTIVITY_TICKS:
                break
            for row in rec.get("sent", ()):
                count[row[0]] += 1
        return {str(k): v for k, v in count.items()}

    def robot(self, rid: int) -> dict:
        """One robot's detail: status, failure, recent frames with the fate of each, log lines."""
        self._decode_state()
        where = next((row[1:] for row in self.pos if row[0] == rid), None)
        known = where is not None or rid in self.dead or rid in self.status
        out: dict[str, Any] = {
            "id": rid,
            "known": known,
            "t": self.t,
            "alive": where is not None,
            "pos": where if where is not None else (self.dead.get(rid) or {}).get("pos"),
            "range": self.ranges.get(rid, self.default_range),
            "status": to_jsonable(self.status.get(rid, {})),
            "failed": self.dead.get(rid),
            "frames_available": self.frames_available,
        }
        if self.frames_available:
            out.update(self._frames_of(rid))
        else:
            out["frames_note"] = ("the world's state stream carries no frames: watch the run from the world's "
                                  "process (swarmactors run --view) or replay its trace to see them")
        logs = self.logs.get(rid)
        if logs is None:
            out["log_note"] = ("robots' log lines reach the world with their final report: they show once the run "
                               "has ended (and in replays)")
            out["log"] = []
        else:
            out["log"] = [line for line in logs if self.t is None or _log_tick(line) <= self.t]
        return out

    def _frames_of(self, rid: int) -> dict:
        """Frames robot ``rid`` sent or was sent over the last ``RECENT_TICKS`` ticks, and what became of them."""
        kinds: dict[tuple[int, int], str] = {}
        sent: dict[tuple[int, int], dict] = {}
        received: list[dict] = []
        for rec in self.recent:
            t = rec["t"]
            for src, seq, kind, dst, size in rec.get("sent", ()):
                kinds[(src, seq)] = kind
                if src == rid:
                    sent[(src, seq)] = {"t": t, "seq": seq, "kind": kind, "dst": dst, "size": size,
                                        "delivered": [], "overheard": [], "dropped": []}
            for src, seq, dst, sent_tick in rec.get("del", ()):
                if (src, seq) in sent:
                    sent[(src, seq)]["delivered"].append([dst, t])
                if dst == rid:
                    received.append({"t": t, "src": src, "seq": seq, "kind": kinds.get((src, seq)),
                                     "sent": sent_tick, "fate": "delivered"})
            for src, seq, dst, sent_tick in rec.get("ovh", ()):
                if (src, seq) in sent:
                    sent[(src, seq)]["overheard"].append([dst, t])
                if dst == rid:
                    received.append({"t": t, "src": src, "seq": seq, "kind": kinds.get((src, seq)),
                                     "sent": sent_tick, "fate": "overheard (excluded: discarded)"})
            for src, seq, dst, cause in rec.get("drop", ()):
                if (src, seq) in sent:
                    sent[(src, seq)]["dropped"].append([dst, cause, t])
                if dst == rid:
                    received.append({"t": t, "src": src, "seq": seq, "kind": kinds.get((src, seq)),
                                     "fate": f"dropped: {cause}"})
        return {"sent": list(sent.values())[-30:], "received": received[-30:],
                "window": [self.recent[0]["t"] if self.recent else None, self.t]}

    def control_events(self) -> list[dict]:
        """Events applied through the world's ``control`` queryable, in order."""
        return [ev for ev in self.events if ev.get("source") == "control"]


def _log_tick(line: str) -> int:
    m = _LOG_TICK.match(line)
    return int(m.group(1)) if m else -1


def _plot_field(sc: dict) -> str | None:
    """The status field that colours robots: the first behaviour's ``plot_field`` (None if unknown)."""
    if not sc:
        return None
    from swarmactors.robot.plugins import BEHAVIORS, PluginError, resolve

    for g in sc.get("robots", []):
        for b in g.get("behaviors", []):
            try:
                field = getattr(resolve(BEHAVIORS, b["use"]), "plot_field", None)
            except PluginError:
                continue
            if field:
                return field
    return None


# ---------------------------------------------------------------- [[events]] export
_EXPORTED = ("kill", "cut", "restore", "partition", "heal", "loss", "move", "stop")


def events_toml(events: list[dict], run_id: str = "") -> str:
    """``[[events]]`` tables reproducing control actions (as recorded by the world, with their tick), by tomli_w."""
    lines = [f"# Actions applied through the control queryable{f' during run {run_id}' if run_id else ''}.",
             "# Paste into the scenario to make the run reproducible without the viewer."]
    tables = []
    for ev in events:
        action = next((k for k in _EXPORTED if k in ev), None)
        if action is not None:
            tables.append({"at": int(ev["t"]), action: ev[action]})
        elif "added" in ev:
            lines.append(f"# at tick {ev.get('t')}: robots {ev['added']} were added by control "
                         "(their specs are not recorded: write an [[events]] add table by hand)")
    if not tables:
        return "\n".join([*lines, "# (no action to export yet)"]) + "\n"
    return "\n".join(lines) + "\n\n" + tomli_w.dumps({"events": tables})
