"""The world process: the registry of hosts and the order of one tick.

The world is the authority on every robot's true state and the only place where range, latency and loss
are decided. It never decodes a frame body and never imports a protocol. Each rule has its own module;
this one holds the hosts that run robots and the order of a tick, read top to bottom (``begin``,
``exchange``, ``end``), which the clock (world/clock.py) drives:

1. apply the actions due at this tick (scenario ``[[events]]``, then ``control``; world/faults.py);
2. compute radio reach and sensing from the positions at this tick (world/sensing.py);
3. hand every host its robots' poses, sensing, known objects and the frames due now;
4. (the robots step;) take each host's velocity commands, status and outgoing frames (world/uplink.py);
5. the radio decides each frame's receivers from this tick's positions (world/radio.py); lockstep
   deliveries fall due ``latency`` ticks later, realtime ones when their latency has elapsed;
6. record what happened (world/counters.py: the trace record and counters; the ``state`` stream);
7. integrate motion to the next tick's positions (world/kinematics.py).

Every message in or out is a ``transport.messages`` type. In lockstep a host registers with one Zenoh query on
``up/{host}``, then each step is a put on ``up/{host}`` carrying its outputs of the previous tick; the world
puts the next tick's inputs on ``down/{host}`` only once every live host is in (the barrier). The host
subscribes to ``down/{host}`` before it registers, so no input can be lost to a start-up race. Steps are not
queries because Zenoh keeps every query's state until its timeout (docs/benchmarks.md, "A host's memory").
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections import defaultdict
from collections.abc import Callable
from typing import Any, NamedTuple, Protocol

import msgspec
import numpy as np

from transport import Keys, Link, MalformedMessage, PendingQuery, host_loss_s, new_key, pack, seal, unseal
from transport.auth import verifies
from transport.messages import (
    CLOCK_COMMANDS,
    F64,
    I32,
    MAX_PER_REQUEST,
    PROTOCOL_VERSION,
    Ack,
    ControlCommand,
    Deliveries,
    FrameIn,
    Inputs,
    JoinReply,
    JoinRequest,
    RobotDescr,
    RunInfo,
    State,
    Stop,
    Uplink,
    decode,
    encode,
)
from transport.scenario import RobotSpec, Scenario
from transport.space import space_from_spec
from world import rng
from world.clock import BUCKET_S, LockstepClock, RealtimeClock, make_clock
from world.counters import Counters, TickRecord
from world.faults import REQUEST_CAP, ROBOT_CAP, Faults
from world.kinematics import MAX_COORD, bad_positions, integrate
from world.radio import Decision, Medium, Outgoing
from world.registry import HostEntry, Robots
from world.sensing import Reach, Sensed, gather, reach, sense_arrays
from world.situated import Situated
from world.space import SpaceRules
from world.uplink import COUNTED_CRASHES, INVALID_POSITION, accept

log = logging.getLogger(__name__)

POS_DIGITS = 6  # positions in traces, state and hashes are rounded to 1e-6 length units
INTERRUPT_REPORTS_S = 5.0  # an interrupted run waits at most this long for its hosts' final reports
# realtime: the world records the copies due within one such span together, with one timer (each copy's fate
# still by its own due time: World._record_fates); a multiple of the clock's BUCKET_S
BOOKKEEPING_S = 10 * BUCKET_S
MAX_BACKDATE_S = 0.05  # realtime: a frame's latency runs from at most this long before the world received it


class Due(NamedTuple):
    """A lockstep tick's deliveries, ordered by (receiver, src, seq).

    For each: the receiver, its frame (an index into ``frames``, the (frame, send tick) pairs), sender and seq.
    """

    dst: np.ndarray
    ref: np.ndarray
    src: np.ndarray
    seq: np.ndarray
    frames: list[tuple[Outgoing, int]]


def bucket_groups(delay: np.ndarray, now: float) -> list[np.ndarray]:
    """Realtime bookkeeping: copies grouped by the ``BOOKKEEPING_S`` span their due time falls in.

    ``delay``: seconds after loop time ``now``; groups are index arrays into it, each in its original order. A
    group is handed to ``RealtimeClock.after`` as one item with its longest delay, which falls in the same bucket
    as each of its copies' or a later one: the clock never fires it before any copy's due time.
    """
    bucket = np.ceil((now + delay) / BOOKKEEPING_S)
    order = np.argsort(bucket, kind="stable")
    return np.split(order, np.flatnonzero(np.diff(bucket[order])) + 1)


class Sink(Protocol):
    """Receives one record per tick (the trace writer is one)."""

    def record(self, rec: dict) -> None: ...


class World:
    """One run's world. Create, ``open()``, then ``await run()``; the result is in ``summary()``."""

    def __init__(
        self,
        spec: Scenario,
        link: Link,
        keys: Keys,
        sinks: list[Sink] = (),
        on_tick: Callable[[World], None] | None = None,
        run_secret: bytes | None = None,
    ):
        run, wspec = spec.run, spec.world
        self.spec = spec
        self.run_secret = run_secret  # seals join replies (transport.auth); None: join replies are plain
        self.link = link
        self.keys = keys
        self.sinks = list(sinks)
        self.on_tick = on_tick
        self.seed = run.seed
        self.ticks = run.ticks
        self.dt = float(run.dt)
        self.clock = make_clock(run.clock, self.ticks, self.dt)
        self.watchdog_s = float(run.watchdog_s)
        self.join_timeout_s = float(run.join_timeout_s)
        self.state_every = run.state_every
        self.trace_commands = run.trace_commands  # "cmd" rows: velocities before the cap
        self.dims = wspec.dims
        self.bounds = np.array(wspec.bounds, dtype=float) if wspec.bounds else None
        self.objects: dict[str, list[float]] = {o.name: list(map(float, o.pos)) for o in wspec.objects}
        self.known_by: dict[str, Any] = {o.name: o.known_by for o in wspec.objects}
        self.radio = spec.radio
        self.medium = Medium(self.radio, self.seed)
        self.robots = Robots(self.dims)
        robots = spec.robot_specs()
        self.robots.add(robots, tick=0)
        # the rules of space (world/space.py): only when the run has obstacles, bodies or heights
        self.space: SpaceRules | None = None
        if wspec.has_space or self.dims == 3 or wspec.blocking or (self.robots.body > 0).any():
            self.space = SpaceRules(space_from_spec(wspec.space_spec()), self.dims, self.radio.occlusion,
                                    wspec.blocking)
        self.known_map = wspec.space_spec() if any(s.knows_map for s in robots) else None
        self.unclaimed: list[int] = list(range(len(self.robots)))
        self.situated = Situated(self.seed, self.radio.rab)  # local frames, bodies' surfaces, clocks, frame.rab
        self.situated.sync(self.robots.spec)
        self.hosts: dict[str, HostEntry] = {}
        self._host_codes_of: tuple | None = None  # _host_codes: what its cache was built from
        self._host_codes_cache: tuple[np.ndarray, list[str]] = (np.empty(0, dtype=np.int64), [])
        self.counters = Counters()
        self.record = TickRecord(self.counters, self._publish_event)
        self.max_robots = wspec.max_robots
        if len(self.robots) > self.max_robots:
            raise ValueError(f"{len(self.robots)} robots exceed world.max_robots = {self.max_robots}")
        self.faults = Faults(spec.events, self.seed, self.robots, self.hosts, self.medium, self.objects,
                             self.record, self.max_robots)
        self.started = False
        self.finished = False
        self.stop_reason: str | None = None
        self.wall_s = 0.0
        self.reports: dict[int, dict] = {}
        self._last_seq: dict[int, int] = {}  # each robot's last accepted frame seq
        # lockstep: frames in the air by due tick, as batches (frames, Decision of their deliveries, send tick);
        # each host's pending step (tick, uplink; -1: registration)
        self._due: dict[int, list[tuple[list[Outgoing], Decision, int]]] = defaultdict(list)
        self._held: dict[str, tuple[int, Uplink | None]] = {}
        self._all_stepped = asyncio.Event()
        self._awaited_tick = -1
        self._ready = asyncio.Event()
        self._final_reports = asyncio.Event()
        self.collecting = False  # the run is over: the world is collecting the hosts' final reports
        self.interrupted = False  # stopped by a signal: reports are awaited INTERRUPT_REPORTS_S at most
        if isinstance(self.clock, RealtimeClock):
            self.clock.on_due = self._rt_deliver
        self._rt_pending: list[tuple[str, Uplink]] = []  # realtime: uplinks received, not taken yet
        # this tick's reach (world/sensing.py) and sensing
        self._reach: Reach = reach(np.zeros((0, self.dims)), np.zeros(0, dtype=np.int64), np.zeros(0))
        self._sensed = Sensed(np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros((0, self.dims)))
        self._poses = np.zeros((0, self.dims + 1))  # each robot's pose row (position, heading), rounded
        self._known: dict[int, list[str]] | None = None  # objects each robot knows this tick (None: all)
        self._hidden: np.ndarray | None = None  # links of ``_reach`` an obstacle blocks (None: none)
        self._rays: dict[int, list[float]] = {}  # robot -> obstacle range-ray distances

    @property
    def tick(self) -> int:
        return self.clock.tick

    @property
    def ticks_done(self) -> int:
        return self.clock.ticks_done

    @property
    def lockstep(self) -> bool:
        return isinstance(self.clock, LockstepClock)

    # ------------------------------------------------------------ set-up
    def open(self) -> None:
        """Declare the world's queryables, subscribers and liveliness watch."""
        self.link.serve(self.keys.join, self._on_join)
        self.link.serve(self.keys.control, self._on_control)
        self.link.serve(self.keys.up_all, self._on_step_query)
        self.link.subscribe(self.keys.up_all, self._on_up_put)
        self.link.watch_liveliness(self.keys.alive_all, self._on_liveliness)
        self.link.declare_token(self.keys.world_alive)  # hosts leave when it vanishes (the world died)

    async def run(self) -> None:
        """Wait until every robot is claimed, then run the clock to the end (or until stopped)."""
        await self._wait_ready()
        self.started = True
        t0 = asyncio.get_running_loop().time()
        try:
            await self.clock.run(self)
        finally:
            self.wall_s = asyncio.get_running_loop().time() - t0
            await self._collect_reports()
            self.finished = True

    def request_stop(self, reason: str, interrupted: bool = False) -> None:
        """Finish the current tick, then end the run (``interrupted``: SIGINT or SIGTERM, do not wait for it)."""
        if self.stop_reason is None:
            self.stop_reason = reason
        self.interrupted = self.interrupted or interrupted
        self.clock.stop()
        self._all_stepped.set()
        self._ready.set()

    # ------------------------------------------------------------ the tick
    def begin(self) -> None:
        """Steps 1-2: actions, then reach and sensing from this tick's positions.

        What happened between two ticks (malformed input, hosts lost) was recorded already and goes
        into this tick's record.
        """
        self.record.rec["t"] = self.tick
        for action, source in self.faults.due(self.tick):
            self._apply(action, source)
        alive = self.robots.alive_ids()
        r = self.robots
        self._reach = reach(r.pos, alive, r.range)
        sensed_ids = self._reach if np.array_equal(r.sensing, r.range) else reach(r.pos, alive, r.sensing)
        self._sensed = sense_arrays(r.pos, sensed_ids, r.noise, self.seed, self.tick, POS_DIGITS)
        self._hidden = self.space.hidden_pairs(r.pos, self._reach) if self.space is not None else None
        self._rays = (self.space.rays(r.pos, r.heading, r.sensing, r.rays, alive)
                      if self.space is not None and r.rays.any() else {})
        if self.space is not None and r.body.any():
            for episode in self.space.collisions(self.tick, r.pos, r):
                self.record.event(self.tick, episode)
        self._poses = np.round(np.hstack([r.pos, r.heading[:, None]]), POS_DIGITS)
        self.situated.sync(r.spec)
        if self.situated.active:  # situated sensing (world/situated.py): own frames, closest points
            rows = self.situated.sense(r.pos, r.heading, alive, r.sensing, r.noise, sensed_ids.as_dict(alive),
                                       self._sensed.as_dict(alive), self.tick, POS_DIGITS)
            self._sensed = Sensed.from_dict(len(r.pos), self.dims, rows)
            self.situated.own_poses(self._poses, r.pos, r.heading, POS_DIGITS)
        self._known = self._known_objects()

    async def exchange(self) -> None:
        """Steps 3-5: inputs to every host; in lockstep, wait for every step and take the outputs."""
        if not self.lockstep:
            for host in self._live_hosts():
                self.link.publish(self.keys.down(host), self._down(host, self._inputs_for(host, None)))
            return
        due = self._deliver_due(self.tick)
        self._awaited_tick = self.tick
        self._all_stepped.clear()
        for host in self._live_hosts():
            # a host that joined since the last tick may not have sent its registration yet: it gets
            # inputs from the tick after its registration arrives (_all_in counts a registration as in)
            if self._held.pop(host, None) is not None:
                self.link.publish(self.keys.down(host), self._down(host, self._inputs_for(host, due)))
        await self._await_steps()
        for host in sorted(self._live_hosts()):
            t, msg = self._held.get(host, (None, None))
            if t == self.tick:
                self._take(host, msg)

    def end(self) -> None:
        """Steps 6-7: record, publish state, integrate motion."""
        alive = self.robots.alive_ids()
        pos = np.round(self.robots.pos[alive], POS_DIGITS).tolist()
        self.record.rec["pos"] = [[rid, *row] for rid, row in zip(alive.tolist(), pos, strict=True)]
        rec = self.record.take()
        for sink in self.sinks:
            sink.record(rec)
        if self.state_every and self.tick % self.state_every == 0 and self._state_watched():
            state = State(self.tick, rec["pos"], {int(r): self.robots.status[r] for r in alive},
                          self.robots.range[alive].round(POS_DIGITS).tolist(), self.objects,
                          dict(self.counters.dropped), self.counters.sent)
            self.link.publish(self.keys.state, encode(state), reliable=False)
        if self.on_tick:
            self.on_tick(self)
        before = self.robots.pos.copy() if self.space is not None else None
        integrate(
            self.robots.pos, self.robots.heading, self.robots.vel, self.robots.speed,
            self.robots.turn_rate, self.robots.alive, self.dt, self.bounds,
        )
        if self.space is not None:
            self.space.constrain(before, self.robots.pos, self.robots, self.dt)
            self.space.unblock_bodies(before, self.robots.pos, self.robots)
        for rid in bad_positions(self.robots.pos, self.robots.alive).tolist():  # the robot crashes, the run goes on
            where = self.robots.pos[rid].tolist()
            np.clip(np.nan_to_num(self.robots.pos[rid]), -MAX_COORD, MAX_COORD, out=self.robots.pos[rid])
            self.counters.refused[INVALID_POSITION] += 1
            self.faults.crash(rid, self.tick, INVALID_POSITION, f"position {where!r} beyond the world's limit")

    def _state_watched(self) -> bool:
        """Whether an observer subscribes to ``state`` (a snapshot nobody reads is not built)."""
        subscribed = getattr(self.link, "subscribed", None)
        return subscribed is None or subscribed(self.keys.state)

    def _inputs_for(self, host: str, due: Due | None) -> Inputs:
        """Step 3: one host's inputs for this tick, as columns (each frame body once per host).

        Its alive robots in id order; each one's pose, what it senses and its inbox are rows of this tick's
        tables (``begin``, ``_deliver_due``), taken for the host's robots with a few array operations.
        """
        entry = self.hosts[host]
        ids = np.fromiter(entry.robots, dtype=np.int64, count=len(entry.robots))
        ids.sort()
        ids = ids[self.robots.alive[ids]]
        sptr, sk = self._sensed.rows(ids)
        frames: list[FrameIn] = []
        inbox = refs = b""
        rab = None
        if due is not None and len(ids):
            iptr, dk = gather(np.searchsorted(due.dst, ids, "left"), np.searchsorted(due.dst, ids, "right"))
            if len(dk):
                used, local = np.unique(due.ref[dk], return_inverse=True)
                pairs = due.frames
                for k in used.tolist():
                    f, sent_tick = pairs[k]
                    frames.append(FrameIn(f.src, f.kind, f.seq, f.body, sent_tick))
                inbox, refs = iptr.astype(I32).tobytes(), local.astype(I32).tobytes()
                if self.situated.rab:
                    rab = self._rab_rows(ids, iptr, due.src[dk], due.seq[dk])
        known = self._known
        rays = self._rays
        msg = Inputs(self.tick, self.clock.now(), self.dims, ids.astype(I32).tobytes(),
                     self._poses[ids].astype(F64).tobytes(),
                     sptr.astype(I32).tobytes() if len(sk) else b"", self._sensed.ids[sk].astype(I32).tobytes(),
                     self._sensed.at[sk].astype(F64).tobytes(), inbox, refs, frames,
                     None if known is None else [known.get(rid, []) for rid in ids.tolist()],
                     [rays.get(rid) for rid in ids.tolist()] if rays else None, rab, self.objects)
        if not self.lockstep:
            msg.epoch = self.clock.epoch
        if entry.pending_dead:
            msg.dead, entry.pending_dead = entry.pending_dead, []
        if entry.pending_new:
            msg.new, entry.pending_new = entry.pending_new, []
        return msg

    def _rab_rows(self, ids: np.ndarray, iptr: np.ndarray, src: np.ndarray, seq: np.ndarray) -> list | None:
        """frame.rab: each robot's (range, bearing) of its inbox frames, flattened (None: it wants none, or none)."""
        rows: list[list[float] | None] = []
        src_l, seq_l, ptr = src.tolist(), seq.tolist(), iptr.tolist()
        for i, rid in enumerate(ids.tolist()):
            row: list[float] = []
            if self.situated.wants_rab(rid):
                for k in range(ptr[i], ptr[i + 1]):
                    row.extend(self.situated.take_rab(src_l[k], seq_l[k], rid))
            rows.append(row or None)
        return rows if any(r is not None for r in rows) else None

    def _known_objects(self) -> dict[int, list[str]] | None:
        """Which objects each robot knows (None: every robot knows every object, the default).

        An object's ``known_by`` is ``"all"`` (mission knowledge), ``"sensing"`` (robots whose sensing range
        reaches it this tick) or a list of robot ids.
        """
        if all(k == "all" for k in self.known_by.values()):
            return None
        known: dict[int, list[str]] = defaultdict(list)
        alive = self.robots.alive_ids()
        for name, who in self.known_by.items():
            if who == "all":
                ids = alive
            elif who == "sensing":
                d = np.linalg.norm(self.robots.pos[alive] - np.array(self.objects[name])[: self.dims], axis=1)
                ids = alive[d <= self.robots.sensing[alive]]
            else:
                ids = [i for i in who if i < len(self.robots)]
            for rid in ids:
                known[int(rid)].append(name)
        return known

    # ------------------------------------------------------------ joining
    def _on_join(self, q: PendingQuery) -> None:
        try:
            if not q.payload:
                raise MalformedMessage("empty join request (a host sends a JoinRequest map)")
            req = decode(q.payload, JoinRequest, what="join request")
        except MalformedMessage as exc:
            self.record.malformed(None, str(exc))
            q.reply_error(str(exc))
            return
        if self.finished or self.collecting:
            q.reply_error("the run has finished")
            return
        name = f"h{len(self.hosts)}"
        host = HostEntry(name, key=new_key())
        if not self.started:
            take = len(self.unclaimed) if req.count is None else min(req.count, len(self.unclaimed))
            ids, self.unclaimed = self.unclaimed[:take], self.unclaimed[take:]
        else:
            want = req.count or 1
            cause = (REQUEST_CAP if want > MAX_PER_REQUEST
                     else ROBOT_CAP if len(self.robots) + want > self.max_robots else None)
            if cause:
                reason = (f"join asking for {want} robots at tick {self.tick} (at most {MAX_PER_REQUEST} per join, "
                          f"{self.max_robots} in the run)")
                self.faults.refuse(self.tick, cause, reason)
                q.reply_error(reason)
                return
            specs = [self._placed_like(self.robots.spec[0]) for _ in range(want)]
            ids = self.robots.add(specs, tick=self.tick)
            self.record.event(self.tick, {"added": ids, "source": "join"})
        for rid in ids:
            self.robots.host[rid] = name
            host.robots.add(rid)
        self.hosts[name] = host
        log.info("host %s joined with robots %s", name, ids)
        run = RunInfo(self.clock.name, self.dt, self.seed, self.ticks, self.watchdog_s, self.tick, self.known_map)
        reply = encode(JoinReply(name, host.key, PROTOCOL_VERSION, [self._robot_descr(r) for r in ids], run))
        q.reply(seal(self.run_secret, reply) if self.run_secret else reply)
        self._check_ready()

    def _down(self, host: str, msg) -> bytes:
        """A downlink message for ``host``, sealed with its key (transport.auth)."""
        return seal(self.hosts[host].key, encode(msg))

    def _robot_descr(self, rid: int) -> RobotDescr:
        s = self.robots.spec[rid]
        self.situated.sync(self.robots.spec)
        pose = self.robots.pose(rid, POS_DIGITS)
        if self.situated.local[rid]:
            pose = [round(v, POS_DIGITS) for v in self.situated.pose(rid, self.robots.pos[rid],
                                                                     self.robots.heading[rid])]
        return RobotDescr(rid, pose, s.behaviors, s.kind, float(self.robots.range[rid]),
                          float(self.robots.sensing[rid]), float(self.robots.speed[rid]), s.knows_map,
                          **self.situated.descr(rid))

    def _placed_like(self, template: RobotSpec) -> RobotSpec:
        """A robot spec for a host joining mid-run: template parameters, random position in bounds."""
        n = len(self.robots)
        lo, hi = (self.bounds if self.bounds is not None else np.array([[0.0] * self.dims, [1.0] * self.dims]))
        u = rng.uniform(self.seed, rng.PLACEMENT, self.tick, n, np.arange(self.dims))
        return msgspec.structs.replace(template, pos=list(lo + u * (hi - lo)))

    def _check_ready(self) -> None:
        if not self.unclaimed and all(h in self._held for h in self._live_hosts()):
            self._ready.set()

    async def _wait_ready(self) -> None:
        try:
            await asyncio.wait_for(self._ready.wait(), self.join_timeout_s)
        except TimeoutError:
            claimed = ", ".join(f"{h.name} ({len(h.robots)})" for h in self.hosts.values()) or "none"
            waiting = [h for h in self._live_hosts() if h not in self._held]
            raise RuntimeError(
                f"{len(self.unclaimed)} robot(s) were not claimed by any host within "
                f"{self.join_timeout_s:.0f} s (robot hosts must join {self.keys.join}); hosts that claimed "
                f"robots: {claimed}" + (f"; never registered: {', '.join(waiting)}" if waiting else "")
            ) from None

    # ------------------------------------------------------------ uplinks
    def _on_step_query(self, q: PendingQuery) -> None:
        """A query on ``up/{host}``: the host's registration (tick -1) or its final reports, in either clock.

        Each is answered at once. Lockstep steps are puts (``_on_up_put``): a query stays in Zenoh's memory
        until its timeout, so one per tick would grow a host by about 0.8 KB a step.
        """
        host = self.keys.host_of(q.key)
        entry = self.hosts.get(host)
        if entry is not None and not entry.alive:
            q.reply(self._down(host, Stop(self.tick, gone=True)))
            return
        msg = self._decode_up(host, q.payload)
        if msg is None:
            q.reply_error("malformed or unauthenticated step")
            return
        if not self.lockstep:
            self._take(host, msg)
            q.reply(self._down(host, Ack(self.clock.epoch)))
            if msg.tick == -1:
                self._held[host] = (-1, None)
                self._check_ready()
                if self.collecting:  # registered after the stop went out: it gets its own
                    self.link.publish(self.keys.down(host), self._down(host, Stop(self.tick)))
            return
        if msg.tick != -1 and msg.reports is None:
            problem = self._step_problem(entry, msg) or f"a step of tick {msg.tick} as a query (steps are puts)"
            self.record.malformed(None, f"step from {host}: {problem}")
            q.reply_error(problem)
            return
        problem = self._step(host, entry, msg)
        if problem:
            q.reply_error(problem)
        else:
            q.reply(self._down(host, Stop(self.tick, bye=True) if msg.reports is not None else Ack(0.0)))

    def _step(self, host: str, entry: HostEntry, msg: Uplink) -> str | None:
        """Lockstep: hold a host's registration or step for the barrier, or take its reports; the problem if not.

        A step or registration that arrives after the run ended is answered with ``Stop``: its host reports now.
        """
        if self.collecting and msg.reports is None:
            entry.registered = True
            self.link.publish(self.keys.down(host), self._down(host, Stop(self.tick)))
            return None
        if host in self._held:  # one step per host per tick: a second one is a replay or a forgery
            problem = f"a second step while one is pending (tick {msg.tick})"
        elif msg.reports is not None and entry.reported:
            problem = "a second report"
        else:
            problem = self._step_problem(entry, msg)  # stale, future or repeated: never held
        if problem:
            self.record.malformed(None, f"step from {host}: {problem}")
            return problem
        if msg.reports is not None:
            self._take_reports(host, msg.reports)
            return None
        if msg.tick == -1:
            entry.registered = True
        self._held[host] = (msg.tick, msg)
        if not self.started:
            self._check_ready()
        elif self._all_in():
            self._all_stepped.set()
        return None

    def _step_problem(self, entry: HostEntry, msg: Uplink) -> str | None:
        """Why a lockstep step is not the one awaited from this host (None if it is).

        A host registers once (tick -1), then steps exactly the awaited tick; its final report (``reports``)
        comes after the last tick.
        """
        if msg.tick == -1:
            return "registered already" if entry.registered else None
        if msg.reports is not None:
            if msg.tick > self._awaited_tick or self.collecting:
                return None
            return f"report for tick {msg.tick} before the end"
        if not self.started or msg.tick != self._awaited_tick:
            what = "stale" if msg.tick < self._awaited_tick else "future"
            return f"{what} step for tick {msg.tick} (awaited: {self._awaited_tick if self.started else -1})"
        return None

    def _on_up_put(self, key: str, payload: bytes) -> None:
        host = self.keys.host_of(key)
        entry = self.hosts.get(host)
        if entry is not None and not entry.alive:
            if self.lockstep and verifies(entry.key, payload):  # a host lost to the watchdog wakes up: it leaves
                self.link.publish(self.keys.down(host), self._down(host, Stop(self.tick, gone=True)))
            return
        msg = self._decode_up(host, payload)
        if msg is None:
            return
        if self.lockstep:
            self._step(host, entry, msg)
            return
        self._rt_pending.append((host, msg))
        if len(self._rt_pending) == 1:
            asyncio.get_running_loop().call_soon(self._rt_take_pending)

    def _rt_take_pending(self) -> None:
        """Realtime: the uplinks that arrived while the loop was busy, taken together, in arrival order.

        Their frames go to the radio as one batch: one decision and one ``Deliveries`` message per receiving
        host instead of one per uplink. An uplink that finds the loop idle is taken at once, alone.
        """
        pending, self._rt_pending = self._rt_pending, []
        frames: list[Outgoing] = []
        for host, msg in pending:
            self._take(host, msg, frames)
        if frames:
            self._transmit(frames)

    def _decode_up(self, host: str, payload: bytes) -> Uplink | None:
        """Verify (per-host key) and decode an uplink; count and return None when it is bad."""
        try:
            entry = self.hosts.get(host)
            if entry is None:
                raise MalformedMessage(f"uplink on up/{host}: no such host joined")
            msg = decode(unseal(entry.key, payload, what=f"uplink on up/{host}"), Uplink, what=f"uplink from {host}")
            if msg.host != host:
                raise MalformedMessage(f"uplink on up/{host} claims host {msg.host!r}")
            return msg
        except MalformedMessage as exc:
            self.record.malformed(None, str(exc))
            return None

    def _take(self, host: str, msg: Uplink, frames: list[Outgoing] | None = None) -> None:
        """Step 4: a host's reports (at the end) and its robots' outputs; the radio takes the frames.

        ``frames`` (realtime): gather the frames there instead, for one radio decision with other uplinks'.
        """
        if msg.reports is not None and not self.lockstep:
            self._take_reports(host, msg.reports)
        if not msg.robots:
            return
        got = accept(host, msg.robots, self.hosts[host].robots, self.robots.alive, self.dims, self._last_seq)
        for rid, reason in got.refused:
            self.record.malformed(rid, reason)
        for rid, cause, error in got.crashes:
            if cause in COUNTED_CRASHES:
                self.counters.refused[cause] += 1
            self.faults.crash(rid, self.tick, cause, error)
        for rid, v in got.velocities:
            self.robots.vel[rid] = self.situated.velocity(rid, v)
            if self.trace_commands:  # as commanded, in the world's frame, before the speed cap
                cmd = np.round(self.robots.vel[rid], POS_DIGITS).tolist()
                self.record.rec.setdefault("cmd", []).append([int(rid), *cmd])
        for rid, changes in got.statuses:
            self.robots.status[rid].update(changes)
            self.record.status(rid, changes)
        if got.frames:
            if frames is None:
                self._transmit(got.frames)
            else:
                frames.extend(got.frames)

    def _take_reports(self, host: str, reports: dict[int, Any]) -> None:
        for rid, rep in reports.items():
            if rid in self.hosts[host].robots:
                self.reports[rid] = rep
        self.hosts[host].reported = True
        self._check_reports_in()

    # ------------------------------------------------------------ radio
    def _transmit(self, frames: list[Outgoing]) -> None:
        """Step 5: decide receivers for frames sent now (from this tick's positions), all pairs at once."""
        r = self.robots
        out = self.medium.decide_batch(self.tick, frames, self._reach, r.alive, r.pos, r.range, self._hidden)
        self.record.sent(frames)
        ok = out.cause < 0
        if not ok.all():
            bad = ~ok
            fr = out.frame[bad]
            self.record.dropped_arrays(out.src[fr], out.seq[fr], out.dst[bad], out.cause[bad])
        handed = ok & ~out.overheard
        if self.situated.rab and handed.any():
            fr = out.frame[handed]
            self.situated.note_rab_arrays(self.tick, out.dst[handed], out.src[fr], out.seq[fr], r.pos, r.heading)
        if self.lockstep:
            if ok.any():
                self._due[self.tick + self.radio.latency].append((frames, out.only(ok), self.tick))
        else:
            self._schedule_realtime(frames, out.frame[ok], out.dst[ok], out.src[out.frame[ok]],
                                    out.seq[out.frame[ok]], out.overheard[ok])

    def _deliver_due(self, tick: int) -> Due | None:
        """Lockstep: the deliveries of tick ``tick``, ordered by (receiver, src, seq), as arrays (``Due``).

        The tick's deliveries are put in (dst, src, seq) order with one sort; the trace records them in that
        order; those whose receiver died meanwhile are dropped as ``dead``. Overheard copies (world/radio.py)
        arrive the same way and are recorded as such, in the same order, but go in no inbox.
        """
        batches = self._due.pop(tick, [])
        if not batches:
            return None
        frames: list[tuple[Outgoing, int]] = []  # (frame, send tick), one per frame, shared by its receivers
        parts = []
        for fs, out, sent_tick in batches:
            parts.append((out.dst, out.src[out.frame], out.seq[out.frame], out.frame + len(frames),
                          np.full(len(out.frame), sent_tick, dtype=np.int64), out.overheard))
            frames.extend([(f, sent_tick) for f in fs])
        dst, src, seq, ref, sent, heard = (np.concatenate(col) for col in zip(*parts, strict=True))
        order = np.lexsort((seq, src, dst))
        dst, src, seq, ref, sent, heard = dst[order], src[order], seq[order], ref[order], sent[order], heard[order]
        keep = self._record_fates(dst, src, seq, sent, heard, self.robots.alive[dst])
        if not keep.any():
            return None
        return Due(dst[keep], ref[keep], src[keep], seq[keep], frames)

    def _record_fates(self, dst: np.ndarray, src: np.ndarray, seq: np.ndarray, sent: np.ndarray,
                      heard: np.ndarray, live: np.ndarray) -> np.ndarray:
        """Record copies that fell due; return the mask of those delivered (the copies a robot is handed).

        ``live``: per copy, whether its receiver was alive at its due time. In this order: dropped as ``dead``
        (the receiver died meanwhile), overheard, delivered.
        """
        if not live.all():
            for d, s_, q in zip(dst[~live].tolist(), src[~live].tolist(), seq[~live].tolist(), strict=True):
                self.record.dead(s_, q, d)
        overheard = live & heard
        if overheard.any():
            self.record.overheard_arrays(src[overheard], seq[overheard], dst[overheard], sent[overheard])
        keep = live & ~heard
        self.record.delivered_arrays(src[keep], seq[keep], dst[keep], sent[keep])
        return keep

    def _schedule_realtime(self, frames: list[Outgoing], fr: np.ndarray, dst: np.ndarray, src: np.ndarray,
                           seq: np.ndarray, heard: np.ndarray) -> None:
        """Realtime: each copy (frame ``frames[fr[i]]`` to ``dst[i]``) is due when its drawn latency has elapsed.

        The latency runs from the sender's radio call (``Outgoing.at``, the sender host's wall clock), taken no
        earlier than ``MAX_BACKDATE_S`` before the world received the frame and never after it (a host cannot buy
        an earlier delivery by back-dating). A delivery goes to its receiver's host at once, which hands the
        frame to its robot at the due time (swarmactors/precise_timer.py), never earlier; the world's own timer
        records the delivery in the trace then (or up to ``BOOKKEEPING_S`` later), or a drop as ``dead`` if the
        receiver died before the due time. An overheard copy goes to no host: only the world's timer records it.

        All copies at once, as arrays: the latencies in one draw (the same values as frame by frame), and the
        bookkeeping as one timer item per ``BOOKKEEPING_S`` of due times (``_rt_deliver`` records a group's copies
        together, with the array recorders, each by its own due time) rather than one per copy.
        """
        if not len(dst):
            return
        sent_at = self.clock.now()
        received = time.time()
        at = np.array([received if f.at is None else f.at for f in frames])
        start = np.minimum(received, np.maximum(at, received - MAX_BACKDATE_S))[fr]
        due = start + self.medium.latencies_s(self.tick, src, seq, dst)
        delay = due - received
        # bookkeeping: one item per BOOKKEEPING_S span of due times, fired at the group's longest delay: never
        # before a copy's due time
        groups = bucket_groups(delay, asyncio.get_running_loop().time())
        self.clock.after([float(delay[g].max()) for g in groups],
                         [(dst[g], src[g], seq[g], heard[g], self.tick, due[g]) for g in groups])
        # the deliveries, per receiving host, at once: each frame once per host, the copies as columns
        to_host = ~heard
        rab = self.situated.rab
        codes, names = self._host_codes()
        of_host = codes[dst]
        for h, host in enumerate(names):
            if not self.hosts[host].alive:
                continue
            sel = np.flatnonzero(to_host & (of_host == h))
            if not len(sel):
                continue
            used, refs = np.unique(fr[sel], return_inverse=True)
            table = [FrameIn(f.src, f.kind, f.seq, f.body, sent_at) for f in map(frames.__getitem__, used.tolist())]
            rows = None
            if rab:
                situated, mine = self.situated, dst[sel].tolist()
                rows = [list(situated.take_rab(frames[k].src, frames[k].seq, d)) if situated.wants_rab(d) else None
                        for k, d in zip(fr[sel].tolist(), mine, strict=True)]
            msg = Deliveries.of(table, dst[sel], refs, due[sel], rows)
            self.link.publish(self.keys.down(host), self._down(host, msg))

    def _host_codes(self) -> tuple[np.ndarray, list[str]]:
        """Each robot's host as an index into the names returned (-1: none), for array selections per host.

        Rebuilt only when robots or hosts were added: a robot never changes host (``_on_join``, ``_apply``).
        """
        key = (len(self.robots.host), len(self.hosts), sum(len(e.robots) for e in self.hosts.values()))
        if self._host_codes_of != key:
            names = list(self.hosts)
            codes = np.full(len(self.robots.host), -1, dtype=np.int64)
            for h, name in enumerate(names):
                members = self.hosts[name].robots
                codes[np.fromiter(members, dtype=np.int64, count=len(members))] = h
            self._host_codes_of, self._host_codes_cache = key, (codes, names)
        return self._host_codes_cache

    def _rt_deliver(self, item: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int, np.ndarray]) -> None:
        """Realtime bookkeeping once a group of copies fell due: delivered (or overheard), or dropped as ``dead``.

        A copy is ``dead`` when its receiver died before the copy's own due time (``Robots.died_at``), however
        late this timer fires.
        """
        dst, src, seq, heard, sent_tick, due = item
        if not self.finished:
            self._record_fates(dst, src, seq, np.full(len(dst), sent_tick, dtype=np.int64), heard,
                               self.robots.died_at[dst] > due)

    # ------------------------------------------------------------ actions and failures
    def _apply(self, action: dict, source: str) -> None:
        """Apply one action; new robots go to the least loaded live host."""
        applied = self.faults.apply(action, source, self.tick)
        for rid in applied.added:
            host = self._least_loaded_host()
            if host is None:
                self.robots.kill(rid, self.tick, "no-host")
                continue
            self.robots.host[rid] = host
            self.hosts[host].robots.add(rid)
            self.hosts[host].pending_new.append(self._robot_descr(rid))
        if applied.stop:
            self.request_stop(applied.stop)

    def _publish_event(self, ev: dict) -> None:
        self.link.publish(self.keys.events, pack(ev), reliable=False)

    def _least_loaded_host(self) -> str | None:
        live = self._live_host_entries()
        if not live:
            return None
        return min(live, key=lambda h: (len(h.robots), int(h.name[1:]))).name

    def _on_liveliness(self, key: str, alive: bool) -> None:
        host = self.keys.host_of(key)
        entry = self.hosts.get(host)
        if alive or entry is None or not entry.alive or self.finished or (self.collecting and entry.reported):
            return  # a host may leave once the run is over and it delivered its final report; before, it is lost
        self._lose_host(host, "host-lost")

    def _lose_host(self, host: str, cause: str) -> None:
        entry = self.hosts[host]
        entry.alive = False
        self.record.event(self.tick, {"host_lost": host, "cause": cause})
        for rid in sorted(entry.robots):
            self.faults.crash(rid, self.tick, cause)
        self._held.pop(host, None)
        if self.lockstep:  # a host that is only slow reads this when it wakes, and leaves with one line
            self.link.publish(self.keys.down(host), self._down(host, Stop(self.tick, gone=True)))
        if self.started and self._all_in():
            self._all_stepped.set()
        self._check_reports_in()

    # ------------------------------------------------------------ control
    def _on_control(self, q: PendingQuery) -> None:
        """Answer one control command; a bad one is refused, counted, and changes nothing."""
        try:
            cmd = decode(q.payload, ControlCommand, what="control command")
            answer = self._control(cmd)
        except (MalformedMessage, ValueError, TypeError) as exc:
            self.record.malformed(None, f"control: {exc}")
            answer = {"ok": False, "error": str(exc)}
        q.reply(pack(answer))

    def _control(self, cmd: ControlCommand) -> dict:
        name = cmd.cmd
        if name == "status":
            return {"ok": True, **self.status()}
        if name == "stop":
            self.request_stop("stopped by control")
            return {"ok": True}
        if name in CLOCK_COMMANDS:
            clock = self.clock
            if not isinstance(clock, LockstepClock):
                raise ValueError(f"{name} needs the lockstep clock (this run is {clock.name})")
            if name == "pause":
                clock.pause()
                return {"ok": True, "tick": self.tick}
            if name == "resume":
                clock.resume()
                return {"ok": True, "tick": self.tick}
            target = self.tick + 1 if name == "step" else cmd.tick
            if type(target) is not int or target < 0:
                raise ValueError(f"run_to: tick {target!r} is not a non-negative integer")
            clock.run_to(target)
            return {"ok": True, "until": target}
        action = {name: cmd.args}
        if name == "add" and isinstance(cmd.args, list):  # caps first: refused under their own cause
            n, queued = len(cmd.args), sum(len(a["add"]) for a in self.faults.queued if "add" in a)
            cause = (REQUEST_CAP if n > MAX_PER_REQUEST
                     else ROBOT_CAP if len(self.robots) + queued + n > self.max_robots else None)
            if cause:
                reason = (f"control add of {n} robots (at most {MAX_PER_REQUEST} per add, "
                          f"{self.max_robots} in the run)")
                self.faults.refuse(self.tick, cause, reason)
                return {"ok": False, "error": reason}
        self.faults.queue(action)
        return {"ok": True, "at": self.tick + 1 if self.started else 0}

    def status(self) -> dict:
        return {
            "run_id": self.keys.run_id,
            "clock": self.clock.name,
            "tick": self.tick,
            "ticks": self.ticks,
            "started": self.started,
            "finished": self.finished,
            "paused": isinstance(self.clock, LockstepClock) and self.clock.paused,
            "robots": len(self.robots),
            "alive": int(self.robots.alive.sum()),
            "hosts": {h.name: sorted(h.robots) for h in self.hosts.values() if h.alive},
            "unclaimed": len(self.unclaimed),
            "objects": self.objects,
            **self.counters.as_dict(),
        }

    # ------------------------------------------------------------ hosts and the lockstep barrier
    def _live_host_entries(self) -> list[HostEntry]:
        return [h for h in self.hosts.values() if h.alive]

    def _live_hosts(self) -> list[str]:
        return [h.name for h in self._live_host_entries()]

    def _all_in(self) -> bool:
        """Every live host has a step pending for the awaited tick (or has just joined: tick -1)."""
        return all(self._stepped(h) for h in self._live_hosts())

    def _stepped(self, host: str) -> bool:
        """The host has the awaited step (or its registration, or its final report) pending."""
        held = self._held.get(host)
        return held is not None and (held[0] >= self._awaited_tick or held[0] == -1)

    async def _await_steps(self) -> None:
        """Wait for every live host's step; a host silent past the watchdog loses its robots."""
        limit = host_loss_s(self.watchdog_s)
        if self._all_in():
            return
        try:
            await asyncio.wait_for(self._all_stepped.wait(), limit)
        except TimeoutError:
            for host in self._live_hosts():
                if not self._stepped(host):  # whatever else it sent
                    log.error("host %s did not finish tick %d within %.1f s", host, self.tick, limit)
                    self._lose_host(host, "watchdog")

    def _check_reports_in(self) -> None:
        if all(h.reported for h in self._live_host_entries()):
            self._final_reports.set()

    async def _collect_reports(self) -> None:
        """Tell every live host to stop and wait (bounded) for its robots' reports."""
        stop = Stop(self.tick)
        self.collecting = True
        self._check_reports_in()
        if self.lockstep:  # to the hosts waiting for inputs; a step still on its way gets its Stop when it comes
            self._awaited_tick = self.tick
            for host in self._live_hosts():
                if self._held.pop(host, None) is not None:
                    self.link.publish(self.keys.down(host), self._down(host, stop))
        else:
            for host in self._live_hosts():
                self.link.publish(self.keys.down(host), self._down(host, stop))
        try:
            wait = min(self.watchdog_s + 5.0, INTERRUPT_REPORTS_S) if self.interrupted else self.watchdog_s + 5.0
            await asyncio.wait_for(self._final_reports.wait(), wait)
        except TimeoutError:
            log.warning("some hosts sent no final report")

    # ------------------------------------------------------------ summary
    def summary(self) -> dict:
        """Everything result.json needs from the world."""
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
            "world": {**self.counters.as_dict(), "per_robot": self.counters.per_robot(len(self.robots)),
                      **({"collisions": self._collision_summary()} if self.space is not None else {})},
            "objects": self.objects,
        }

    def _collision_summary(self) -> dict:
        """Collision counts and episodes for result.json (episodes still open end at the last tick)."""
        self.space.close(max(self.ticks_done - 1, 0))
        return self.space.summary()
