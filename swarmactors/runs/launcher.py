"""Starting a run: the world, its robot hosts, the trace, the result.

``run`` is the one entry point behind ``swarmactors run`` and the Python API.
K = 0 host processes (the default) runs the robots inside the world's process
over the same Zenoh session; K >= 1 spawns K host processes (``spawn`` start
method, fixed ``PYTHONHASHSEED``; Zenoh's runtime does not survive ``fork``)
that connect to the world's private Unix socket (``run(tcp=True)``: a loopback TCP port; docs/security.md).
"""

from __future__ import annotations

import asyncio
import dataclasses
import itertools
import json
import logging
import multiprocessing
import os
import re
import shutil
import signal
import tempfile
import time
import uuid
from collections.abc import Callable, Collection
from contextlib import contextmanager
from pathlib import Path

from swarmactors.oracle.checks import run_checks
from swarmactors.oracle.result import Result, package_version, to_jsonable
from swarmactors.oracle.trace import TraceWriter
from swarmactors.robot.host import RobotHost
from swarmactors.robot.hosting import host_process, quiet_gc
from swarmactors.robot.plugins import scenario_modules
from transport import Endpoints, Keys, Link, lease_settings, new_key
from transport.auth import RUN_SECRET_ENV, run_secret_from_env
from transport.scenario import Scenario
from world import POS_DIGITS, WorldSession

log = logging.getLogger(__name__)
HASH_SEED = "0"
HOSTS_EXIT_S = 5.0  # after the world ends, its host processes get this long (in all) to exit, then are killed
STOP_SIGNALS = {signal.SIGINT: "SIGINT", signal.SIGTERM: "SIGTERM"}  # both end a run the same way


@contextmanager
def private_endpoints(tcp: bool = False):
    """Where a local run listens: a Unix socket in a new directory only this user can open (mode 0700).

    ``tcp`` asks for an ephemeral loopback TCP port instead, which every local user can reach
    (docs/security.md). The directory is removed when the run ends.
    """
    if tcp:
        yield Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"])
        return
    folder = tempfile.mkdtemp(prefix="swarmactors-")  # created 0700
    try:
        yield Endpoints(mode="peer", listen=[f"unixsock-stream/{folder}/world.sock"])
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def run_dir(name: str, seed: int, base: Path = Path("out")) -> Path:
    """A new directory for one run, ``out/<name>/<UTC time>-s<seed>``, with ``out/<name>/latest`` pointing to it.

    Runs never overwrite each other; two in the same second get ``-2``, ``-3``... The ``latest`` link is
    replaced atomically (a new link renamed over the old one).
    """
    parent = base / name
    parent.mkdir(parents=True, exist_ok=True)
    stem = f"{time.strftime('%Y%m%dT%H%M%SZ', time.gmtime())}-s{seed}"
    for n in itertools.count(1):
        folder = parent / (stem if n == 1 else f"{stem}-{n}")
        try:
            folder.mkdir()
            break
        except FileExistsError:
            continue
    link = parent / "latest"
    tmp = parent / f".latest-{os.getpid()}"
    try:
        tmp.unlink(missing_ok=True)
        tmp.symlink_to(folder.name, target_is_directory=True)
        os.replace(tmp, link)
    except OSError as exc:  # e.g. a file system without symbolic links: the run goes on
        log.warning("could not point %s to %s: %s", link, folder.name, exc)
    return folder


def new_run_id(name: str) -> str:
    stem = re.sub(r"[^A-Za-z0-9_.-]", "-", name)[:40] or "run"
    return f"{stem}-{uuid.uuid4().hex[:8]}"


