"""A robot-host process: its entry point, its Zenoh session, its garbage-collector setting.

Kept apart from ``swarmactors.runs.launcher`` (which imports the world, and so scipy) so that a host process
imports only the robot side: the Behavior API, the host, the transport and the behaviours it runs
(tests/test_host_imports.py checks that no oracle, networkx or scipy reaches it).
"""

from __future__ import annotations

import asyncio
import dataclasses
import gc
import logging
import re
import signal
import sys
import time
from collections.abc import Callable, Collection
from contextlib import contextmanager

from swarmactors.exitcodes import EXIT_RUNTIME
from swarmactors.robot.host import RobotHost, WorldLost
from transport import Endpoints, Keys, Link, QueryError, host_loss_s, lease_settings

log = logging.getLogger(__name__)
PROGRESS_EVERY_S = 10.0  # a host's progress line, at most this often
LOG_FORMAT = "%(levelname)s %(name)s: %(message)s"  # the command line's and every host process's log lines
WORLD_GONE_S = 120.0  # after its run a ``robots`` host waits at most this long for the world to close (serve_host)


class HostError(RuntimeError):
    """A host that could not reach or join its world (exit 3, one line naming the endpoint)."""


def host_process(endpoint: str, run_id: str, count: int | None, allow: tuple[str, ...] = (),
                 watchdog_s: float = 10.0) -> None:
    """Entry point of a spawned robot-host process; exit 3 with one line when the world dies or loses it.

    SIGINT is ignored: Ctrl-C reaches the whole process group, and the world ends the run, asking this host
    for its robots' reports first (a host killed by the same Ctrl-C would lose them).
    """
    logging.basicConfig(level=logging.WARNING, format=LOG_FORMAT)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    endpoints = Endpoints(mode="peer", connect=[endpoint], extra=lease_settings(watchdog_s))
    try:
        asyncio.run(serve_host(endpoints, run_id, count, allow))
    except HostError as exc:
        print(f"swarmactors host: {exc}", file=sys.stderr, flush=True)
        sys.exit(EXIT_RUNTIME)


async def serve_host(endpoints: Endpoints, run_id: str, count: int | None, allow: Collection[str] = (),
                     wait: float = 60.0, say: Callable[[str], None] | None = None,
                     refuse: Callable[[str], None] | None = None, linger: float = 0.0) -> RobotHost:
    """Join run ``run_id`` through ``endpoints`` and run robots until the world stops; return the host.

    ``allow``: modules whose Behavior subclasses the host may build, beside the registered entry points.
    A host may start before its world: it retries with backoff for ``wait`` seconds, then raises HostError.
    ``say`` gets one line at a time: joined, the robots claimed, progress every PROGRESS_EVERY_S, a summary.
    ``refuse`` gets one line at join when the host refused the behaviour of some of its robots, naming the
    ``--allow`` that would have let it build them (those robots fail as ``refused_behavior``; the run goes on).
    After the run the host waits (at most ``linger`` seconds: ``swarmactors robots`` gives WORLD_GONE_S) until the
    world has closed, so that ``docker-compose up --abort-on-container-exit`` stops the world only once it has
    every host's reports (the hosts ``run`` spawns do not wait: the world ends them).
    """
    say = say or (lambda _line: None)
    where = ", ".join(endpoints.connect) or "the local session"
    deadline = time.monotonic() + wait
    link = await open_link(endpoints, deadline, where)
    with link, quiet_gc():
        host = RobotHost(link, Keys(run_id), count, allow)
        try:
            await host.join(timeout=max(0.0, deadline - time.monotonic()))
        except RuntimeError as exc:
            raise HostError(join_failure(str(exc), run_id, where, wait)) from None
        ids = sorted(host.robots)
        info = host.run_info
        if not ids:
            say(f"no robot left: the world at {where} (run {run_id!r}) has given all its robots to other hosts; "
                "this host has nothing to run and stays until the run ends")
        else:
            say(f"joined run {run_id!r} at {where} as host {host.name} ({info.clock}, {info.ticks} ticks): "
                f"robots {id_ranges(ids)} ({len(ids)})")
        line = refusal_line(host)
        if line and refuse is not None:
            refuse(line)
        started = time.monotonic()
        reporter = asyncio.create_task(_report_progress(host, say))
        try:
            await host.run()
        except WorldLost as exc:
            raise HostError(f"{exc} (at {where}); this host stops") from None
        except QueryError as exc:  # the session to the world broke (or the world dropped this host's step)
            raise HostError(f"lost the world of run {run_id!r} at {where} at tick {host.tick}: {exc}") from None
        finally:
            reporter.cancel()
        if linger and not host.gone:
            await until_world_closes(link, Keys(run_id), linger)
        if host.gone:
            limit = host_loss_s(host.run_info.watchdog_s)
            raise HostError(f"the world of run {run_id!r} at {where} lost this host at tick {host.tick} "
                            f"(silent longer than 2·watchdog_s + 5 = {limit:g} s); its robots are gone")
        say(host_summary(host, time.monotonic() - started))
    return host


