"""The world session: a ``Simulation`` (world/sim.py) served to robot hosts over Zenoh.

The session adds transport and nothing else: the Link and its keys, sealing (transport/auth.py), joining and
registration, the lockstep barrier, liveliness, the ``control`` queryable, the ``state``/``events`` streams and
the realtime bookkeeping timers. The clock (world/clock.py) drives its three steps of a tick (``begin``,
``exchange``, ``end``), each a thin wrapper around the simulation's.

In lockstep a host registers with one Zenoh query on ``up/{host}``, then each step is a put on ``up/{host}``
carrying its outputs of the previous tick; the session puts the next tick's inputs on ``down/{host}`` only once
every registered live host is in (the barrier), and the radio then decides the tick's frames at once. The host
subscribes to ``down/{host}`` before it registers, so no input can be lost to a start-up race. Steps are not
queries because Zenoh keeps every query's state until its timeout (benchmarks/log/2026-12-01.md, "A host's memory").
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable

from transport import Keys, Link, MalformedMessage, PendingQuery, host_loss_s, pack, seal
from transport.auth import verifies
from transport.messages import (
    PROTOCOL_VERSION,
    Ack,
    JoinReply,
    JoinRequest,
    RunInfo,
    Stop,
    Uplink,
    decode,
    encode,
)
from transport.scenario import Scenario
from world.barrier import Barrier
from world.clock import LockstepClock, make_clock
from world.control import answer_control
from world.counters import Sink
from world.peers import Peers
from world.sim import Refused, Simulation

log = logging.getLogger(__name__)

INTERRUPT_REPORTS_S = 5.0  # an interrupted run waits at most this long for its hosts' final reports
REGISTER_MIN_S = 5.0  # a joined host must register within max(watchdog_s, this) of its join
UNREGISTERED = "unregistered"  # the cause of a host (and its robots) that joined and never registered


class WorldSession:
    """Serves a Simulation to robot hosts over a Link (module docstring)."""

    def __init__(self, spec: Scenario, link: Link, keys: Keys, sinks: list[Sink] = (),
                 on_tick: Callable[[WorldSession], None] | None = None, run_secret: bytes | None = None):
        run = spec.run
        self.link = link
        self.keys = keys
        self.sinks = list(sinks)
        self.on_tick = on_tick
        self.run_secret = run_secret  # seals join replies (transport.auth); None: join replies are plain
        self.sim = Simulation(spec, on_event=self._publish_event)
        self.ticks = run.ticks
        self.clock = make_clock(run.clock, self.ticks, self.sim.dt)
        if not self.lockstep:
            self.clock.on_due = self._bookkeeping
        self.watchdog_s = float(run.watchdog_s)
        self.join_timeout_s = float(run.join_timeout_s)
        self.register_within_s = max(self.watchdog_s, REGISTER_MIN_S)
        self.state_every = run.state_every
        self.peers = Peers()  # world/peers.py
        self.started = self.finished = False
        self.collecting = False  # the run is over: the session is collecting the hosts' final reports
        self.interrupted = False  # stopped by a signal: reports are awaited INTERRUPT_REPORTS_S at most
        self.stop_reason: str | None = None
        self.wall_s = 0.0
        self.barrier = Barrier()  # lockstep: each host's pending step (world/barrier.py)
        self._ready = asyncio.Event()
        self._final_reports = asyncio.Event()
        self._rt_pending: list[tuple[str, Uplink]] = []  # realtime: uplinks received, not taken yet

    @property
    def tick(self) -> int:
        return self.clock.tick

    @property
    def ticks_done(self) -> int:
        return self.clock.ticks_done

    @property
    def lockstep(self) -> bool:
        return isinstance(self.clock, LockstepClock)

    # ------------------------------------------------------------ set-up and run
    def open(self) -> None:
        """Declare the world's queryables, subscribers and liveliness watch."""
        self.link.serve(self.keys.join, self._on_join)
        self.link.serve(self.keys.control, lambda q: answer_control(self, q))
        self.link.serve(self.keys.up_all, self._on_step_query)
        self.link.subscribe(self.keys.up_all, self._on_up_put)
        self.link.watch_liveliness(self.keys.alive_all, self._on_liveliness)
        self.link.declare_token(self.keys.world_alive)  # hosts leave when it vanishes (the world died)

    async def run(self) -> None:
        """Wait until every robot is claimed, then run the clock to the end (or until stopped)."""
        informer = asyncio.ensure_future(self._keep_hosts_informed())
        try:
            await self._wait_ready()
            self.started = True
            t0 = asyncio.get_running_loop().time()
            try:
                await self.clock.run(self)
            finally:
                self.wall_s = asyncio.get_running_loop().time() - t0
                await self._collect_reports()
                self.finished = True
        finally:
            informer.cancel()

    def request_stop(self, reason: str, interrupted: bool = False) -> None:
        """Finish the current tick, then end the run (``interrupted``: SIGINT or SIGTERM, do not wait for it)."""
        if self.stop_reason is None:
            self.stop_reason = reason
        self.interrupted = self.interrupted or interrupted
        self.clock.stop()
        self.barrier.all_in.set()
        self._ready.set()

    # ------------------------------------------------------------ the tick (driven by the clock)
    def begin(self) -> None:
        """Steps 1-2 (world/sim.py); hosts that joined and never registered lose their claim first."""
        self._release_unregistered()
        self.sim.begin(self.tick, self.clock.now())
        if self.sim.stop_request:
            self.request_stop(self.sim.stop_request)

    async def exchange(self) -> None:
        """Steps 3-5: inputs to every host; in lockstep, wait for every step, take the outputs, transmit."""
        if not self.lockstep:
            for host in self._live_hosts():
                self._send(host, self.sim.inputs(host, epoch=self.clock.epoch))
            return
        self.barrier.open(self.tick)
        for host in self._live_hosts():
            # a host that joined since the last tick may not have sent its registration yet: it gets
            # inputs from the tick after its registration arrives (the barrier counts a registration as in)
            if self.barrier.release(host):
                self._send(host, self.sim.inputs(host))
        await self._await_steps()
        for host in sorted(self._live_hosts()):
            msg = self.barrier.step(host)
            if msg is not None:
                self.sim.take(host, msg)
        self.sim.transmit()  # once per tick, over every frame of the tick

    def end(self) -> None:
        """Steps 6-7: record (to the sinks and the ``state`` stream), integrate motion."""
        rec = self.sim.end()
        for sink in self.sinks:
            sink.record(rec)
        # a snapshot nobody subscribes to is not built
        if self.state_every and self.tick % self.state_every == 0 and self.link.subscribed(self.keys.state):
            self.link.publish(self.keys.state, encode(self.sim.state(rec)), reliable=False)
        if self.on_tick:
            self.on_tick(self)

    # ------------------------------------------------------------ downlinks
    def _send(self, host: str, msg) -> None:
        self.link.publish(self.keys.down(host), self.peers.seal(host, msg))

    async def _keep_hosts_informed(self) -> None:
        """Every ``watchdog_s``, an ``Ack`` to each registered host that heard nothing for that long (world/peers.py).

        A paused world, or one waiting for its start or a slow host, is not taken for a silent one.
        """
        while True:
            await asyncio.sleep(self.watchdog_s)
            for host in self.peers.quiet(self._live_hosts(), self.barrier.held, self.watchdog_s):
                self._send(host, Ack(self.clock.epoch))

    def _publish_event(self, ev: dict) -> None:
        self.link.publish(self.keys.events, pack(ev), reliable=False)

    # ------------------------------------------------------------ joining
    def _on_join(self, q: PendingQuery) -> None:
        try:
            if not q.payload:
                raise MalformedMessage("empty join request (a host sends a JoinRequest map)")
            req = decode(q.payload, JoinRequest, what="join request")
        except MalformedMessage as exc:
            self.sim.record.malformed(None, str(exc))
            q.reply_error(str(exc))
            return
        if self.finished or self.collecting:
            q.reply_error("the run has finished")
            return
        name = f"h{len(self.peers)}"
        try:
            robots = self.sim.join(name, req.count) if self.started else self.sim.claim(name, req.count)
        except Refused as exc:
            q.reply_error(str(exc))
            return
        name, peer = self.peers.join()
        log.info("host %s joined with robots %s", name, [r.id for r in robots])
        sim = self.sim
        run = RunInfo(self.clock.name, sim.dt, sim.seed, self.ticks, self.watchdog_s, self.tick, sim.known_map)
        reply = encode(JoinReply(name, peer.key, PROTOCOL_VERSION, robots, run))
        q.reply(seal(self.run_secret, reply) if self.run_secret else reply)
        self._check_ready()

    def _check_ready(self) -> None:
        if not self.sim.unclaimed and all(h in self.barrier.held for h in self._live_hosts()):
            self._ready.set()

    async def _wait_ready(self) -> None:
        """Wait until every robot is claimed and every claiming host registered (``join_timeout_s`` at most).

        A host that claimed robots and does not register within ``register_within_s`` gives them back to the
        unclaimed ones (``_release_unregistered``), for another host to claim.
        """
        deadline = time.monotonic() + self.join_timeout_s
        while not self._ready.is_set():
            left = deadline - time.monotonic()
            if left <= 0:
                claimed = ", ".join(f"{n} ({len(h.robots)})" for n, h in self.sim.hosts.items()) or "none"
                waiting = [h for h in self._live_hosts() if h not in self.barrier.held]
                raise RuntimeError(
                    f"{len(self.sim.unclaimed)} robot(s) were not claimed by any host within "
                    f"{self.join_timeout_s:.0f} s (robot hosts must join {self.keys.join}); hosts that claimed "
                    f"robots: {claimed}" + (f"; never registered: {', '.join(waiting)}" if waiting else ""))
            try:
                await asyncio.wait_for(self._ready.wait(), min(left, 0.5))
            except TimeoutError:
                self._release_unregistered()

    def _release_unregistered(self, every: bool = False) -> None:
        """A host that joined and did not register within ``register_within_s`` (``every``: at all) loses its claim.

        Before the run starts its robots go back to the unclaimed ones; during the run, and at its end, they crash
        with the cause ``unregistered`` (the lockstep barrier never waited for them: ``_barrier_hosts``). Counted
        under ``world.refused.unregistered``.
        """
        for host, ago in self.peers.late(self._live_hosts(), self.barrier.held, self.register_within_s, every):
            robots = len(self.sim.hosts[host].robots)
            self.sim.faults.refuse(self.tick, UNREGISTERED, f"host {host} claimed {robots} robot(s) {ago:.1f} s "
                                                            f"ago and never registered (a host registers within "
                                                            f"{self.register_within_s:g} s)")
            if self.started:
                self._lose_host(host, UNREGISTERED)
            else:
                self.sim.release(host)
                self.sim.record.event(self.tick, {"host_lost": host, "cause": UNREGISTERED})

    # ------------------------------------------------------------ uplinks
    def _on_step_query(self, q: PendingQuery) -> None:
        """A query on ``up/{host}``: the host's registration (tick -1) or its final reports, in either clock.

        Each is answered at once. Lockstep steps are puts (``_on_up_put``): a query stays in Zenoh's memory
        until its timeout, so one per tick would grow a host by about 0.8 KB a step.
        """
        host = self.keys.host_of(q.key)
        if host in self.sim.hosts and not self.sim.hosts[host].alive:
            q.reply(self.peers.seal(host, Stop(self.tick, gone=True)))
            return
        msg = self._decode_up(host, q.payload)
        if msg is None:
            q.reply_error("malformed or unauthenticated step")
            return
        if not self.lockstep:
            self._take_realtime([(host, msg)])
            q.reply(self.peers.seal(host, Ack(self.clock.epoch)))
            if msg.tick == -1:
                self.peers[host].registered = True
                self.barrier.held[host] = (-1, None)
                self._check_ready()
                if self.collecting:  # registered after the stop went out: it gets its own
                    self._send(host, Stop(self.tick))
            return
        if msg.tick != -1 and msg.reports is None:
            problem = self._step_problem(host, msg) or f"a step of tick {msg.tick} as a query (steps are puts)"
            self.sim.record.malformed(None, f"step from {host}: {problem}")
            q.reply_error(problem)
            return
        problem = self._step(host, msg)
        if problem:
            q.reply_error(problem)
        else:
            q.reply(self.peers.seal(host, Stop(self.tick, bye=True) if msg.reports is not None else Ack(0.0)))

    def _step(self, host: str, msg: Uplink) -> str | None:
        """Lockstep: hold a host's registration or step for the barrier, or take its reports; the problem if not.

        A step or registration that arrives after the run ended is answered with ``Stop``: its host reports now.
        """
        peer = self.peers[host]
        if self.collecting and msg.reports is None:
            peer.registered = True
            self._send(host, Stop(self.tick))
            return None
        problem = self._step_problem(host, msg)  # stale, future or repeated: never held
        if problem:
            self.sim.record.malformed(None, f"step from {host}: {problem}")
            return problem
        if msg.reports is not None:
            self._take_reports(host, msg.reports)
            return None
        if msg.tick == -1:
            peer.registered = True
        self.barrier.hold(host, msg, self._barrier_hosts() if self.started else [])
        if not self.started:
            self._check_ready()
        return None

    def _step_problem(self, host: str, msg: Uplink) -> str | None:
        peer = self.peers[host]
        return self.barrier.problem(host, msg, peer.registered, peer.reported, self.started, self.collecting)

    def _on_up_put(self, key: str, payload: bytes) -> None:
        host = self.keys.host_of(key)
        if host in self.sim.hosts and not self.sim.hosts[host].alive:
            if self.lockstep and verifies(self.peers[host].key, payload):  # a host lost to the watchdog wakes up
                self._send(host, Stop(self.tick, gone=True))
            return
        msg = self._decode_up(host, payload)
        if msg is None:
            return
        if self.lockstep:
            self._step(host, msg)
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
        self._take_realtime(pending)

    def _take_realtime(self, uplinks: list[tuple[str, Uplink]]) -> None:
        """Realtime: take the uplinks, transmit their frames, hand the deliveries over, set the bookkeeping."""
        for host, msg in uplinks:
            if msg.reports is not None:
                self._take_reports(host, msg.reports)
            self.sim.take(host, msg)
        deliveries, slots = self.sim.transmit(now=self.clock.now())
        for host, msg in deliveries.items():
            self._send(host, msg)
        wall = time.time()
        self.clock.after([s * self.sim.air.width - wall for s in slots], slots)

    def _bookkeeping(self, slot: int) -> None:
        """Realtime: a slot of the air fell due; its copies are recorded with their fates (world/sim.py)."""
        if not self.finished:
            self.sim.deliver(slot * self.sim.air.width)

    def _decode_up(self, host: str, payload: bytes) -> Uplink | None:
        """Verify (per-host key) and decode an uplink; count and return None when it is bad."""
        try:
            return self.peers.open(host, payload)
        except MalformedMessage as exc:
            self.sim.record.malformed(None, str(exc))
            return None

    def _take_reports(self, host: str, reports: dict) -> None:
        self.sim.take_reports(host, reports)
        self.peers[host].reported = True
        self._check_reports_in()

    # ------------------------------------------------------------ hosts lost
    def _on_liveliness(self, key: str, alive: bool) -> None:
        host = self.keys.host_of(key)
        entry = self.sim.hosts.get(host)
        if (alive or entry is None or not entry.alive or self.finished
                or (self.collecting and self.peers[host].reported)):
            return  # a host may leave once the run is over and it delivered its final report; before, it is lost
        self._lose_host(host, "host-lost")

    def _lose_host(self, host: str, cause: str) -> None:
        self.sim.lose_host(host, cause)
        self.barrier.release(host)
        if self.lockstep:  # a host that is only slow reads this when it wakes, and leaves with one line
            self._send(host, Stop(self.tick, gone=True))
        if self.started:
            self.barrier.check(self._barrier_hosts())
        self._check_reports_in()

    # ------------------------------------------------------------ control (world/control.py)
    def status(self) -> dict:
        """The run as the ``status`` control command tells it."""
        return {
            "run_id": self.keys.run_id, "clock": self.clock.name, "tick": self.tick, "ticks": self.ticks,
            "started": self.started, "finished": self.finished,
            "paused": isinstance(self.clock, LockstepClock) and self.clock.paused,
            "hosts": {h: sorted(self.sim.hosts[h].robots) for h in self._live_hosts()},
            **self.sim.status(),
        }

    # ------------------------------------------------------------ hosts and the lockstep barrier
    def _live_hosts(self) -> list[str]:
        return self.sim.live_hosts()

    def _barrier_hosts(self) -> list[str]:
        """The hosts the lockstep barrier waits for: live and registered (a join alone never stalls a tick)."""
        return [h for h in self._live_hosts() if self.peers[h].registered or h in self.barrier.held]

    async def _await_steps(self) -> None:
        """Wait for every registered live host's step; a host silent past the watchdog loses its robots."""
        limit = host_loss_s(self.watchdog_s)
        if not await self.barrier.wait(self._barrier_hosts(), limit):
            for host in self._barrier_hosts():
                if not self.barrier.stepped(host):  # whatever else it sent
                    log.error("host %s did not finish tick %d within %.1f s", host, self.tick, limit)
                    self._lose_host(host, "watchdog")

    def _check_reports_in(self) -> None:
        if all(self.peers[h].reported for h in self._live_hosts()):
            self._final_reports.set()

    async def _collect_reports(self) -> None:
        """Tell every live host to stop and wait (bounded) for its robots' reports."""
        stop = Stop(self.tick)
        self.collecting = True
        self._release_unregistered(every=True)  # robots that never ran: none of their hosts will report
        self._check_reports_in()
        if self.lockstep:  # to the hosts waiting for inputs; a step still on its way gets its Stop when it comes
            self.barrier.open(self.tick)
            for host in self._live_hosts():
                if self.barrier.release(host):
                    self._send(host, stop)
        else:
            for host in self._live_hosts():
                self._send(host, stop)
        try:
            wait = min(self.watchdog_s + 5.0, INTERRUPT_REPORTS_S) if self.interrupted else self.watchdog_s + 5.0
            await asyncio.wait_for(self._final_reports.wait(), wait)
        except TimeoutError:
            log.warning("some hosts sent no final report")

    # ------------------------------------------------------------ summary
    def summary(self) -> dict:
        """Everything result.json needs from the world."""
        return {"ticks": self.ticks_done, "wall_s": self.wall_s, "stop_reason": self.stop_reason,
                **self.sim.summary(self.ticks_done)}
