"""A lockstep run in one process and one loop, with no Zenoh: the Simulation and its robots' runtimes, side by side.

``run_inprocess(scenario, hosts=K)`` steps the world's ``Simulation`` (world/sim.py) and K ``RobotRuntime``s
(swarmactors.robot) tick by tick, handing each runtime the ``Inputs`` the world would send it and taking back its
robots' ``RobotOut`` rows, exactly as the Zenoh sessions do (world/session.py, swarmactors.robot.session) but with
nothing in between: no keys, no sealing, no encoding, no network. It writes the same result.json and trace as
``swarmactors.run`` and gives the same trace hash for the same scenario and seed: that equality is the proof that
the sessions add transport and nothing else (tests/unit/test_inprocess.py checks it on pinned scenarios).

It is an API for tests, notebooks and environments built on the simulator (``InProcessRun.step`` advances one
tick); the command line keeps the Zenoh path, where every message really travels over Zenoh. Realtime runs need
the wall clock and the sessions: they are refused here.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Collection
from pathlib import Path

from swarmactors.oracle.result import Result, to_jsonable
from swarmactors.oracle.trace import TraceWriter
from swarmactors.robot import RobotRuntime
from swarmactors.runs.launcher import (
    allowed_modules,
    assemble,
    judge,
    new_run_id,
    resolve_run,
    run_dir,
    split,
    write_result,
)
from transport.messages import RobotOut, RunInfo, Uplink
from transport.scenario import Scenario
from world import POS_DIGITS, Simulation


class InProcessRun:
    """One lockstep run's Simulation and robot runtimes, stepped by ``step`` (module docstring)."""

    def __init__(self, spec: Scenario, hosts: int = 1, allow: Collection[str] | None = None,
                 sinks: Collection = ()):
        """``spec``: a resolved scenario; ``hosts``: how many runtimes share its robots (as ``--processes``).

        ``allow``: the modules whose behaviour classes the runtimes may build beside the registered ones
        (default: the scenario's own, as ``run`` allows its hosts); ``sinks`` get each tick's record.
        """
        if spec.run.clock != "lockstep":
            raise ValueError(f"run.clock = {spec.run.clock!r}: an in-process run is lockstep only "
                             "(realtime runs need the Zenoh sessions: swarmactors.run)")
        self.spec = spec
        self.sim = Simulation(spec)
        self.sinks = list(sinks)
        self.tick = 0
        self.ticks = spec.run.ticks
        self._loop: asyncio.AbstractEventLoop | None = None  # sync_step's
        allow = allowed_modules(spec.to_dict()) if allow is None else allow
        sim = self.sim
        run = RunInfo("lockstep", sim.dt, sim.seed, self.ticks, float(spec.run.watchdog_s), 0, sim.known_map)
        self.runtimes: dict[str, RobotRuntime] = {}
        n = len(sim.robots)
        for i, count in enumerate(split(n, max(1, min(hosts, n)))):
            name = f"h{i}"
            runtime = RobotRuntime(run, allow, name)
            runtime.adopt(sim.claim(name, count))
            self.runtimes[name] = runtime

    @property
    def done(self) -> bool:
        """Every tick has run, or a ``stop`` action ended the run."""
        return self.tick >= self.ticks or self.sim.stop_request is not None

    async def step(self) -> dict:
        """One tick: ``robots_step`` then ``world_step``; the tick's record."""
        return self.world_step(await self.robots_step())

    async def robots_step(self) -> dict[str, list[RobotOut]]:
        """A tick's first half: the world's begin, then every live host's runtime stepped on its inputs.

        Returns each host's robot rows; ``world_step`` takes them (an environment acts in between: swarmactors.rl).
        """
        sim, tick = self.sim, self.tick
        sim.begin(tick, float(tick))
        outs: dict[str, list[RobotOut]] = {}
        for host in sorted(sim.live_hosts()):
            outs[host] = await self.runtimes[host].step(sim.inputs(host))
        return outs

    def world_step(self, outs: dict[str, list[RobotOut]]) -> dict:
        """A tick's second half: the hosts' rows taken (by host name), transmitted at once, the tick's end."""
        sim, tick = self.sim, self.tick
        for host in sorted(outs):
            sim.take(host, Uplink(host, tick, outs[host]))
        sim.transmit()
        rec = sim.end()
        for sink in self.sinks:
            sink.record(rec)
        self.tick += 1
        return rec

    def sync_step(self) -> dict:
        """``step`` outside an event loop (its own loop, kept across ticks: behaviours may hold loop objects)."""
        if self._loop is None:
            self._loop = asyncio.new_event_loop()
        return self._loop.run_until_complete(self.step())

    def reports(self) -> None:
        """The robots' final reports, into the simulation (as the hosts' last uplinks do)."""
        for host in self.sim.live_hosts():
            self.sim.take_reports(host, self.runtimes[host].reports())


async def arun_inprocess(scenario, *, out: str | Path | None = None, hosts: int = 1,
                         overrides: list[str] = (), **settings) -> Result:
    """``run_inprocess`` inside a running event loop (a notebook's, a test's)."""
    sc = resolve_run(scenario, overrides=overrides, settings=settings)
    spec = Scenario.from_dict(sc)
    data = to_jsonable(spec.to_dict())
    out_dir = Path(out) if out is not None else run_dir(spec.run.name, spec.run.seed)
    out_dir.mkdir(parents=True, exist_ok=True)
    run = spec.run
    run_id = new_run_id(run.name)
    writer = TraceWriter(out_dir / "trace.msgpack",
                         {"run_id": run_id, "clock": run.clock, "seed": run.seed, "pos_digits": POS_DIGITS,
                          "scenario": data},
                         compression=None if run.trace_compression == "none" else run.trace_compression,
                         mode=run.trace_mode)
    t0 = time.perf_counter()
    try:
        driver = InProcessRun(spec, hosts=hosts, sinks=[writer])
        while not driver.done:
            await driver.step()
        driver.reports()
    finally:
        writer.close()
    sim = driver.sim
    summary = {"ticks": driver.tick, "wall_s": time.perf_counter() - t0, "stop_reason": sim.stop_request,
               **sim.summary(driver.tick)}
    result = write_result(assemble(data, summary, writer, run_id, 0, False), out_dir)
    if spec.checks:
        result.data["checks"] = judge(result, spec.checks)
        result = write_result(result.data, out_dir)
    return result


def run_inprocess(scenario, *, out: str | Path | None = None, hosts: int = 1, overrides: list[str] = (),
                  **settings) -> Result:
    """Run a lockstep scenario (a TOML path, a dict, or a ``swarmactors.Scenario``) in this process, without Zenoh.

    The arguments are ``swarmactors.run``'s (``hosts`` in place of ``processes``); so are result.json and the
    trace written to ``out``, and the trace hash.
    """
    return asyncio.run(arun_inprocess(scenario, out=out, hosts=hosts, overrides=overrides, **settings))