_NOT_ALLOWED = re.compile(r"refused behaviour '([^']+)': not a registered behaviour nor in a module this host allows")
_NOT_IMPORTABLE = re.compile(r"PluginError: cannot import '([^']+)' for '([^']+)': ModuleNotFoundError")


def refusal_line(host: RobotHost) -> str | None:
    """One line for the robots whose behaviour this host could not build for want of an option or a module.

    A ``module:Class`` outside the allowlist needs ``--allow MODULE``; an allowed module the host cannot import
    needs the host started where the module is (its directory, or ``PYTHONPATH``).
    """
    refused: dict[str, list[int]] = {}
    missing: dict[str, list[int]] = {}
    for rid, robot in sorted(host.robots.items()):
        error = robot.error or ""
        if m := _NOT_ALLOWED.match(error):
            refused.setdefault(m.group(1), []).append(rid)
        elif m := _NOT_IMPORTABLE.match(error):
            missing.setdefault(m.group(2), []).append(rid)
    parts = []
    if refused:
        what = "; ".join(f"{use!r} (robots {id_ranges(ids)})" for use, ids in refused.items())
        modules = sorted({use.partition(":")[0] for use in refused})
        parts.append(f"this host refused {what}: neither a registered behaviour nor in a module it allows, so "
                     f"those robots fail; start the host with {' '.join(f'--allow {m}' for m in modules)}")
    if missing:
        what = "; ".join(f"{use!r} (robots {id_ranges(ids)})" for use, ids in missing.items())
        modules = sorted({use.partition(":")[0] for use in missing})
        parts.append(f"this host cannot import {what}, so those robots fail; start the host in the directory "
                     f"that holds {', '.join(m.replace('.', '/') for m in modules)} (.py), or put that directory "
                     "on PYTHONPATH")
    return "; ".join(parts) or None


async def until_world_closes(link: Link, keys: Keys, within_s: float) -> None:
    """Wait until the world's liveliness token vanishes (it closes once it has every host's reports), or ``within_s``.

    The token is seen first (the subscription's history); if it is not there within a second, the world is gone.
    """
    seen, gone = asyncio.Event(), asyncio.Event()
    link.watch_liveliness(keys.world_alive, lambda _key, alive: (seen if alive else gone).set())
    try:
        await asyncio.wait_for(seen.wait(), 1.0)
        await asyncio.wait_for(gone.wait(), within_s)
    except TimeoutError:
        pass


