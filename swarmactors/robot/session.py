"""The robot host over Zenoh: joins the world and drives a ``RobotRuntime`` with what travels on the wire.

A host joins the world (``world/join``), receives its robots (ids assigned by the world), subscribes to
``down/{host}`` and registers with one query on ``up/{host}``. In lockstep each step is then one put on
``up/{host}`` carrying all its robots' outputs of the tick; the next tick's inputs arrive as one put on
``down/{host}`` (not as a query's reply: Zenoh keeps a query's state until its timeout). In realtime the host
publishes frames on ``up/{host}`` the moment its robots send them and hands over deliveries as they arrive on
``down/{host}``, each at its due time.

Everything between inputs and outputs (hook order, frame tables, the watchdog) is the runtime's
(``swarmactors.robot.runtime``); this module owns the transport: the link, the keys, sealing and verifying,
joining, registration, the liveliness of both ends, realtime timers and the final reports.
"""

from __future__ import annotations

import asyncio
import logging
import os
import sys
import time
from collections.abc import Collection

from swarmactors.robot.actor import Robot
from swarmactors.robot.precise_timer import LoopTimer, PreciseTimer, plain_loop, precise_loop
from swarmactors.robot.runtime import RT_STAMPS, RobotRuntime
from transport import Keys, Link, MalformedMessage, host_loss_s, seal, unseal
from transport.auth import run_secret_from_env, verifies
from transport.messages import (
    PROTOCOL_VERSION,
    Deliveries,
    Downlink,
    Inputs,
    JoinReply,
    JoinRequest,
    RobotOut,
    RunInfo,
    Stop,
    Uplink,
    decode,
    encode,
)

log = logging.getLogger(__name__)

# realtime: how long the thread holding the GIL keeps it when another thread waits (Python's default is 5 ms;
# Zenoh's callback threads need it to hand frames over on time)
RT_SWITCH_INTERVAL_S = 0.0002
# realtime: how a host waits for a delivery's due time: "loop", the event loop's own timers made precise
# (precise_timer.precise_loop; falls back to "thread" on a loop it cannot change), or "thread", a timer thread
# that posts to the loop (precise_timer.PreciseTimer). Benchmarks compare the two with SWARMACTORS_RT_TIMER.
RT_TIMER = os.environ.get("SWARMACTORS_RT_TIMER", "loop")


class WorldLost(RuntimeError):
    """The world went away (its liveliness token vanished, or it stopped answering) or lost this host."""