def split(n: int, k: int) -> list[int]:
    """Robot counts for k hosts: as even as possible."""
    return [n // k + (1 if i < n % k else 0) for i in range(k)]


def allowed_modules(sc: dict) -> set[str]:
    """The scenario's own behaviour modules (``module:Class`` in groups and ``add`` events): hosts may build them."""
    specs = [b for g in sc.get("robots", []) for b in g.get("behaviors", [])]
    for ev in sc.get("events", []):
        for spec in ev.get("add", []) if isinstance(ev.get("add"), list) else []:
            if isinstance(spec, dict):
                specs += [b for b in spec.get("behaviors", []) if isinstance(b, dict)]
    return scenario_modules(specs)


async def run_world(
    sc: Scenario | dict,
    out_dir: Path,
    endpoints: Endpoints,
    run_id: str,
    processes: int = 0,
    local_host: bool = True,
    on_tick: Callable[[WorldSession], None] | None = None,
    on_open: Callable[[WorldSession, Link], None] | None = None,
    run_secret: bytes | None = None,
    return_on_signal: bool = False,
    on_result: Callable[[Result], None] | None = None,
) -> Result:
    """Run a resolved scenario's world (and, if asked, its hosts) to a Result on disk.

    ``sc`` is a resolved ``Scenario`` (``swarmactors.runs.scenario.resolve``) or its data (``resolve_scenario``,
    result.json's ``scenario``), typed here once.

    ``run_secret`` seals the join replies (transport.auth); default: ``SWARMACTORS_RUN_SECRET`` if set, else a
    fresh one when this run starts its own hosts (``local_host``), which get it through the environment.

    SIGINT and SIGTERM end the run (``interrupted``, checks not run); one that comes once the world has its
    robots' reports leaves the run whole and its checks run. Either way result.json is written first; then
    the signal goes on to the caller (SIGINT as KeyboardInterrupt, SIGTERM to the handler in force before the
    run), so that a script or a test suite stops as it would have, unless ``return_on_signal`` (the command
    line, which prints the summary and exits 130), which returns the Result with ``Result.signal`` set.

    ``on_result(result)`` runs once result.json is whole, while the world's session (and its liveliness token)
    is still open: ``robots`` hosts wait for that token to vanish, so docker-compose's
    ``--abort-on-container-exit`` stops the world only after what ``on_result`` printed (the summary).
    """
    if run_secret is None:
        run_secret = run_secret_from_env() or (new_key() if local_host else None)
    loop = asyncio.get_running_loop()
    interrupted: str | None = None  # the signal that ended the run, if one did
    late: str | None = None  # a signal that came after the world had its reports: the run is whole
    world: WorldSession | None = None

    def interrupt(name: str) -> None:
        """SIGINT and SIGTERM end the run the same way; one that comes before the world exists stops it at once."""
        nonlocal interrupted, late
        if world is not None and world.finished:
            late = late or name
            return
        interrupted = name
        if world is not None:
            world.request_stop(f"interrupted ({name})", interrupted=True)

    previous = {signum: signal.getsignal(signum) for signum in STOP_SIGNALS}
    for signum, name in STOP_SIGNALS.items():  # installed before anything is written (SIGTERM: docker stop)
        try:
            loop.add_signal_handler(signum, interrupt, name)
        except (RuntimeError, ValueError):  # not the main thread
            pass
    spec = sc if isinstance(sc, Scenario) else Scenario.from_dict(sc)
    data = to_jsonable(spec.to_dict())  # result.json's and the trace header's scenario
    try:
        out_dir.mkdir(parents=True, exist_ok=True)  # noqa: ASYNC240 — one quick mkdir before the world opens
        keys = Keys(run_id)
        run = spec.run
        writer = TraceWriter(
            out_dir / "trace.msgpack",
            {"run_id": run_id, "clock": run.clock, "seed": run.seed, "pos_digits": POS_DIGITS, "scenario": data},
            compression=None if run.trace_compression == "none" else run.trace_compression,
            mode=run.trace_mode,
        )
        procs: list[multiprocessing.Process] = []
        watchdog_s = float(run.watchdog_s)
        # the session lease follows the documented rule 2·watchdog_s + 5 (transport.lease_settings)
        endpoints = dataclasses.replace(endpoints, extra={**lease_settings(watchdog_s), **endpoints.extra})
        with Link(endpoints, loop) as link:
            world = WorldSession(spec, link, keys, sinks=[writer], on_tick=on_tick, run_secret=run_secret)
            world.open()
            if on_open:
                on_open(world, link)
            if interrupted is not None:  # a signal came while the world was being set up
                world.request_stop(f"interrupted ({interrupted})", interrupted=True)
            try:
                n = len(world.sim.robots)
                k = min(processes, n)
                if k > 0:
                    endpoint = link.locators()[0]
                    procs = spawn_hosts(endpoint, run_id, split(n, k), allowed_modules(data), run_secret, watchdog_s)
                with quiet_gc():
                    try:
                        async with asyncio.TaskGroup() as tg:
                            tg.create_task(world.run())
                            if k == 0 and local_host:
                                tg.create_task(_local_host(link, keys, allowed_modules(data), run_secret))
                    except BaseExceptionGroup as group:  # the first failure as itself (e.g. robots never claimed)
                        raise group.exceptions[0] from None
            finally:
                writer.close()
                await asyncio.to_thread(end_hosts, procs, HOSTS_EXIT_S)
            # the world has its reports: a signal from here on is late and leaves a whole result.json, checks run
            summary = world.summary()
            result = write_result(assemble(data, summary, writer, run_id, processes, interrupted is not None), out_dir)
            if interrupted is None and spec.checks:
                result.data["checks"] = judge(result, spec.checks)
                result = write_result(result.data, out_dir)
            if on_result is not None:
                on_result(result)
    finally:  # the handlers stay until result.json is written, so no signal can cut it
        for signum in STOP_SIGNALS:
            try:
                loop.remove_signal_handler(signum)
                if previous[signum] is not None:
                    signal.signal(signum, previous[signum])
            except (RuntimeError, ValueError):
                pass
    result.signal = interrupted or late
    if result.signal and not return_on_signal:
        pass_on(result.signal)
    return result


def pass_on(name: str) -> None:
    """Deliver a signal that a run caught to whoever handled it before: SIGINT as KeyboardInterrupt."""
    if name == "SIGINT":
        raise KeyboardInterrupt
    signal.raise_signal(signal.SIGTERM)


def judge(result: Result, specs: list[dict]) -> list[dict]:
    """Run the scenario's checks; each outcome names the ``[[checks]]`` entry that produced it (``check``)."""
    outcomes = []
    for spec in specs:
        outcomes += [{**o, "check": spec["use"]} for o in run_checks(result, [spec])]
    return outcomes


async def _local_host(link: Link, keys: Keys, allow: Collection[str] = (), run_secret: bytes | None = None) -> None:
    host = RobotHost(link, keys, allow=allow, run_secret=run_secret)
    await host.join()
    await host.run()


def end_hosts(procs: list[multiprocessing.Process], within_s: float) -> None:
    """Wait up to ``within_s`` in all for host processes to exit, then kill the ones still running."""
    deadline = time.monotonic() + within_s
    for p in procs:
        p.join(max(0.0, deadline - time.monotonic()))
    for p in procs:
        if p.is_alive():
            p.kill()
            p.join(1.0)


def spawn_hosts(endpoint: str, run_id: str, counts: list[int], allow: Collection[str] = (),
                run_secret: bytes | None = None, watchdog_s: float = 10.0) -> list[multiprocessing.Process]:
    """Start one host process per count (``spawn`` method, fixed hash seed); ``allow`` as serve_host.

    ``watchdog_s`` sets the hosts' session lease by the documented rule (transport.lease_settings).

    ``run_secret`` reaches the children through their environment (``SWARMACTORS_RUN_SECRET``), not argv.
    """
    ctx = multiprocessing.get_context("spawn")
    allow = tuple(sorted(allow))
    with fixed_hash_seed(), _env(RUN_SECRET_ENV, run_secret.hex() if run_secret else None):
        procs = [ctx.Process(target=host_process, args=(endpoint, run_id, c, allow, watchdog_s),
                                 daemon=True) for c in counts]
        for p in procs:
            p.start()
    return procs


@contextmanager
def _env(name: str, value: str | None):
    """Set (or leave alone, if None) an environment variable for processes started inside."""
    previous = os.environ.get(name)
    if value is not None:
        os.environ[name] = value
    try:
        yield
    finally:
        if value is not None:
            if previous is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = previous


@contextmanager
def fixed_hash_seed():
    """Processes started inside get ``PYTHONHASHSEED`` = HASH_SEED (spawn children inherit the environment)."""
    previous = os.environ.get("PYTHONHASHSEED")
    os.environ["PYTHONHASHSEED"] = HASH_SEED
    try:
        yield
    finally:
        if previous is None:
            os.environ.pop("PYTHONHASHSEED", None)
        else:
            os.environ["PYTHONHASHSEED"] = previous


# what a host reports of a robot beside its behaviours' reports, and the robot entry's field for it
REPORT_FIELDS = {"_error": "error", "_log": "log", "_traceback": "traceback", "_started": "started"}


def assemble(sc: dict, summary: dict, writer: TraceWriter, run_id: str, processes: int, interrupted: bool) -> dict:
    """The result.json document (checks are added after it is on disk)."""
    robots = {}
    for rid, info in summary["robots"].items():
        entry = dict(info)
        rep = summary["reports"].get(rid, {})
        for name, value in rep.items():
            entry[REPORT_FIELDS.get(name, name)] = value
        if info["failed"] and info["failed"].get("error") and "error" not in entry:
            entry["error"] = info["failed"]["error"]
        robots[rid] = entry
    return to_jsonable(
        {
            "run_id": run_id,
            "scenario": sc,
            "seed": sc["run"]["seed"],
            "clock": sc["run"]["clock"],
            "processes": processes,
            "ticks": summary["ticks"],
            "wall_s": round(summary["wall_s"], 4),
            "version": package_version(),
            "trace": writer.path.name if writer.path and not writer.error else None,
            "trace_hash": writer.trace_hash,
            "trace_error": writer.error,
            "interrupted": interrupted,
            "stop_reason": summary["stop_reason"],
            "robots": robots,
            "world": summary["world"],
            "objects": summary["objects"],
            "metrics": metrics(sc, summary["reports"]),
            "checks": [],
        }
    )


def metrics(sc: dict, reports: dict[int, dict]) -> dict:
    """Each behaviour class's run-level metrics over every robot's report."""
    from swarmactors.robot.plugins import BEHAVIORS, resolve

    out = {}
    specs = {b["as"]: b["use"] for g in sc["robots"] for b in g["behaviors"]}
    for key, use in sorted(specs.items()):
        cls = resolve(BEHAVIORS, use)
        per_robot = {rid: rep[key] for rid, rep in reports.items() if isinstance(rep.get(key), dict)}
        try:
            out[key] = cls.metrics(per_robot)
        except Exception as exc:
            out[key] = {"metrics_error": f"{exc.__class__.__name__}: {exc}"}
    return out


def scenario_file(path: str | Path) -> None:
    """A scenario path that is a readable UTF-8 file (ScenarioError naming it otherwise, exit 2)."""
    from swarmactors.runs.scenario import ScenarioError

    p, source = Path(path), str(path)
    if p.is_dir():
        names = sorted(q.name for q in p.glob("*.toml"))
        hint = f" (it holds {', '.join(names[:5])}{', ...' if len(names) > 5 else ''})" if names else ""
        raise ScenarioError(source, "file", "is a directory, not a scenario file" + hint)
    try:
        p.read_bytes().decode("utf-8")
    except FileNotFoundError:
        raise ScenarioError(source, "file", "no such file") from None
    except UnicodeDecodeError as exc:
        raise ScenarioError(source, "file", f"not UTF-8 text (a binary file?): byte {exc.start}") from None
    except OSError as exc:
        raise ScenarioError(source, "file", f"cannot read: {exc.strerror}") from None


def validate_run(sc: dict, source: str) -> None:
    """Refuse at load what would only fail after the run (ScenarioError naming the file and key, exit 2).

    * every behaviour names a ``Behavior`` subclass (not a function, not another class);
    * a check of a protocol family (``flooding.reach``) needs a behaviour reporting under that family's name;
    * a check that declares the clocks it holds under (``fn.clocks``) is refused under another clock, naming
      the check to use instead when it declares one (``fn.instead = {"realtime": "flooding.component"}``).
    """
    from swarmactors.robot.plugins import CHECKS, PluginError, RefusedBehavior, available, resolve, resolve_behavior
    from swarmactors.runs.scenario import ScenarioError

    allow = allowed_modules(sc)
    reported, packages = set(), set()
    for g, group in enumerate(sc.get("robots", [])):
        for b, spec in enumerate(group.get("behaviors", [])):
            try:
                cls = resolve_behavior(spec["use"], allow)
            except RefusedBehavior as exc:
                raise ScenarioError(source, f"robots[{g}].behaviors[{b}].use",
                                    str(exc).removeprefix("refused behaviour ")) from None
            reported.add(spec.get("as") or spec["use"])
            packages.add(cls.__module__.rpartition(".")[0])
    families = available("swarmactors.families")
    clock = sc["run"]["clock"]
    for i, check in enumerate(sc.get("checks", [])):
        name = check["use"]
        try:
            fn = resolve(CHECKS, name)
        except PluginError:
            continue  # the scenario's own validation names it
        family = name.partition(".")[0] if ":" not in name else None
        # a family's check reads the reports under the family's name, or of a behaviour from its own package
        if family in families and family not in reported and fn.__module__.rpartition(".")[0] not in packages:
            have = ", ".join(sorted(reported)) or "none"
            raise ScenarioError(source, f"checks[{i}].use", f"{name!r} judges the {family!r} behaviour, which no "
                                f"robot runs in this scenario (behaviours reporting: {have})")
        clocks = getattr(fn, "clocks", None)
        if clocks and clock not in clocks:
            instead = (getattr(fn, "instead", None) or {}).get(clock)
            hint = f"; use {instead!r} instead" if instead else ""
            raise ScenarioError(source, f"checks[{i}].use", f"{name!r} holds only under the "
                                f"{' or '.join(clocks)} clock, and this run's clock is {clock}{hint}")


def resolve_run(scenario, processes: int | None = None, overrides: list[str] = (),
                settings: dict | None = None) -> dict:
    """The resolved scenario of a run: a TOML path, a dict as parsed from TOML or a ``swarmactors.Scenario``.

    ``settings`` are overrides written ``section__key=value``; ``overrides`` are ``"section.key=value"`` strings.
    """
    import copy

    from swarmactors.runs.scenario import read_raw, resolve_scenario, set_value

    if hasattr(scenario, "raw"):  # a swarmactors.Scenario
        raw, source = copy.deepcopy(scenario.raw), f"<Scenario {scenario.raw['run'].get('name')}>"
    elif isinstance(scenario, dict):
        raw, source = copy.deepcopy(scenario), "<dict>"
    else:
        scenario_file(scenario)
        raw, source = read_raw(scenario), str(scenario)
    for key, value in (settings or {}).items():
        set_value(raw, key.replace("__", "."), value, source)
    if processes is not None:
        set_value(raw, "run.processes", processes, source)
    sc = resolve_scenario(raw, source, list(overrides))
    validate_run(sc, source)
    return sc


async def arun(scenario, *, out: str | Path | None = None, processes: int | None = None,
               overrides: list[str] = (), tcp: bool = False, **settings) -> Result:
    """``run`` as a coroutine, for code that already runs an asyncio loop (a notebook)."""
    sc = resolve_run(scenario, processes, overrides, settings)
    out_dir = Path(out) if out is not None else run_dir(sc["run"]["name"], sc["run"]["seed"])
    with private_endpoints(tcp) as endpoints:
        return await run_world(sc, out_dir, endpoints, new_run_id(sc["run"]["name"]), processes=sc["run"]["processes"])


def run(scenario, *, out: str | Path | None = None, processes: int | None = None,
        overrides: list[str] = (), tcp: bool = False, **settings) -> Result:
    """Run a scenario (a TOML path or a dict as parsed from TOML) and return its Result.

    ``settings`` are overrides written ``section__key=value`` (``radio__loss=0.1``,
    ``run__seed=3``); ``overrides`` takes ``"section.key=value"`` strings as on
    the command line. Output goes to ``out`` as given, else to a new ``out/<run.name>/<UTC time>-s<seed>``
    (``out/<run.name>/latest`` points to it; ``launcher.run_dir``). The world listens on a private Unix
    socket (``tcp=True``: a loopback TCP port).
    """
    return asyncio.run(arun(scenario, out=out, processes=processes, overrides=overrides, tcp=tcp, **settings))


def write_result(data: dict, out_dir: Path) -> Result:
    path = out_dir / "result.json"
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(data, indent=1, allow_nan=False))
    tmp.replace(path)
    return Result(data, path)
