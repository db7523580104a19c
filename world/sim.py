"""The simulation core: robots, radio, space and faults, stepped tick by tick, with no I/O.

A ``Simulation`` knows no Zenoh, no asyncio, no keys and no wall-clock timer: a session (world/session.py) or
the in-process driver (swarmactors/runs/inprocess.py) feeds it and reads it. One tick, top to bottom (like ARGoS's
step):

1. ``begin(tick, now)``: the actions due now (scenario ``[[events]]``, then ``control``; world/faults.py), radio
   reach and sensing from this tick's positions (world/sensing.py), and in lockstep the copies due now
   (``deliver``);
2. ``inputs(host)``: a host's robots' poses, sensing, known objects and inbox (world/tables.py);
3. (the robots step;) ``take(host, uplink)``: their velocity commands, status and frames (world/uplink.py);
4. ``transmit()``: the radio decides the receivers of every frame taken since the last call, at once, from
   this tick's positions (world/radio.py), and puts the copies in the air (world/air.py): lockstep once per
   tick, realtime once per batch of arrivals; realtime returns the ``Deliveries`` to hand to each host now;
5. ``deliver(until)``: the copies due by ``until`` leave the air with their fate (delivered, overheard,
   ``dead``), recorded in the trace record;
6. ``end()``: the tick's record (world/counters.py), then motion integrated to the next tick (world/kinematics.py).

Time: ``now`` for robots is the clock's (ticks in lockstep, seconds since the start in realtime); the air and
robots' deaths use the simulation's ``time`` (the tick in lockstep, wall-clock seconds in realtime), so a copy's
fate depends only on when it was due, never on when it was looked at.
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable
from typing import Any

import msgspec
import numpy as np

from transport.messages import MAX_PER_REQUEST, Deliveries, Inputs, RobotDescr, State, Uplink
from transport.scenario import RobotSpec, Scenario
from transport.space import space_from_spec
from world import rng
from world.air import Air, Copies
from world.counters import Counters, TickRecord
from world.faults import REQUEST_CAP, ROBOT_CAP, Faults
from world.kinematics import MAX_COORD, bad_positions, integrate
from world.radio import Medium, Outgoing
from world.registry import HostEntry, Robots
from world.situated import Situated
from world.space import SpaceRules
from world.tables import POS_DIGITS, TickTables
from world.uplink import COUNTED_CRASHES, INVALID_POSITION, accept

BOOKKEEPING_S = 0.005  # realtime: the air's slot; copies due within one slot are recorded together
MAX_BACKDATE_S = 0.05  # realtime: a frame's latency runs from at most this long before the world received it


class Refused(ValueError):
    """A request the simulation will not take, under a named cause (counted in ``world.refused``)."""

    def __init__(self, cause: str, reason: str):
        super().__init__(reason)
        self.cause = cause


class Simulation:
    """The world's state and rules; a session or a driver steps it (module docstring)."""

    def __init__(self, spec: Scenario, on_event: Callable[[dict], None] | None = None,
                 time: Callable[[], float] | None = None):
        """``spec``: a resolved scenario (transport/scenario.py; its checks are the runner's).

        ``on_event`` gets each event as it happens (the session publishes them); ``time`` is the realtime
        clock (wall-clock seconds); a lockstep simulation's time is its tick.
        """
        run, wspec = spec.run, spec.world
        self.spec = spec
        self.realtime = run.clock == "realtime"
        self.seed = run.seed
        self.dt = float(run.dt)
        self.trace_commands = run.trace_commands  # "cmd" rows: velocities before the cap
        self.dims = wspec.dims
        self.bounds = np.array(wspec.bounds, dtype=float) if wspec.bounds else None
        self.objects: dict[str, list[float]] = {o.name: list(map(float, o.pos)) for o in wspec.objects}
        self.radio = spec.radio
        self.medium = Medium(self.radio, self.seed, self.dt, self.realtime)
        self.tick = 0
        self.time = (time or wall_time) if self.realtime else (lambda: float(self.tick))
        self.now = 0.0  # the clock's time of this tick (``begin``; realtime: of the last ``transmit``)
        self.robots = Robots(self.dims, now=lambda: self.time())
        robots = spec.robot_specs()
        self.robots.add(robots, tick=0)
        self.space: SpaceRules | None = None  # the rules of space (world/space.py), when there are any
        if wspec.has_space or self.dims == 3 or wspec.blocking or (self.robots.body > 0).any():
            self.space = SpaceRules(space_from_spec(wspec.space_spec()), self.dims, self.radio.occlusion,
                                    wspec.blocking)
            self.medium.use_space(self.space.space)
        self.known_map = wspec.space_spec() if any(s.knows_map for s in robots) else None
        self.unclaimed: list[int] = list(range(len(self.robots)))
        self.situated = Situated(self.seed, self.radio.rab)  # local frames, bodies' surfaces, clocks, frame.rab
        self.situated.sync(self.robots.spec)
        self.hosts: dict[str, HostEntry] = {}
        self.counters = Counters()
        self.record = TickRecord(self.counters, on_event or (lambda ev: None))
        self.max_robots = wspec.max_robots
        if len(self.robots) > self.max_robots:
            raise ValueError(f"{len(self.robots)} robots exceed world.max_robots = {self.max_robots}")
        self.faults = Faults(spec.events, self.seed, self.robots, self.hosts, self.medium, self.objects,
                             self.record, self.max_robots)
        self.stop_request: str | None = None  # a ``stop`` action asked the run to end, for this reason
        self.reports: dict[int, dict] = {}
        self.air = Air(BOOKKEEPING_S if self.realtime else 1.0)
        self.tables = TickTables(self, {o.name: o.known_by for o in wspec.objects})
        self._last_seq: dict[int, int] = {}  # each robot's last accepted frame seq
        self._outbox: list[Outgoing] = []  # frames taken since the last transmit
        self._due: Copies | None = None  # lockstep: this tick's deliveries (``begin``)

    # ------------------------------------------------------------ hosts and robots
    def claim(self, host: str, count: int | None = None) -> list[RobotDescr]:
        """Before the run: ``host`` claims ``count`` unclaimed robots (None: all of them)."""
        take = len(self.unclaimed) if count is None else min(count, len(self.unclaimed))
        ids, self.unclaimed = self.unclaimed[:take], self.unclaimed[take:]
        return self._give(host, ids)

    def join(self, host: str, count: int | None = None) -> list[RobotDescr]:
        """During the run: ``host`` joins with ``count`` new robots (default 1), like the first group's.

        They are placed at random in the bounds; ``Refused`` beyond ``MAX_PER_REQUEST`` or ``max_robots``.
        """
        want = count or 1
        if want > MAX_PER_REQUEST or len(self.robots) + want > self.max_robots:
            reason = (f"join asking for {want} robots at tick {self.tick} (at most {MAX_PER_REQUEST} per join, "
                      f"{self.max_robots} in the run)")
            cause = REQUEST_CAP if want > MAX_PER_REQUEST else ROBOT_CAP
            self.faults.refuse(self.tick, cause, reason)
            raise Refused(cause, reason)
        template = self.robots.spec[0]
        ids = self.robots.add([self._placed_like(template, len(self.robots) + i) for i in range(want)], self.tick)
        self.record.event(self.tick, {"added": ids, "source": "join"})
        return self._give(host, ids)

    def _give(self, host: str, ids: list[int]) -> list[RobotDescr]:
        entry = self.hosts.setdefault(host, HostEntry(host))
        for rid in ids:
            self.robots.host[rid] = host
            entry.robots.add(rid)
        return [self.robot_descr(r) for r in ids]

    def release(self, host: str) -> None:
        """Before the run: ``host``'s robots go back to the unclaimed ones."""
        entry = self.hosts[host]
        entry.alive = False
        self.unclaimed = sorted([*self.unclaimed, *entry.robots])
        for rid in entry.robots:
            self.robots.host[rid] = None
        entry.robots.clear()

    def lose_host(self, host: str, cause: str) -> None:
        """``host`` is gone (crashed, silent, never registered): its robots fail with ``cause``."""
        entry = self.hosts[host]
        entry.alive = False
        self.record.event(self.tick, {"host_lost": host, "cause": cause})
        for rid in sorted(entry.robots):
            self.faults.crash(rid, self.tick, cause)

    def robot_descr(self, rid: int) -> RobotDescr:
        """What a host must know of robot ``rid`` to run it."""
        s = self.robots.spec[rid]
        self.situated.sync(self.robots.spec)
        pose = self.robots.pose(rid, POS_DIGITS)
        if self.situated.local[rid]:
            pose = [round(v, POS_DIGITS) for v in self.situated.pose(rid, self.robots.pos[rid],
                                                                     self.robots.heading[rid])]
        return RobotDescr(rid, pose, s.behaviors, s.kind, float(self.robots.range[rid]),
                          float(self.robots.sensing[rid]), float(self.robots.speed[rid]), s.knows_map,
                          **self.situated.descr(rid))

    def _placed_like(self, template: RobotSpec, rid: int) -> RobotSpec:
        """Robot ``rid``'s spec for a mid-run join: the template's parameters, a random position in the bounds.

        The draw is keyed on (tick, rid), so each robot of one join gets its own position.
        """
        lo, hi = (self.bounds if self.bounds is not None else np.array([[0.0] * self.dims, [1.0] * self.dims]))
        u = rng.uniform(self.seed, rng.PLACEMENT, self.tick, rid, np.arange(self.dims))
        return msgspec.structs.replace(template, pos=list(lo + u * (hi - lo)))

    def live_hosts(self) -> list[str]:
        return [name for name, h in self.hosts.items() if h.alive]

    # ------------------------------------------------------------ actions
    def queue(self, action: dict, source: str = "control") -> int:
        """Queue a ``control`` action for the next tick; return the tick it applies at.

        ``Refused`` (caps) or ``ValueError`` (not an action this world can apply) otherwise, with nothing queued.
        """
        ((name, value),) = action.items()
        if name == "add" and isinstance(value, list):  # caps first: refused under their own cause
            n, queued = len(value), sum(len(a["add"]) for a in self.faults.queued if "add" in a)
            cause = (REQUEST_CAP if n > MAX_PER_REQUEST
                     else ROBOT_CAP if len(self.robots) + queued + n > self.max_robots else None)
            if cause:
                reason = f"{source} add of {n} robots (at most {MAX_PER_REQUEST} per add, {self.max_robots} in the run)"
                self.faults.refuse(self.tick, cause, reason)
                raise Refused(cause, reason)
        self.faults.queue(action)
        return self.tick + 1

    def _apply(self, action: dict, source: str) -> None:
        """Apply one action; new robots go to the least loaded live host."""
        applied = self.faults.apply(action, source, self.tick)
        for rid in applied.added:
            live = [h for h in self.hosts.values() if h.alive]
            if not live:
                self.robots.kill(rid, self.tick, "no-host")
                continue
            host = min(live, key=lambda h: (len(h.robots), int(h.name[1:]) if h.name[1:].isdigit() else 0))
            self.robots.host[rid] = host.name
            host.robots.add(rid)
            host.pending_new.append(self.robot_descr(rid))
        if applied.stop and self.stop_request is None:
            self.stop_request = applied.stop

    # ------------------------------------------------------------ the tick
    def begin(self, tick: int, now: float) -> None:
        """Steps 1-2: actions due, then reach and sensing from this tick's positions; lockstep: the copies due.

        What happened between two ticks (malformed input, hosts lost) was recorded already and goes into this
        tick's record.
        """
        self.tick = tick
        self.now = now
        self.record.rec["t"] = tick
        for action, source in self.faults.due(tick):
            self._apply(action, source)
        self.tables.compute()
        self._due = None if self.realtime else self.deliver(tick)

    def inputs(self, host: str, epoch: float | None = None) -> Inputs:
        """Step 3: ``host``'s robots' inputs of this tick (``epoch``: the realtime clock's start)."""
        msg = self.tables.inputs(self.hosts[host], self._due)
        msg.epoch = epoch
        return msg

    def take(self, host: str, msg: Uplink) -> None:
        """Step 4: a host's robots' outputs; their frames wait for ``transmit``."""
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
        self._outbox.extend(got.frames)

    def take_reports(self, host: str, reports: dict[int, Any]) -> None:
        """A host's final reports, for the robots it runs."""
        for rid, rep in reports.items():
            if rid in self.hosts[host].robots:
                self.reports[rid] = rep

    def transmit(self, now: float | None = None) -> tuple[dict[str, Deliveries], list[int]]:
        """Step 5: the radio decides every frame taken since the last call, at once; the copies go in the air.

        Returns, in realtime, the ``Deliveries`` to hand each host now (each host hands a copy to its robot at
        the copy's due time; ``now``: the clock's time they leave) and the air slots that were empty before (the
        session's bookkeeping timers).
        """
        if now is not None:
            self.now = now
        frames, self._outbox = self._outbox, []
        if not frames:
            return {}, []
        r = self.robots
        t = self.tables
        out = self.medium.decide_batch(self.tick, frames, t.reach, r.alive, r.pos, r.range, t.hidden, r.tx_power)
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
        fr, dst = out.frame[ok], out.dst[ok]
        src, seq = out.src[fr], out.seq[fr]
        if not self.realtime:
            due = np.full(len(dst), float(self.tick + self.radio.latency))
            return {}, self.air.put(self._copies(frames, fr, dst, src, seq, due, out.overheard[ok]))
        due = self._due_times(frames, fr, src, seq, dst)
        slots = self.air.put(self._copies(frames, fr, dst, src, seq, due, out.overheard[ok]))
        return self.tables.deliveries(frames, fr, dst, due, ~out.overheard[ok]), slots

    def _copies(self, frames, fr, dst, src, seq, due, overheard) -> Copies:
        return Copies(dst, fr, src, seq, np.full(len(dst), self.tick, dtype=np.int64), due, overheard,
                      [(f, self.tick) for f in frames])

    def _due_times(self, frames: list[Outgoing], fr: np.ndarray, src: np.ndarray, seq: np.ndarray,
                   dst: np.ndarray) -> np.ndarray:
        """Realtime: each copy is due its drawn latency after the sender's radio call (``Outgoing.at``).

        The call is taken no earlier than ``MAX_BACKDATE_S`` before the world received the frame and never after
        it: a host cannot buy an earlier delivery by back-dating.
        """
        received = self.time()
        at = np.array([received if f.at is None else f.at for f in frames])
        start = np.minimum(received, np.maximum(at, received - MAX_BACKDATE_S))[fr]
        return start + self.medium.latencies_s(self.tick, src, seq, dst)

    def deliver(self, until: float) -> Copies | None:
        """Step 5b: the copies due by ``until`` leave the air; the delivered ones are returned.

        Each is recorded, in (receiver, src, seq) order, as ``dead`` (its receiver died at or before the copy's
        due time), overheard, or delivered.
        """
        c = self.air.pop(until)
        if c is None:
            return None
        live = self.robots.died_at[c.dst] > c.due
        if not live.all():
            for d, s_, q in zip(c.dst[~live].tolist(), c.src[~live].tolist(), c.seq[~live].tolist(), strict=True):
                self.record.dead(s_, q, d)
        heard = live & c.overheard
        if heard.any():
            self.record.overheard_arrays(c.src[heard], c.seq[heard], c.dst[heard], c.sent[heard])
        keep = live & ~c.overheard
        self.record.delivered_arrays(c.src[keep], c.seq[keep], c.dst[keep], c.sent[keep])
        return c.only(keep) if keep.any() else None

    def end(self) -> dict:
        """Steps 6-7: the tick's record (returned), then motion integrated to the next tick's positions."""
        alive = self.robots.alive_ids()
        pos = np.round(self.robots.pos[alive], POS_DIGITS).tolist()
        self.record.rec["pos"] = [[rid, *row] for rid, row in zip(alive.tolist(), pos, strict=True)]
        rec = self.record.take()
        r = self.robots
        before = r.pos.copy() if self.space is not None else None
        integrate(r.pos, r.heading, r.vel, r.speed, r.turn_rate, r.alive, self.dt, self.bounds)
        if self.space is not None:
            self.space.constrain(before, r.pos, r, self.dt)
            self.space.unblock_bodies(before, r.pos, r)
        for rid in bad_positions(r.pos, r.alive).tolist():  # the robot crashes, the run goes on
            where = r.pos[rid].tolist()
            np.clip(np.nan_to_num(r.pos[rid]), -MAX_COORD, MAX_COORD, out=r.pos[rid])
            self.counters.refused[INVALID_POSITION] += 1
            self.faults.crash(rid, self.tick, INVALID_POSITION, f"position {where!r} beyond the world's limit")
        return rec

    def state(self, rec: dict) -> State:
        """The ``state`` snapshot of a tick's record (for observers)."""
        alive = self.robots.alive_ids()
        return State(self.tick, rec["pos"], {int(r): self.robots.status[r] for r in alive},
                     self.robots.range[alive].round(POS_DIGITS).tolist(), self.objects,
                     dict(self.counters.dropped), self.counters.sent)

    # ------------------------------------------------------------ what it holds
    def status(self) -> dict:
        """The simulation's part of a ``control`` status answer."""
        return {"robots": len(self.robots), "alive": int(self.robots.alive.sum()), "unclaimed": len(self.unclaimed),
                "objects": self.objects, **self.counters.as_dict()}

    def summary(self, ticks_done: int) -> dict:
        """What result.json needs from the simulation (``ticks_done``: ticks completed)."""
        r = self.robots
        robots = {}
        for rid in range(len(r)):
            death = r.deaths.get(rid)
            robots[rid] = {
                "alive": bool(r.alive[rid]), "pose": r.pose(rid, POS_DIGITS), "host": r.host[rid],
                "joined_at": r.joined_at[rid],
                "failed": None if death is None else {"tick": death.tick, "cause": death.cause, "error": death.error},
                "status": r.status[rid], "range": float(r.range[rid]), "sensing": float(r.sensing[rid]),
            }
        world = {**self.counters.as_dict(), "per_robot": self.counters.per_robot(len(r))}
        if self.space is not None:  # collision episodes still open end at the last tick
            self.space.close(max(ticks_done - 1, 0))
            world["collisions"] = self.space.summary()
        return {"robots": robots, "reports": self.reports, "world": world, "objects": self.objects}


def wall_time() -> float:
    """The realtime simulation's time: wall-clock seconds."""
    return _time.time()