class HostSession:
    """Joins the world and runs its robots until the world says stop (``join``, then ``run``).

    After the join: ``name`` (given by the world), ``run_info``, ``runtime`` (the ``RobotRuntime`` it drives),
    ``robots`` and ``tick`` (the runtime's). ``bad_downlinks`` counts what it dropped unverified or stale;
    ``gone`` is set when the world answered that it had lost this host.
    """

    def __init__(self, link: Link, keys: Keys, count: int | None = None, allow: Collection[str] = (),
                 run_secret: bytes | None = None):
        """``allow``: the modules whose Behavior subclasses this host may build, beside registered entry points.

        ``run_secret`` (default: ``SWARMACTORS_RUN_SECRET``) authenticates the join reply; without it the join
        reply, and so the key that authenticates downlinks, is taken on trust.
        """
        self.allow = frozenset(allow)
        self.run_secret = run_secret if run_secret is not None else run_secret_from_env()
        self.bad_downlinks = 0  # downlinks and join replies dropped because they did not verify, or were stale
        self.link = link
        self.keys = keys
        self.count = count
        self.name = ""
        self.key = b""
        self.runtime: RobotRuntime | None = None
        self.gone = False  # the world answered a step with Stop(gone): it had lost this host
        self.heard_at = time.monotonic()  # the last authentic downlink, or this host's last uplink (_world_silent)
        self.silent_s = 0.0  # how long the world had been silent when this host gave up on it
        self._inbox: asyncio.Queue[Downlink] = asyncio.Queue()  # lockstep: downlinks for the step loop
        self._stopped = asyncio.Event()  # realtime: the world said stop

    @property
    def run_info(self) -> RunInfo | None:
        """The run's parameters, from the join reply (None before)."""
        return self.runtime.run if self.runtime else None

    @property
    def robots(self) -> dict[int, Robot]:
        """This host's robots by id (the runtime's)."""
        return self.runtime.robots if self.runtime else {}

    @property
    def tick(self) -> int:
        """The tick of the last inputs taken (-1 before the first)."""
        return self.runtime.tick if self.runtime else -1

    async def join(
        self,
        timeout: float = 60.0,  # noqa: ASYNC109 — a deadline for retries; each join query keeps its own 5 s timeout
    ) -> None:
        """Ask the world for robots (retrying until ``timeout``), build them, and declare this host alive."""
        req = encode(JoinRequest(self.count))
        deadline = time.monotonic() + timeout
        while True:
            try:
                reply = await self.link.query(self.keys.join, req, timeout=5.0,
                                              accept=self._verify_join if self.run_secret else None)
                if self.run_secret:
                    reply = unseal(self.run_secret, reply, what="join reply")
                break
            except Exception as exc:
                log.info("join of %s failed: %s", self.keys.join, exc)
                if time.monotonic() > deadline:
                    raise RuntimeError(f"could not join {self.keys.join}: {exc}") from None
                await asyncio.sleep(0.2)
        info = decode(reply, JoinReply, what="join reply")
        if info.version != PROTOCOL_VERSION:  # e.g. lockstep steps changed from queries to puts in version 3
            raise RuntimeError(f"the world speaks protocol version {info.version} and this host {PROTOCOL_VERSION}: "
                               "run the same swarmactors version on both")
        self.name = info.host
        self.key = info.key
        self.runtime = RobotRuntime(info.run, self.allow, self.name)
        self.runtime.adopt(info.robots)
        self.link.declare_token(self.keys.alive(self.name))

    async def run(self) -> None:
        """Run the robots until the world says stop; WorldLost when the world dies first.

        The host watches the world's liveliness token: when it vanishes (the world's process died, or its
        session lease expired) the robots stop at once and WorldLost is raised, in either clock.
        """
        if not self.name:
            await self.join()
        world_gone = asyncio.Event()
        self.link.watch_liveliness(self.keys.world_alive, lambda _key, alive: alive or world_gone.set())
        clock = asyncio.ensure_future(self._run_lockstep() if self.run_info.clock == "lockstep"
                                      else self._run_realtime())
        self.heard_at = time.monotonic()
        watch = asyncio.ensure_future(self._world_silent(world_gone))
        try:
            await asyncio.wait({clock, watch}, return_when=asyncio.FIRST_COMPLETED)
            if not clock.done():  # the world's token went: a run that was ending anyway may still finish
                await asyncio.wait({clock}, timeout=0.5)
        finally:
            watch.cancel()
            if not clock.done():
                clock.cancel()
                await asyncio.wait({clock}, timeout=1.0)
        if clock.done() and not clock.cancelled() and (clock.exception() is None or not world_gone.is_set()):
            return clock.result()  # the run's own end (or its own error)
        if self.silent_s:
            raise WorldLost(f"lost the world of run {self.keys.run_id!r} at tick {self.tick}: it sent nothing for "
                            f"{self.silent_s:.0f} s (a world tells its hosts it is there every watchdog_s; a host "
                            "stops after 2·watchdog_s + 5 s of silence)")
        raise WorldLost(f"lost the world of run {self.keys.run_id!r} at tick {self.tick}: its liveliness token "
                        "vanished (the world died, or its session dropped this host after a silence longer than "
                        "the lease, 2·watchdog_s + 5 s)")

    async def _world_silent(self, world_gone: asyncio.Event) -> None:
        """Return when the world's token vanishes, or when it sent nothing for 2·watchdog_s + 5 s.

        A world, even paused, acks each host every ``watchdog_s`` (WorldSession._keep_hosts_informed); this host's own
        uplinks count as activity too, so a long step of its own is not taken for the world's silence.
        """
        limit = host_loss_s(self.run_info.watchdog_s)
        while not world_gone.is_set():
            try:
                await asyncio.wait_for(world_gone.wait(), min(1.0, limit))
            except TimeoutError:
                quiet = time.monotonic() - self.heard_at
                if quiet > limit:
                    self.silent_s = quiet
                    return

    # -- common to both clocks -----------------------------------
    def _uplink(self, tick: int, rows: list[RobotOut] = (), reports: dict | None = None) -> bytes:
        """An uplink message, sealed with this host's key (transport.auth)."""
        self.heard_at = time.monotonic()
        return seal(self.key, encode(Uplink(self.name, tick, list(rows), reports)))

    def _verify_join(self, data: bytes) -> bool:
        return self._verify(self.run_secret, data)

    def _verify(self, key: bytes, data: bytes) -> bool:
        """A reply or downlink sealed under ``key``; anything else is counted and dropped."""
        if verifies(key, data):
            return True
        self.bad_downlinks += 1
        n = self.bad_downlinks
        level = logging.WARNING if n & (n - 1) == 0 else logging.DEBUG  # the 1st, 2nd, 4th, 8th, ... of them
        what = "downlink" if self.name else "join reply"
        log.log(level, "host %s dropped a %s that fails authentication (%d so far)",
                self.name or f"joining run {self.keys.run_id!r}", what, n)
        return False

    async def _ask(self, uplink: str, data: bytes, timeout: float) -> Downlink:  # noqa: ASYNC109 — a Zenoh query's own timeout
        """One query on ``up/{host}`` (registration, final reports) and its authentic reply, decoded."""
        reply = await self.link.query(uplink, data, timeout=timeout, accept=lambda d: self._verify(self.key, d))
        return decode(unseal(self.key, reply, what="downlink"), Downlink, what="downlink")

    def _on_down(self, key: str, payload: bytes) -> None:
        """A message on ``down/{host}``: kept only when it is sealed under this host's key."""
        if not self._verify(self.key, payload):
            return
        self.heard_at = time.monotonic()
        try:
            msg = decode(unseal(self.key, payload, what="downlink"), Downlink, what="downlink")
        except MalformedMessage as exc:
            log.warning("%s", exc)
            return
        if self.run_info.clock == "lockstep":
            self._lockstep_down(msg)
        elif isinstance(msg, Stop):
            self.runtime.stop()
            self._stopped.set()
        elif isinstance(msg, Deliveries):
            self.runtime.take_deliveries(msg)
        elif isinstance(msg, Inputs):
            self.runtime.take_inputs(msg)

    async def _send_reports(self, uplink: str) -> None:
        reports = self.runtime.reports()
        if self.bad_downlinks:
            for rep in reports.values():
                rep["_bad_downlinks"] = self.bad_downlinks  # this host's count, in each of its robots' report
        try:
            await self.link.query(uplink, self._uplink(self.tick + 1, (), reports), timeout=30.0)
        except Exception as exc:
            log.warning("final report not acknowledged: %s", exc)

    # -- lockstep --------------------------------------------------------------
    async def _run_lockstep(self) -> None:
        """Register, then step each tick's inputs from ``down/{host}`` and put the outputs on ``up/{host}``."""
        uplink = self.keys.up(self.name)
        self.link.subscribe(self.keys.down(self.name), self._on_down)
        msg = await self._ask(uplink, self._uplink(-1), 30.0)  # an Ack, or Stop(gone) if the world lost us already
        while not isinstance(msg, Stop):
            msg = await self._inbox.get()
            while isinstance(msg, Inputs):
                out = await self.runtime.step(msg)
                self.link.publish(uplink, self._uplink(msg.tick, out))
                msg = await self._inbox.get()
        self.gone = msg.gone
        if not (msg.gone or msg.bye):
            await self._send_reports(uplink)

    def _lockstep_down(self, msg: Downlink) -> None:
        """Queue a lockstep downlink, unless it is stale (a replay: inputs of a tick stepped, an old stop)."""
        if not isinstance(msg, Inputs | Stop):
            return
        if msg.tick <= self.tick if isinstance(msg, Inputs) else msg.tick < self.tick:
            self.bad_downlinks += 1
            log.warning("host %s dropped a stale downlink (tick %d, at tick %d)", self.name, msg.tick, self.tick)
            return
        self._inbox.put_nowait(msg)

    # -- realtime ----------------------------------------------------------------
    async def _run_realtime(self) -> None:
        """Register, then hand the runtime what arrives on ``down/{host}`` until the world says stop."""
        uplink = self.keys.up(self.name)
        runtime = self.runtime
        loop = asyncio.get_running_loop()
        precise = RT_TIMER == "loop" and precise_loop(loop)
        stamped = RT_STAMPS is not None
        timer = (LoopTimer(loop, runtime.deliver, stamped=stamped) if precise
                 else PreciseTimer(loop, runtime.deliver, self.name, stamped=stamped))
        switch = sys.getswitchinterval()
        sys.setswitchinterval(RT_SWITCH_INTERVAL_S)  # the timer and Zenoh threads get the GIL within this
        runtime.start_realtime(lambda rows: self.link.publish(uplink, self._uplink(runtime.tick, rows)), timer)
        self.link.subscribe(self.keys.down(self.name), self._on_down)
        try:
            await self.link.query(uplink, self._uplink(-1), timeout=30.0)
            # The epoch arrives with every tick's inputs; the registration reply predates the start.
            await self._stopped.wait()
        finally:
            runtime.stop()
            timer.close()
            if precise:
                plain_loop(loop)
            sys.setswitchinterval(switch)
        await runtime.close()
        await self._send_reports(uplink)
