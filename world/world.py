"""The world process: registry, clock, kinematics, radio, faults, streams.

The world is the authority on every robot's true state and the only place
where range, latency and loss are decided. It never decodes a frame body and
never imports a protocol. ``World.run`` drives one of the two clocks
(``lockstep`` or ``realtime``); the order of one tick is fixed in
``_begin_tick`` and ``_end_tick``:

1. apply the events due at this tick (scenario ``[[events]]`` and ``control``);
2. compute radio reach and sensing from the positions at this tick;
3. hand every host its robots' poses, sensing and the frames due now;
4. (the robots step;) collect velocity commands, status and outgoing frames;
5. the radio decides each frame's receivers from this tick's positions;
   lockstep deliveries fall due ``latency`` ticks later;
6. record what happened (trace sinks, ``state`` stream);
7. integrate motion to the next tick's positions.

In lockstep a host's step is a Zenoh query on ``up/{host}`` carrying its
outputs of the previous tick; the world answers it with the next tick's
inputs only once every live host is in. No input can be lost to a start-up
race, and the query itself is the barrier.
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field
from operator import itemgetter
from typing import Any, Protocol

import numpy as np

from transport import Keys, Link, MalformedMessage, PendingQuery, new_key, pack, unpack, unseal
from world import rng
from world.kinematics import integrate
from world.radio import DROP_CAUSES, Medium, Outgoing, RadioConfig
from world.registry import HostEntry, Robots
from world.sensing import sense, within

log = logging.getLogger(__name__)

_NOTHING: list = [[], []]
_INT64 = 1 << 63
RT_BUCKET_S = 0.0005  # realtime deliveries due within the same half millisecond share one timer
ACTIONS = ("kill", "kill_fraction", "add", "cut", "restore", "partition", "heal", "loss", "move", "stop")
_BY_DST_SRC_SEQ = itemgetter(0, 1, 2)
POS_DIGITS = 6  # positions in traces, state and hashes are rounded to 1e-6 length units
PROTOCOL_VERSION = 1


class Sink(Protocol):
    """Receives one record per tick (the trace writer is one)."""

    def record(self, rec: dict) -> None: ...


@dataclass
class Counters:
    sent: int = 0
    delivered: int = 0
    dropped: dict[str, int] = field(default_factory=lambda: {c: 0 for c in DROP_CAUSES})
    sent_by: dict[int, int] = field(default_factory=lambda: defaultdict(int))
    received_by: dict[int, int] = field(default_factory=lambda: defaultdict(int))
    dropped_by: dict[int, dict[str, int]] = field(default_factory=lambda: defaultdict(lambda: defaultdict(int)))
    malformed: list[str] = field(default_factory=list)  # first reasons, for the result

    def drop(self, src: int | None, cause: str, n: int = 1) -> None:
        self.dropped[cause] += n
        if src is not None and src >= 0:
            self.dropped_by[src][cause] += n

    def as_dict(self) -> dict:
        return {
            "frames_sent": self.sent,
            "deliveries": self.delivered,
            "dropped": dict(self.dropped),
            "dropped_total": sum(self.dropped.values()),
            "malformed_examples": self.malformed[:20],
        }


class World:
    """One run's world. Create, then ``await run()``; the summary is in ``summary()``."""

    def __init__(
        self,
        spec: dict,
        link: Link,
        keys: Keys,
        sinks: list[Sink] = (),
        on_tick: Callable[[World], None] | None = None,
    ):
        run = spec["run"]
        self.spec = spec
        self.link = link
        self.keys = keys
        self.sinks = list(sinks)
        self.on_tick = on_tick
        self.clock = run.get("clock", "lockstep")
        self.seed = int(run.get("seed", 0))
        self.ticks = int(run["ticks"])
        self.dt = float(run.get("dt", 1.0))
        self.watchdog_s = float(run.get("watchdog_s", 10.0))
        self.join_timeout_s = float(run.get("join_timeout_s", 60.0))
        self.state_every = int(run.get("state_every", 1))
        wspec = spec.get("world", {})
        self.dims = int(wspec.get("dims", 2))
        b = wspec.get("bounds")
        self.bounds = np.array(b, dtype=float) if b else None
        self.objects: dict[str, list[float]] = {
            o["name"]: list(map(float, o["pos"])) for o in wspec.get("objects", [])
        }
        self.radio = RadioConfig.from_dict(spec.get("radio", {}))
        self.medium = Medium(self.radio, self.seed)
        self.robots = Robots(self.dims)
        self.robots.add(spec["robots"], tick=0)
        self.unclaimed: list[int] = list(range(len(self.robots)))
        self.hosts: dict[str, HostEntry] = {}
        self.counters = Counters()
        self.events = sorted(spec.get("events", []), key=lambda e: e["at"])
        self._event_idx = 0
        self.control_queue: list[dict] = []
        self.tick = 0
        self.ticks_done = 0
        self.started = False
        self.finished = False
        self.stop_reason: str | None = None
        self.wall_s = 0.0
        self.epoch = 0.0
        self.reports: dict[int, dict] = {}
        # lockstep: frames in the air, by due tick; held step queries, by host
        self._due: dict[int, list[tuple[int, Outgoing, int]]] = defaultdict(list)
        self._held: dict[str, tuple[int, PendingQuery, dict]] = {}
        self._barrier = asyncio.Event()
        self._awaited_tick = -1
        self._pending_new: dict[str, list[dict]] = defaultdict(list)
        self._pending_dead: dict[str, list[int]] = defaultdict(list)
        self._ready = asyncio.Event()
        self._resume = asyncio.Event()
        self._resume.set()
        self._pause_at: int | None = None
        self._stop_event = asyncio.Event()
        self._final_reports = asyncio.Event()
        self._rt_deliveries: dict[str, list] = defaultdict(list)
        self._rt_buckets: dict[int, list] = {}
        self._rt_flush_scheduled: set[str] = set()
        # per-tick record being built
        self._rec: dict[str, Any] = {}
        self._reach: dict[int, np.ndarray] = {}
        self._sensed: dict[int, list] = {}
        self._poses: list[list[float]] = []
        self._seq_seen: dict[int, int] = {}

    # ------------------------------------------------------------ set-up
    def open(self) -> None:
        """Declare the world's queryables, subscribers and liveliness watch."""
        self.link.serve(self.keys.join, self._on_join)
        self.link.serve(self.keys.control, self._on_control)
        self.link.serve(self.keys.up_all, self._on_step_query)
        self.link.subscribe(self.keys.up_all, self._on_up_put)
        self.link.watch_liveliness(self.keys.alive_all, self._on_liveliness)

    # ------------------------------------------------------------ join
    def _on_join(self, q: PendingQuery) -> None:
        try:
            req = unpack(q.payload, what="join request") if q.payload else {}
            if not isinstance(req, dict):
                raise MalformedMessage("join request is not a map")
            count = req.get("count")
            if count is not None and (not isinstance(count, int) or isinstance(count, bool) or count < 1):
                raise MalformedMessage(f"join count {count!r} is not a positive integer")
        except MalformedMessage as exc:
            self._malformed(None, str(exc))
            q.reply_error(str(exc))
            return
        if self.finished:
            q.reply_error("the run has finished")
            return
        name = f"h{len(self.hosts)}"
        host = HostEntry(name, key=new_key())
        if not self.started:
            take = len(self.unclaimed) if count is None else min(count, len(self.unclaimed))
            ids, self.unclaimed = self.unclaimed[:take], self.unclaimed[take:]
        else:
            template = dict(self.spec["robots"][0]) if self.spec["robots"] else {}
            specs = [self._placed_like(template) for _ in range(count or 1)]
            ids = self._add_robots(specs, source="join")
        for rid in ids:
            self.robots.host[rid] = name
            host.robots.add(rid)
        self.hosts[name] = host
        log.info("host %s joined with robots %s", name, ids)
        q.reply(
            pack(
                {
                    "host": name,
                    "key": host.key,
                    "version": PROTOCOL_VERSION,
                    "robots": [self._robot_descr(r) for r in ids],
                    "run": {
                        "clock": self.clock,
                        "dt": self.dt,
                        "seed": self.seed,
                        "ticks": self.ticks,
                        "watchdog_s": self.watchdog_s,
                        "tick": self.tick,
                    },
                }
            )
        )
        self._check_ready()

    def _robot_descr(self, rid: int) -> dict:
        s = self.robots.spec[rid]
        return {
            "id": rid,
            "pose": self.robots.pose(rid, POS_DIGITS),
            "behaviors": s.get("behaviors", []),
            "kind": s.get("kind", "ground"),
            "range": float(self.robots.range[rid]),
            "sensing": float(self.robots.sensing[rid]),
            "speed": float(self.robots.speed[rid]),
        }

    def _placed_like(self, template: dict) -> dict:
        """A robot spec for a host joining mid-run: template parameters, random position in bounds."""
        n = len(self.robots)
        lo, hi = (self.bounds if self.bounds is not None else np.array([[0.0] * self.dims, [1.0] * self.dims]))
        u = rng.uniform(self.seed, rng.PLACEMENT, self.tick, n, np.arange(self.dims))
        return {k: v for k, v in template.items() if k != "pos"} | {"pos": list(lo + u * (hi - lo))}

    def _check_ready(self) -> None:
        if not self.unclaimed and all(h in self._held for h in self._live_hosts()):
            self._ready.set()

    # ------------------------------------------------------------ uplink
    def _on_step_query(self, q: PendingQuery) -> None:
        host = self.keys.host_of(q.key)
        entry = self.hosts.get(host)
        if entry is not None and not entry.alive:
            q.reply(pack({"stop": True, "t": self.tick, "in": [], "gone": True}))
            return
        msg = self._decode_up(host, q.payload)
        if msg is None:
            q.reply_error("malformed or unauthenticated step")
            return
        if self.clock == "realtime":
            if msg.get("rep") is not None:
                self._take_reports(host, msg["rep"])
            self._absorb(host, msg)
            q.reply(pack({"ok": True, "epoch": self.epoch}))
            if msg["t"] == -1:
                self._held[host] = (-1, None, {})
                self._check_ready()
            return
        if host in self._held:  # one step per host per tick: a second one is a replay or a forgery
            self._malformed(None, f"second step from {host} while one is pending (tick {msg['t']})")
            q.reply_error("a step from this host is already pending")
            return
        if msg.get("rep") is not None:
            self._take_reports(host, msg["rep"])
        self._held[host] = (msg["t"], q, msg)
        if not self.started:
            self._check_ready()
        elif self._all_in():
            self._barrier.set()

    def _on_up_put(self, key: str, payload: bytes) -> None:
        host = self.keys.host_of(key)
        entry = self.hosts.get(host)
        if entry is not None and not entry.alive:
            return
        msg = self._decode_up(host, payload)
        if msg is None:
            return
        if self.clock != "realtime":
            self._malformed(None, f"put on up/{host} in lockstep (steps must be queries)")
            return
        if msg.get("rep") is not None:
            self._take_reports(host, msg["rep"])
        self._absorb(host, msg)

    def _decode_up(self, host: str, payload: bytes) -> dict | None:
        """Verify (per-host key) and decode an uplink; count and return None when it is bad."""
        try:
            entry = self.hosts.get(host)
            if entry is None:
                raise MalformedMessage(f"uplink on up/{host}: no such host joined")
            msg = unpack(unseal(entry.key, payload, what=f"uplink on up/{host}"), what=f"uplink from {host}")
            if not isinstance(msg, dict):
                raise MalformedMessage(f"uplink from {host} is not a map")
            if msg.get("h") != host:
                raise MalformedMessage(f"uplink on up/{host} claims host {msg.get('h')!r}")
            t = msg.get("t")
            if type(t) is not int:
                raise MalformedMessage(f"uplink from {host} has tick {t!r}")
            if not isinstance(msg.get("r", []), list):
                raise MalformedMessage(f"uplink from {host} has a non-list robot section")
            return msg
        except MalformedMessage as exc:
            self._malformed(None, str(exc))
            return None

    def _malformed(self, src: int | None, reason: str) -> None:
        self.counters.drop(src, "malformed")
        if len(self.counters.malformed) < 100:
            self.counters.malformed.append(reason)
        self._rec.setdefault("mal", []).append(reason)
        log.warning("malformed: %s", reason)

    def _absorb(self, host: str, msg: dict) -> None:
        """Take a host's per-robot outputs: velocity, status, errors, frames."""
        owned = self.hosts[host].robots
        frames: list[Outgoing] = []
        for entry in msg.get("r", []):
            if not (isinstance(entry, list) and len(entry) == 5 and type(entry[0]) is int
                    and isinstance(entry[2], list)):
                self._malformed(None, f"robot record from {host} is not [id, vel, [frames], status, error]")
                continue
            rid, vel, out, status, err = entry
            if rid not in owned:
                self._malformed(rid if 0 <= rid < len(self.robots) else None,
                                f"host {host} sent for robot {rid}, which it does not run")
                continue
            if not self.robots.alive[rid]:
                continue
            if err is not None:
                self._crash(rid, "crashed" if not str(err).startswith("watchdog") else "watchdog", str(err))
                continue
            if vel is not None:
                self._set_velocity(rid, vel)
            if status:
                if isinstance(status, dict) and all(type(k) is str for k in status):
                    self.robots.status[rid].update(status)
                    self._rec.setdefault("status", {})[rid] = status
                else:
                    self._malformed(rid, f"status of robot {rid} is not a map with string keys")
            for f in out:
                frame = self._check_frame(rid, f)
                if frame is not None:
                    frames.append(frame)
        if frames:
            self._transmit(frames)

    def _set_velocity(self, rid: int, vel: Any) -> None:
        if (
            isinstance(vel, list)
            and 1 <= len(vel) <= self.dims
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in vel)
        ):
            v = np.zeros(self.dims)
            v[: len(vel)] = vel
            self.robots.vel[rid] = v
        else:
            self._malformed(rid, f"velocity of robot {rid} is {vel!r}")

    def _check_frame(self, src: int, f: Any) -> Outgoing | None:
        """Validate a frame header ``[dst, kind, seq, body, exclude]`` from robot ``src``."""
        if not (isinstance(f, list) and len(f) == 5):
            self._malformed(src, f"frame from robot {src} is not [dst, kind, seq, body, exclude]")
            return None
        dst, kind, seq, body, exclude = f
        ok = (
            (dst is None or (type(dst) is int and 0 <= dst < _INT64))
            and isinstance(kind, str)
            and 0 < len(kind) <= 64
            and type(seq) is int
            and self._seq_seen.get(src, -1) < seq < _INT64
            and isinstance(body, bytes)
            and isinstance(exclude, list)
            and all(type(x) is int and 0 <= x < _INT64 for x in exclude)
        )
        if not ok:
            self._malformed(src, f"bad frame header from robot {src}: dst={dst!r} kind={kind!r} seq={seq!r}")
            return None
        self._seq_seen[src] = seq
        return Outgoing(src, dst, kind, seq, body, tuple(exclude))

    def _take_reports(self, host: str, reports: Any) -> None:
        if not isinstance(reports, dict):
            self._malformed(None, f"reports from {host} are not a map")
            return
        for rid, rep in reports.items():
            if isinstance(rid, int) and rid in self.hosts[host].robots:
                self.reports[rid] = rep
        self.hosts[host].reported = True
        self._check_reports_in()

    # ------------------------------------------------------------ radio
    def _transmit(self, frames: list[Outgoing]) -> None:
        """Decide receivers for frames sent now (from this tick's positions)."""
        reach = self._reach
        deliveries, drops = self.medium.decide(
            self.tick, frames, reach, self.robots.alive, self.robots.pos, self.robots.range
        )
        c = self.counters
        sent = self._rec.setdefault("sent", [])
        for f in frames:
            c.sent += 1
            c.sent_by[f.src] += 1
            sent.append([f.src, f.seq, f.kind, f.dst, len(f.body)])
        if drops:
            rec_drops = self._rec.setdefault("drop", [])
            for src, seq, dst, kind, cause in drops:
                c.drop(src, cause)
                rec_drops.append([src, seq, dst, cause])
        if self.clock == "lockstep":
            self._due[self.tick + self.radio.latency].extend(deliveries)
        else:
            self._schedule_realtime(deliveries)

    def _deliver_due(self, tick: int) -> dict[int, list]:
        """Lockstep: each robot's inbox of tick ``tick`` as (frame, send tick), ordered by (src, seq)."""
        inbox: dict[int, list] = defaultdict(list)
        due = self._due.pop(tick, [])
        due.sort(key=_BY_DST_SRC_SEQ)
        alive = self.robots.alive.tolist()
        rec_del = self._rec.setdefault("del", [])
        dead: list = []
        for d in due:
            if alive[d[0]]:
                inbox[d[0]].append((d[3], d[4]))
                rec_del.append([d[1], d[2], d[0], d[4]])
            else:
                dead.append(d)
        c = self.counters
        for dst, src, seq, _, _ in dead:
            c.drop(src, "dead")
            self._rec.setdefault("drop", []).append([src, seq, dst, "dead"])
        for dst, frames in inbox.items():
            c.received_by[dst] += len(frames)
        c.delivered += len(rec_del)
        return inbox

    def _schedule_realtime(self, deliveries: list[tuple[int, Outgoing]]) -> None:
        loop = asyncio.get_running_loop()
        by_frame: dict[int, list[int]] = defaultdict(list)
        frames: dict[int, Outgoing] = {}
        for dst, _, _, f, _ in deliveries:
            by_frame[id(f)].append(dst)
            frames[id(f)] = f
        sent_at = time.time() - self.epoch
        now = loop.time()
        for key, dsts in by_frame.items():
            f = frames[key]
            lat = self.medium.latencies_s(self.tick, f.src, f.seq, np.array(dsts))
            for dst, delay in zip(dsts, lat.tolist()):
                # One timer per bucket of RT_BUCKET_S; a bucket fires at its end, so never before c_min.
                bucket = math.ceil((now + delay) / RT_BUCKET_S)
                due = self._rt_buckets.get(bucket)
                if due is None:
                    due = self._rt_buckets[bucket] = []
                    loop.call_at(bucket * RT_BUCKET_S, self._rt_fire, bucket)
                due.append((dst, f, sent_at, self.tick))

    def _rt_fire(self, bucket: int) -> None:
        for delivery in self._rt_buckets.pop(bucket, ()):
            self._rt_deliver(*delivery)

    def _rt_deliver(self, dst: int, f: Outgoing, sent_at: float, sent_tick: int) -> None:
        if self.finished:
            return
        if not self.robots.alive[dst]:
            self.counters.drop(f.src, "dead")
            self._rec.setdefault("drop", []).append([f.src, f.seq, dst, "dead"])
            return
        host = self.robots.host[dst]
        if host is None:
            return
        self.counters.delivered += 1
        self.counters.received_by[dst] += 1
        self._rec.setdefault("del", []).append([f.src, f.seq, dst, sent_tick])
        self._rt_deliveries[host].append([dst, f.src, f.kind, f.seq, f.body, sent_at])
        if host not in self._rt_flush_scheduled:
            self._rt_flush_scheduled.add(host)
            asyncio.get_running_loop().call_soon(self._rt_flush, host)

    def _rt_flush(self, host: str) -> None:
        self._rt_flush_scheduled.discard(host)
        batch = self._rt_deliveries.pop(host, [])
        if batch and self.hosts.get(host) and self.hosts[host].alive:
            self.link.publish(self.keys.down(host), pack({"d": batch}))

    # ------------------------------------------------------------ faults
    def _crash(self, rid: int, cause: str, error: str | None = None) -> None:
        if self.robots.kill(rid, self.tick, cause, error):
            ev = {"robot": rid, "failed": cause}
            if error:
                ev["error"] = error
            self._event(ev)
            host = self.robots.host[rid]
            if host:
                self._pending_dead[host].append(rid)

    def _event(self, ev: dict) -> None:
        ev = {"t": self.tick, **ev}
        self._rec.setdefault("ev", []).append(ev)
        self.link.publish(self.keys.events, pack(ev), reliable=False)

    def _add_robots(self, specs: list[dict], source: str) -> list[int]:
        ids = self.robots.add(specs, tick=self.tick)
        self._event({"added": ids, "source": source})
        return ids

    def apply(self, action: dict, source: str) -> str | None:
        """Apply one scenario event or control command now; return an error text or None."""
        problem = self.check_action(action)
        if problem:
            return problem
        if "kill" in action:
            ids = action["kill"]
            ids = [ids] if type(ids) is int else ids
            self._event({"kill": ids, "source": source})
            for rid in ids:
                self._crash(rid, "killed")
        elif "kill_fraction" in action:
            alive = self.robots.alive_ids()
            k = int(round(float(action["kill_fraction"]) * len(alive)))
            order = np.argsort(rng.uniform(self.seed, rng.PLACEMENT, self.tick, -1, alive), kind="stable")
            ids = sorted(alive[order[:k]].tolist())
            self._event({"kill": ids, "source": source})
            for rid in ids:
                self._crash(rid, "killed")
        elif "add" in action:
            ids = self._add_robots(action["add"], source)
            for rid in ids:
                host = self._least_loaded_host()
                if host is None:
                    self.robots.kill(rid, self.tick, "no-host")
                    continue
                self.robots.host[rid] = host
                self.hosts[host].robots.add(rid)
                self._pending_new[host].append(self._robot_descr(rid))
        elif "cut" in action or "restore" in action:
            verb = "cut" if "cut" in action else "restore"
            pairs = action[verb]
            for a, b in pairs:
                (self.medium.cut if verb == "cut" else self.medium.restore)(a, b)
            self._event({verb: pairs, "source": source})
        elif "partition" in action:
            self.medium.partition(action["partition"])
            self._event({"partition": action["partition"], "source": source})
        elif "heal" in action:
            self.medium.heal()
            self._event({"heal": True, "source": source})
        elif "loss" in action:
            p = action["loss"]
            self.medium.set_loss(float(p))
            self._event({"loss": float(p), "source": source})
        elif "move" in action:
            mv = action["move"]
            name = mv["object"]
            self.objects[name] = list(map(float, mv["pos"]))
            self._event({"move": {"object": name, "pos": self.objects[name]}, "source": source})
        elif "stop" in action:
            self.request_stop(f"stopped by {source}")
        return None
    def check_action(self, action: dict) -> str | None:
        """Why ``action`` (one event or control command) cannot be applied now, or None."""
        if len(action) != 1 or next(iter(action)) not in ACTIONS:
            return f"unknown command {sorted(action)} (known: {', '.join(ACTIONS)})"
        ((name, value),) = action.items()
        n = len(self.robots)

        def robot_id(x) -> bool:
            return type(x) is int and 0 <= x < n

        def probability(x) -> bool:
            return type(x) in (int, float) and 0.0 <= x <= 1.0

        def point(p) -> bool:
            return (isinstance(p, list) and 1 <= len(p) <= self.dims
                    and all(type(v) in (int, float) and math.isfinite(v) for v in p))

        if name == "kill":
            ids = [value] if type(value) is int else value
            if not (isinstance(ids, list) and ids and all(robot_id(i) for i in ids)):
                return f"kill: {value!r} is not a robot id or a list of robot ids (0..{n - 1})"
        elif name in ("kill_fraction", "loss") and not probability(value):
            return f"{name}: {value!r} is not in [0, 1]"
        elif name == "add" and not (isinstance(value, list) and value and all(
                isinstance(s, dict) and point(s.get("pos")) for s in value)):
            return "add: expected a list of robot specs, each with pos = [x, y]"
        elif name in ("cut", "restore") and not (isinstance(value, list) and all(
                isinstance(p, list) and len(p) == 2 and all(robot_id(i) for i in p) for p in value)):
            return f"{name}: expected a list of [a, b] robot id pairs"
        elif name == "partition" and not (isinstance(value, list) and all(
                isinstance(g, list) and all(robot_id(i) for i in g) for g in value)):
            return "partition: expected a list of lists of robot ids"
        elif name == "move" and not (isinstance(value, dict) and value.get("object") in self.objects
                                     and point(value.get("pos"))):
            return f"move: expected {{object, pos}} with object one of {sorted(self.objects)}"
        return None


    def _least_loaded_host(self) -> str | None:
        live = [h for h in self._live_hosts_entries()]
        if not live:
            return None
        return min(live, key=lambda h: (len(h.robots), int(h.name[1:]))).name

    def _apply_due_events(self) -> None:
        while self._event_idx < len(self.events) and self.events[self._event_idx]["at"] <= self.tick:
            ev = {k: v for k, v in self.events[self._event_idx].items() if k != "at"}
            self._event_idx += 1
            err = self.apply(ev, "scenario")
            if err:
                log.error("scenario event at tick %d: %s", self.tick, err)
        queued, self.control_queue = self.control_queue, []
        for action in queued:
            self.apply(action, "control")

    def _on_liveliness(self, key: str, alive: bool) -> None:
        host = self.keys.host_of(key)
        entry = self.hosts.get(host)
        if alive or entry is None or not entry.alive or entry.reported or self.finished:
            return  # a host that delivered its final report may leave
        self._lose_host(host, "host-lost")

    def _lose_host(self, host: str, cause: str) -> None:
        entry = self.hosts[host]
        entry.alive = False
        self._event({"host_lost": host, "cause": cause})
        for rid in sorted(entry.robots):
            self._crash(rid, cause)
        self._held.pop(host, None)
        if self.started and self._all_in():
            self._barrier.set()
        self._check_reports_in()

    def _check_reports_in(self) -> None:
        if all(h.reported for h in self._live_hosts_entries()):
            self._final_reports.set()

    # ------------------------------------------------------------ control
    def _on_control(self, q: PendingQuery) -> None:
        """Answer one control command; a bad one is refused, counted, and changes nothing."""
        try:
            cmd = unpack(q.payload, what="control command")
            if not isinstance(cmd, dict) or not isinstance(cmd.get("cmd"), str):
                raise MalformedMessage("control command must be a map with a 'cmd' string")
            answer = self._control(cmd["cmd"], cmd)
        except (MalformedMessage, ValueError, TypeError) as exc:
            self._malformed(None, f"control: {exc}")
            answer = {"ok": False, "error": str(exc)}
        q.reply(pack(answer))

    def _control(self, name: str, cmd: dict) -> dict:
        if name == "status":
            return {"ok": True, **self.status()}
        if name == "stop":
            self.request_stop("stopped by control")
            return {"ok": True}
        if name in ("pause", "resume", "step", "run_to"):
            if self.clock != "lockstep":
                raise ValueError(f"{name} needs the lockstep clock (this run is {self.clock})")
            if name == "pause":
                self._resume.clear()
                return {"ok": True, "tick": self.tick}
            if name == "resume":
                self._pause_at = None
                self._resume.set()
                return {"ok": True, "tick": self.tick}
            target = self.tick + 1 if name == "step" else cmd.get("tick")
            if type(target) is not int or target < 0:
                raise ValueError(f"run_to: tick {target!r} is not a non-negative integer")
            self._pause_at = target
            self._resume.set()
            return {"ok": True, "until": target}
        action = {name: cmd.get("args", True)}
        problem = self.check_action(action)
        if problem:
            raise ValueError(problem)
        self.control_queue.append(action)
        return {"ok": True, "at": self.tick + 1 if self.started else 0}

    def status(self) -> dict:
        return {
            "run_id": self.keys.run_id,
            "clock": self.clock,
            "tick": self.tick,
            "ticks": self.ticks,
            "started": self.started,
            "finished": self.finished,
            "paused": not self._resume.is_set(),
            "robots": len(self.robots),
            "alive": int(self.robots.alive.sum()),
            "hosts": {h.name: sorted(h.robots) for h in self.hosts.values() if h.alive},
            "unclaimed": len(self.unclaimed),
            "objects": self.objects,
            **self.counters.as_dict(),
        }

    def request_stop(self, reason: str) -> None:
        """Finish the current tick, then end the run (also used for SIGINT)."""
        if self.stop_reason is None:
            self.stop_reason = reason
        self._stop_event.set()
        self._resume.set()
        self._barrier.set()
        self._ready.set()

    # ------------------------------------------------------------ the tick
    def _begin_tick(self) -> None:
        """Steps 1-2: events, then reach and sensing from this tick's positions.

        What happened between two ticks (malformed input, hosts lost) was
        collected in ``_rec`` already and goes into this tick's record.
        """
        self._rec["t"] = self.tick
        self._apply_due_events()
        alive = self.robots.alive_ids()
        self._reach = within(self.robots.pos, alive, self.robots.range)
        if np.array_equal(self.robots.sensing, self.robots.range):
            sensed_ids = self._reach
        else:
            sensed_ids = within(self.robots.pos, alive, self.robots.sensing)
        self._sensed = sense(self.robots.pos, sensed_ids, self.robots.noise, self.seed, self.tick, POS_DIGITS)
        r = self.robots
        self._poses = np.round(np.hstack([r.pos, r.heading[:, None]]), POS_DIGITS).tolist()

    def _inputs_for(self, host: str, inbox: dict[int, list] | None) -> dict:
        """Step 3: one host's inputs for this tick.

        Each frame body travels once per host (``frames``), however many of the
        host's robots receive it; a robot's inbox lists indices into that table.
        """
        entry = self.hosts[host]
        rows = []
        table: list[list] = []
        index: dict[int, int] = {}
        poses = self._poses
        for rid in sorted(entry.robots):
            if not self.robots.alive[rid]:
                continue
            refs = []
            for f, sent_tick in (inbox.get(rid, ()) if inbox is not None else ()):
                k = index.get(id(f))
                if k is None:
                    k = index[id(f)] = len(table)
                    table.append([f.src, f.kind, f.seq, f.body, sent_tick])
                refs.append(k)
            rows.append([rid, poses[rid], self._sensed.get(rid, _NOTHING), refs])
        msg = {"t": self.tick, "now": self._now(), "in": rows, "frames": table, "objects": self.objects}
        if self.clock == "realtime":
            msg["epoch"] = self.epoch
        if self._pending_dead.get(host):
            msg["dead"] = self._pending_dead.pop(host)
        if self._pending_new.get(host):
            msg["new"] = self._pending_new.pop(host)
        return msg

    def _now(self) -> float:
        return float(self.tick) if self.clock == "lockstep" else time.time() - self.epoch

    def _end_tick(self) -> None:
        """Steps 6-7: record, publish state, integrate motion."""
        alive = self.robots.alive_ids()
        self._rec["pos"] = [
            [rid, *row] for rid, row in zip(alive.tolist(), np.round(self.robots.pos[alive], POS_DIGITS).tolist())
        ]
        rec, self._rec = self._rec, {}
        self.ticks_done = self.tick + 1
        for sink in self.sinks:
            sink.record(rec)
        if self.state_every and self.tick % self.state_every == 0:
            self.link.publish(
                self.keys.state,
                pack({"t": self.tick, "pos": rec["pos"], "status": {int(r): self.robots.status[r] for r in alive},
                      "ranges": self.robots.range[alive].round(POS_DIGITS).tolist(), "objects": self.objects,
                      "dropped": dict(self.counters.dropped), "sent": self.counters.sent}),
                reliable=False,
            )
        if self.on_tick:
            self.on_tick(self)
        integrate(
            self.robots.pos, self.robots.heading, self.robots.vel, self.robots.speed,
            self.robots.turn_rate, self.robots.alive, self.dt, self.bounds,
        )

    # ------------------------------------------------------------ clocks
    def _live_hosts_entries(self) -> list[HostEntry]:
        return [h for h in self.hosts.values() if h.alive]

    def _live_hosts(self) -> list[str]:
        return [h.name for h in self._live_hosts_entries()]

    def _all_in(self) -> bool:
        """Every live host has a step pending for the awaited tick (or has just joined: tick -1)."""
        return all(
            h in self._held and (self._held[h][0] >= self._awaited_tick or self._held[h][0] == -1)
            for h in self._live_hosts()
        )

    async def _wait_ready(self) -> None:
        try:
            await asyncio.wait_for(self._ready.wait(), self.join_timeout_s)
        except TimeoutError:
            raise RuntimeError(
                f"{len(self.unclaimed)} robot(s) were not claimed by any host within "
                f"{self.join_timeout_s:.0f} s (robot hosts must join {self.keys.join})"
            ) from None

    async def run(self) -> None:
        """Run the clock to the end (or until stopped)."""
        await self._wait_ready()
        self.started = True
        self.epoch = time.time()
        t0 = time.perf_counter()
        try:
            if self.clock == "lockstep":
                await self._run_lockstep()
            else:
                await self._run_realtime()
        finally:
            self.wall_s = time.perf_counter() - t0
            await self._collect_reports()
            self.finished = True

    async def _run_lockstep(self) -> None:
        for k in range(self.ticks):
            if self._stop_event.is_set():
                break
            if self._pause_at is not None and k >= self._pause_at:
                self._resume.clear()
                self._pause_at = None
            await self._resume.wait()
            if self._stop_event.is_set():
                break
            self.tick = k
            self._begin_tick()
            inbox = self._deliver_due(k)
            self._awaited_tick = k
            self._barrier.clear()
            for host in self._live_hosts():
                _, q, _ = self._held.pop(host)
                if q is not None:
                    q.reply(pack(self._inputs_for(host, inbox)))
            await self._await_barrier()
            for host in sorted(self._live_hosts()):
                t, _, msg = self._held.get(host, (None, None, None))
                if t == k:
                    self._absorb(host, msg)
            self._end_tick()

    async def _await_barrier(self) -> None:
        """Wait for every live host's step; a host silent past the watchdog loses its robots."""
        limit = 2 * self.watchdog_s + 5.0
        if self._all_in():
            return
        try:
            await asyncio.wait_for(self._barrier.wait(), limit)
        except TimeoutError:
            for host in self._live_hosts():
                if host not in self._held:
                    log.error("host %s did not finish tick %d within %.1f s", host, self.tick, limit)
                    self._lose_host(host, "watchdog")

    async def _run_realtime(self) -> None:
        loop = asyncio.get_running_loop()
        start = loop.time()
        for k in range(self.ticks):
            if self._stop_event.is_set():
                break
            self.tick = k
            self._begin_tick()
            for host in self._live_hosts():
                self.link.publish(self.keys.down(host), pack(self._inputs_for(host, None)))
            delay = start + (k + 1) * self.dt - loop.time()
            if delay > 0:
                try:
                    await asyncio.wait_for(self._stop_event.wait(), delay)
                except TimeoutError:
                    pass
            self._end_tick()

    async def _collect_reports(self) -> None:
        """Tell every live host to stop and wait (bounded) for its robots' reports."""
        stop = pack({"stop": True, "t": self.tick, "in": []})
        self._check_reports_in()
        if self.clock == "lockstep":
            self._awaited_tick = self.tick
            for host in self._live_hosts():
                held = self._held.pop(host, None)
                if held is not None and held[1] is not None:
                    held[1].reply(stop)
            try:
                await asyncio.wait_for(self._final_reports.wait(), self.watchdog_s + 5.0)
            except TimeoutError:
                log.warning("some hosts sent no final report")
            for host in list(self._held):
                _, q, _ = self._held.pop(host)
                if q is not None:
                    q.reply(pack({"bye": True}))
        else:
            for host in self._live_hosts():
                self.link.publish(self.keys.down(host), stop)
            try:
                await asyncio.wait_for(self._final_reports.wait(), self.watchdog_s + 5.0)
            except TimeoutError:
                log.warning("some hosts sent no final report")

    # ------------------------------------------------------------ summary
    def summary(self) -> dict:
        """Everything result.json needs from the world."""
        c = self.counters
        robots = {}
        for rid in range(len(self.robots)):
            death = self.robots.deaths.get(rid)
            robots[rid] = {
                "alive": bool(self.robots.alive[rid]),
                "pose": self.robots.pose(rid, POS_DIGITS),
                "host": self.robots.host[rid],
                "joined_at": self.robots.joined_at[rid],
                "failed": None if death is None else {"tick": death.tick, "cause": death.cause, "error": death.error},
                "status": self.robots.status[rid],
                "range": float(self.robots.range[rid]),
                "sensing": float(self.robots.sensing[rid]),
            }
        return {
            "ticks": self.ticks_done,
            "wall_s": self.wall_s,
            "stop_reason": self.stop_reason,
            "robots": robots,
            "reports": self.reports,
            "world": {**c.as_dict(), "per_robot": {
                rid: {"sent": c.sent_by.get(rid, 0), "received": c.received_by.get(rid, 0),
                      "dropped": dict(c.dropped_by.get(rid, {}))} for rid in range(len(self.robots))}},
            "objects": self.objects,
        }