async def open_link(endpoints: Endpoints, deadline: float, where: str) -> Link:
    """A Zenoh session to ``endpoints``, retried with backoff (1, 2, 4, ... 8 s a try) until ``deadline``."""
    step = 1.0
    while True:
        left = deadline - time.monotonic()
        try_s = max(0.5, min(step, left))
        extra = dict(endpoints.extra)
        if endpoints.connect:
            extra["connect/timeout_ms"] = int(try_s * 1000)
        try:
            return Link(dataclasses.replace(endpoints, extra=extra))
        except Exception as exc:  # Zenoh's "unable to connect": the world may not be up yet
            if time.monotonic() + 0.1 >= deadline:
                raise HostError(f"no world answered at {where} ({str(exc).split(' at /')[0].strip()})") from None
            log.info("no world at %s yet (%s); retrying", where, exc)
        await asyncio.sleep(min(0.5, max(0.0, deadline - time.monotonic())))
        step = min(step * 2, 8.0)


def join_failure(error: str, run_id: str, where: str, wait: float) -> str:
    """The one line a host prints when the world would not give it robots."""
    if "has finished" in error or "in the run)" in error:  # world.py's refusals: run over, or world.max_robots
        return (f"no robot left for this host: the world at {where} (run {run_id!r}) gave every robot to other "
                f"hosts ({error.rpartition(': ')[2]})")
    if "no reply" in error:
        return (f"no world answered the join of run {run_id!r} at {where} within {wait:g} s "
                "(is --run-id the world's? see --wait)")
    return f"could not join run {run_id!r} at {where}: {error}"


def id_ranges(ids: list[int]) -> str:
    """Sorted robot ids as ranges: ``0-9, 12, 14-15``."""
    parts: list[str] = []
    start = prev = None
    for i in ids:
        if prev is not None and i == prev + 1:
            prev = i
            continue
        if start is not None:
            parts.append(str(start) if start == prev else f"{start}-{prev}")
        start = prev = i
    if start is not None:
        parts.append(str(start) if start == prev else f"{start}-{prev}")
    return ", ".join(parts) or "none"


def _frames_sent(host: RobotHost) -> int:
    return sum(r.frames_sent for r in host.robots.values())


async def _report_progress(host: RobotHost, say: Callable[[str], None]) -> None:
    total = host.run_info.ticks if host.run_info else 0
    while True:
        await asyncio.sleep(PROGRESS_EVERY_S)
        alive = sum(r.alive for r in host.robots.values())
        say(f"host {host.name}: tick {max(host.tick, 0)}/{total}, frames sent {_frames_sent(host)}, "
            f"{alive}/{len(host.robots)} robots alive")


def host_summary(host: RobotHost, wall_s: float) -> str:
    """One line at the end of a host: ticks, frames, robots alive, crashed robots with their error."""
    crashed: dict[str, list[int]] = {}  # the first line of the error -> the robots that crashed with it
    for rid, r in sorted(host.robots.items()):
        if r.error:
            crashed.setdefault(r.error.splitlines()[0], []).append(rid)
    alive = sum(r.alive for r in host.robots.values())
    line = (f"host {host.name} done: {max(host.tick, 0) + 1 if host.robots else 0} ticks in {wall_s:.1f} s, "
            f"frames sent {_frames_sent(host)}, {len(host.robots)} robots ({alive} alive)")
    if crashed:
        first = "; ".join(f"{id_ranges(ids)}: {err}" for err, ids in list(crashed.items())[:3])
        n = sum(len(ids) for ids in crashed.values())
        line += f", {n} crashed ({first}{'; ...' if len(crashed) > 3 else ''})"
    return line


@contextmanager
def quiet_gc():
    """Tune the garbage collector for a run: freeze what set-up allocated, collect rarely.

    A full collection walks every object (about 120,000 after importing scipy
    and networkx), and pauses of ~100 ms at N = 1000 took half the wall time
    (docs/benchmarks.md). Outcomes and trace hashes do not depend on it.
    """
    old = gc.get_threshold()
    gc.collect()
    gc.freeze()
    gc.set_threshold(50_000, 50, 1000)
    try:
        yield
    finally:
        gc.set_threshold(*old)
        gc.unfreeze()
