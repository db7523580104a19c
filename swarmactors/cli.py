"""The ``swarmactors`` command line.

Exit codes: 0 the run finished and every check passed; 1 a check failed;
2 bad input (nothing started); 3 the run could not complete (e.g. robots never
claimed); 130 interrupted by SIGINT or SIGTERM (trace and a partial result.json written).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import logging
import os
import re
import signal
import sys
from contextlib import nullcontext
from pathlib import Path

from rich.console import Console

from swarmactors.exitcodes import EXIT_CHECK, EXIT_INPUT, EXIT_INTERRUPTED, EXIT_OK, EXIT_RUNTIME, run_exit
from swarmactors.robot.hosting import WORLD_GONE_S, HostError, refusal_line, serve_host
from swarmactors.robot.plugins import BEHAVIORS, COMMANDS, PluginError, available, family_command, resolve
from swarmactors.runs import scenario as scenario_mod
from swarmactors.runs.launcher import new_run_id, private_endpoints, run_dir, run_world, scenario_file, validate_run
from swarmactors.runs.progress import RunProgress, crash_tracebacks, summary_table
from swarmactors.runs.scenario import ScenarioError
from swarmactors.tools import export as export_cli
from swarmactors.tools import figures as figures_cli
from swarmactors.tools import newproject
from transport import Endpoints, Keys, Security, ensure_files, lease_settings
from transport.auth import RUN_SECRET_ENV
from transport.config import check_endpoint

INSECURE_WARNING = ("warning: running without --secure on {where}: {who} can join this run, read its traffic "
                    "and answer its hosts (docs/security.md)")



class UsageError(Exception):
    pass


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # exit 2 with the message, as for any bad input
        self.print_usage(sys.stderr)
        self.exit(EXIT_INPUT, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="swarmactors", description="Robot swarms as asynchronous actors over Eclipse Zenoh.")
    p.add_argument("-v", "--verbose", action="store_true", help="log at INFO level (and show tracebacks)")
    p.add_argument("--version", action="version", version=f"swarmactors {_version()}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    def scenario_args(sp, out_help: str = "output directory, used as given (default: a new "
                      "out/<run.name>/<UTC time>-s<seed>, with out/<run.name>/latest pointing to it)"):
        sp.add_argument("scenario", help="scenario TOML file")
        sp.add_argument("--seed", type=int, help="override run.seed")
        sp.add_argument("--clock", choices=["lockstep", "realtime"], help="override run.clock")
        sp.add_argument("--trace", choices=["off", "summary", "full"],
                        help="override run.trace: no trace file, one without the per-delivery rows, or all "
                             "(the trace hash is the same in every mode)")
        sp.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help="override any scenario key (repeatable), e.g. radio.loss=0.1 or robots.0.count=50")
        sp.add_argument("--out", type=Path, help=out_help)
        sp.add_argument("--quiet", action="store_true", help="no progress display, no table")
        sp.add_argument("--json", action="store_true", help="print result.json's summary as JSON on stdout")

    run = sub.add_parser("run", help="run a scenario: world and robots, progress, result.json, trace, plot")
    scenario_args(run)
    run.add_argument("--processes", type=int, help="robot host processes K (0 = robots in the world's process)")
    run.add_argument("--tcp", action="store_true",
                     help="listen on a loopback TCP port (reachable by every local user) instead of a private "
                          "Unix socket")
    _view_args(run)

    world = sub.add_parser("world", help="run only the world; robot hosts join with `swarmactors robots`")
    scenario_args(world)
    world.add_argument("--listen", action="append", default=[], help="Zenoh endpoint to listen on (repeatable)")
    world.add_argument("--connect", action="append", default=[], help="Zenoh endpoint to connect to (repeatable)")
    world.add_argument("--mode", choices=["peer", "router"], default="router")
    world.add_argument("--run-id", default="swarm", help="run id shared with the robot hosts (default: swarm)")
    world.add_argument("--secure", type=Path, metavar="DIR",
                       help="TLS, a join credential and access control; certificates are made in DIR if missing")
    world.add_argument("--tls-name", action="append", default=[],
                       help="extra DNS name or IP address for the world's certificate (repeatable)")
    _view_args(world)

    chk = sub.add_parser("check", help="run a protocol family's conformance suite against an implementation")
    chk.add_argument("family", nargs="?", default="all", help="family name, or all (default)")
    chk.add_argument("--behavior", help="module:Class of your implementation (default: the built-in one)")
    size = chk.add_mutually_exclusive_group()
    size.add_argument("--quick", dest="mode", action="store_const", const="quick", help="the quick suite (default)")
    size.add_argument("--full", dest="mode", action="store_const", const="full", help="the full suite")
    chk.set_defaults(mode="quick")
    chk.add_argument("--clock", choices=["lockstep", "realtime"], help="only the cases of this clock")
    chk.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    chk.add_argument("--cluster", metavar="tcp://HOST:8786",
                     help="run the cases on this Dask scheduler's workers (docs/scaling.md)")
    _cluster_certs_arg(chk)
    chk.add_argument("--json", type=Path, metavar="OUT", help="write the results as JSON")
    chk.add_argument("--junit", type=Path, metavar="OUT", help="write JUnit XML")
    chk.add_argument("--out", type=Path, default=Path("out/check"), help="where cases write their runs")
    chk.add_argument("--no-determinism", action="store_true", help="skip the 2-process trace-hash comparison")

    robots = sub.add_parser("robots", help="run a robot host that joins a world")
    robots.add_argument("--connect", action="append", required=True, help="the world's Zenoh endpoint")
    robots.add_argument("--run-id", default="swarm")
    robots.add_argument("--count", type=int, help="robots to ask for (default: all unclaimed)")
    robots.add_argument("--mode", choices=["peer", "client"], default="client")
    robots.add_argument("--secure", type=Path, metavar="DIR", help="directory with ca.pem and host.credential")
    robots.add_argument("--allow", action="append", default=[], metavar="MODULE",
                        help="a module whose Behavior classes this host may run (repeatable): a scenario's "
                             "use = \"mine:MyBehavior\" needs --allow mine here (the world cannot grant it); "
                             "registered behaviours are always allowed, nothing else is")
    robots.add_argument("--wait", type=float, default=60.0, metavar="S",
                        help="keep trying to reach and join the world for S seconds, with backoff (default 60, "
                             "as the world's run.join_timeout_s), then exit 3")
    robots.add_argument("--quiet", action="store_true", help="print only warnings and errors")

    lst = sub.add_parser("list", help="list what is installed: behaviors, checks, families or scenarios")
    lst.add_argument("what", choices=["behaviors", "checks", "families", "scenarios"])

    view = sub.add_parser("view", help="watch a running world in the browser (live viewer)")
    view.add_argument("--connect", default="tcp/127.0.0.1:7447", help="the world's Zenoh endpoint")
    view.add_argument("--run", dest="run_id", help="run id (default: the only run answering there)")
    _server_args(view, "--port", "--host")
    _foxglove_args(view, "instead of the web page, serve the run to Foxglove on this WebSocket port")

    replay = sub.add_parser("replay", help="replay a trace: in the browser with a time slider, or as GIF/MP4")
    replay.add_argument("trace", type=Path, help="a trace.msgpack file (or a run's output directory)")
    what = replay.add_mutually_exclusive_group()
    what.add_argument("--view", action="store_true", help="serve the page with a time slider (the default)")
    what.add_argument("--gif", type=Path, metavar="OUT", help="write an animated GIF")
    what.add_argument("--mp4", type=Path, metavar="OUT", help="write an MP4 (needs ffmpeg)")
    what.add_argument("--events", action="store_true",
                      help="print the run's control actions as [[events]] for a scenario")
    replay.add_argument("--every", type=int, default=1, help="animation: render every N-th tick (default 1)")
    replay.add_argument("--fps", type=float, default=10.0, help="animation: frames per second (default 10)")
    replay.add_argument("--field", help="animation: status field that colours robots (default: the protocol's)")
    replay.add_argument("--quiet", action="store_true", help="no progress display")
    replay.add_argument("--no-verify", action="store_true",
                        help="replay a trace whose hashes do not match (a warning instead of exit 2)")
    _server_args(replay, "--port", "--host")
    _foxglove_args(replay, "instead of the web page, play the trace to Foxglove on this WebSocket port")
    replay.add_argument("--rate", type=float, default=10.0, help="--foxglove: ticks per second (default 10)")

    sweep = sub.add_parser("sweep", help="run a grid of parameters x trials over worker processes, to a CSV")
    scenario_args(sweep, "output directory (default out/<run.name>-sweep; a sweep resumes there)")
    sweep.add_argument("--grid", action="append", default=[], metavar="SECTION.KEY=V1,V2,...",
                       help="values of one key to sweep (repeatable: the grid is their product)")
    sweep.add_argument("--trials", type=int, help="runs per grid point, seeds derived from run.seed (default 1, "
                       "or the sweep file's)")
    sweep.add_argument("--workers", type=int, default=max(1, (os.cpu_count() or 2) - 1),
                       help="worker processes (default: CPUs - 1)")
    sweep.add_argument("--keep", choices=["all", "failed", "none"], default="failed",
                       help="which trials keep their result.json and trace (default: failed)")
    sweep.add_argument("--cluster", metavar="tcp://HOST:8786",
                       help="run the trials on this Dask scheduler's workers instead of local processes "
                            "(docs/scaling.md)")
    _cluster_certs_arg(sweep)
    certs = sub.add_parser("cluster-certs", help="create the CA and the certificate of a Dask cluster with TLS")
    certs.add_argument("directory", type=Path, help="where ca.pem, cluster.pem and cluster.key go (kept if there)")
    certs.add_argument("--name", action="append", default=[], help="another name the certificate is valid for")
    _family_commands(sub)  # the families' own subcommands (TSC's schedule, ...)
    export_cli.add_parser(sub)  # swarmactors export RUN
    newproject.add_parser(sub)  # swarmactors new NAME
    figures_cli.add_parser(sub)  # swarmactors figures [--plot|--run] [ID...]
    schema = sub.add_parser("schema", help="print the JSON Schema of a scenario file, for editors that complete and "
                                           "check TOML (docs/scenarios.md)")
    schema.add_argument("--out", type=Path, help="write it to this file instead of standard output")
    return p


def _family_commands(sub) -> None:
    """Add each family's subcommands; one that cannot load, or takes a name already used, is reported and skipped."""
    from swarmactors.robot.plugins import family_of

    for name in sorted(available(COMMANDS)):
        if name in sub.choices:
            print(f"warning: family {family_of(COMMANDS, name)!r}: subcommand {name!r} is already a swarmactors "
                  "command; skipped", file=sys.stderr)
            continue
        try:
            family_command(name).add_parser(sub)
        except Exception as exc:  # a broken family costs its own subcommand, never the command line
            print(f"warning: {_one_line(exc)}; subcommand {name!r} skipped", file=sys.stderr)


def _cluster_certs_arg(sp) -> None:
    sp.add_argument("--cluster-certs", type=Path, metavar="DIR",
                    help="with --cluster tls://…: the directory of ca.pem, cluster.pem and cluster.key "
                         "(swarmactors cluster-certs DIR; default $SWARMACTORS_CLUSTER_CERTS)")


def _server_args(sp, port: str, host: str) -> None:
    sp.add_argument(port, dest="view_port", type=int, default=8050, metavar="PORT",
                    help="viewer HTTP port (default 8050; 0 picks a free one)")
    sp.add_argument(host, dest="view_host", default="127.0.0.1", metavar="ADDR",
                    help="address the viewer listens on (default 127.0.0.1)")


def _foxglove_args(sp, what: str) -> None:
    sp.add_argument("--foxglove", nargs="?", type=int, const=8765, metavar="PORT",
                    help=f"{what} (default 8765; 0 picks a free one; needs the [foxglove] extra)")
    sp.add_argument("--foxglove-host", default="127.0.0.1", metavar="ADDR",
                    help="address the Foxglove feed listens on (default 127.0.0.1)")


def _view_args(sp) -> None:
    sp.add_argument("--view", action="store_true",
                    help="serve the live viewer (lockstep runs wait after tick 0 for ▶ in the page)")
    _server_args(sp, "--view-port", "--view-host")
    _foxglove_args(sp, "serve the run live to Foxglove on this WebSocket port (docs/foxglove.md)")
    sp.add_argument("--no-plots", action="store_true", help="do not write the per-run charts beside result.json")


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("swarmactors")
    except PackageNotFoundError:
        return "unknown"


def main(argv: list[str] | None = None) -> int:
    """Run one command; errors end in one line on stderr and an exit code, never a traceback (``-v`` shows it)."""
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")
    try:
        with _cluster_certs(getattr(args, "cluster_certs", None)):
            return _main(args)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # stdout went away (``swarmactors list checks | head``): nothing more to say
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    except Exception as exc:  # the last resort: one line naming the error, the traceback only with -v
        if args.verbose:
            raise
        code = EXIT_INPUT if isinstance(exc, (OSError, UnicodeError, ValueError, PluginError)) else EXIT_RUNTIME
        print(f"error: {_one_line(exc)} (run with -v for the traceback)", file=sys.stderr)
        return code


@contextlib.contextmanager
def _cluster_certs(folder: Path | None):
    """``--cluster-certs DIR`` as ``$SWARMACTORS_CLUSTER_CERTS`` for one command (``swarmactors.runs.cluster``)."""
    if folder is None:
        yield
        return
    before = os.environ.get("SWARMACTORS_CLUSTER_CERTS")
    os.environ["SWARMACTORS_CLUSTER_CERTS"] = str(folder)
    try:
        yield
    finally:
        if before is None:
            del os.environ["SWARMACTORS_CLUSTER_CERTS"]
        else:
            os.environ["SWARMACTORS_CLUSTER_CERTS"] = before


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{exc.__class__.__name__}: {text[0] if text else ''}".rstrip(": ")


def _main(args) -> int:
    err = Console(stderr=True, no_color=not sys.stderr.isatty(), soft_wrap=True)
    _user_modules_importable(getattr(args, "scenario", None))
    try:
        if args.command == "list":
            return _list(args.what)
        if args.command == "cluster-certs":
            from transport.security import cluster_files

            folder = cluster_files(args.directory, args.name)
            print(f"{folder}: ca.pem, cluster.pem and cluster.key for --cluster tls://… (docs/scaling.md)")
            return EXIT_OK
        if args.command == "list":
            return _list(args.what)
        if args.command == "robots":
            return _robots(args)  # bad credentials files raise ValueError: exit 2
        if args.command == "check":
            return _check(args, err)
        if args.command in available(COMMANDS) and getattr(args, "handler", None) is not None:
            return family_command(args.command).command(args)  # exit codes as the family's module documents
        if args.command == "schema":
            from swarmactors.runs.schema import json_schema

            if args.out:
                args.out.write_text(json_schema() + "\n", encoding="utf-8")
            else:
                print(json_schema())
            return EXIT_OK
        if args.command in ("export", "new"):
            return (export_cli if args.command == "export" else newproject).command(args)
        if args.command == "figures":
            return figures_cli.command(args)
        if args.command == "sweep":
            scenario_file(args.scenario)
        if args.command == "view":
            check_endpoint(args.connect)  # bad input (exit 2), not "cannot reach"
        if args.command in ("view", "replay", "sweep"):
            from swarmactors.tools.see import command  # the viewer, replays and sweeps (docs/viewer.md)

            if args.command == "sweep":
                with _signals_interrupt():
                    return command(args, err)
            return command(args, err)
        sc = _load(args)
    except (ScenarioError, UsageError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)  # plain text: paths and keys must not be wrapped
        return EXIT_INPUT
    try:
        return _run(args, sc, err)
    except UsageError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except (RuntimeError, OSError) as exc:
        print(f"run failed: {exc}", file=sys.stderr)
        return EXIT_RUNTIME


def _shipped_hint(scenario: str) -> None:
    """A missing scenario named like a shipped one: say where that one is (outside a checkout, say)."""
    path = Path(scenario)
    if path.exists():
        return
    same = [p for p in shipped_scenarios() if p.name == path.name or p.stem == path.name]
    if same:
        raise UsageError(f"{scenario}: no such file; the shipped scenario of that name is {same[0]}")


def _user_modules_importable(scenario: str | None) -> None:
    """Let ``use = "module:Class"`` find modules beside the scenario file and in the current directory."""
    beside = []
    if scenario:
        try:
            beside = [str(Path(scenario).resolve().parent)]
        except (OSError, RuntimeError):  # a symlink loop: loading the scenario says so, naming the file
            pass
    for folder in beside + [str(Path.cwd())]:
        if folder not in sys.path:
            sys.path.append(folder)


def _load(args) -> dict:
    _shipped_hint(args.scenario)
    scenario_file(args.scenario)
    if args.command in ("run", "world") and args.foxglove is not None:
        from swarmactors.tools.see import check_foxglove

        check_foxglove(args)  # the extra is installed, and --view is not asked too (exit 2)
    overrides = list(args.set)
    if args.seed is not None:
        overrides.append(f"run.seed={args.seed}")
    if args.clock is not None:
        overrides.append(f'run.clock="{args.clock}"')
    if args.trace is not None:
        overrides.append(f'run.trace="{args.trace}"')
    if getattr(args, "processes", None) is not None:
        if args.processes < 0:
            raise UsageError(f"--processes {args.processes}: must be >= 0")
        overrides.append(f"run.processes={args.processes}")
    sc = scenario_mod.load(args.scenario, overrides)
    validate_run(sc, args.scenario)
    return sc


def _run(args, sc: dict, err: Console) -> int:
    if args.out is not None and args.out.exists() and not args.out.is_dir():
        raise UsageError(f"--out {args.out}: is a file, not a directory")
    out_dir = args.out or run_dir(sc["run"]["name"], sc["run"]["seed"])
    if args.command == "world":
        run_id, local = args.run_id, False
        Keys(run_id)
        endpoints = _world_endpoints(args, run_id)
    else:
        endpoints = None  # a private Unix socket unless --tcp (launcher.private_endpoints)
        run_id, local = new_run_id(sc["run"]["name"]), True
    with nullcontext(endpoints) if endpoints is not None else private_endpoints(args.tcp) as where:
        return _run_on(args, sc, err, out_dir, where, run_id, local)


def _run_on(args, sc: dict, err: Console, out_dir: Path, endpoints: Endpoints, run_id: str, local: bool) -> int:
    progress = RunProgress(sc["run"]["ticks"], sc["run"]["name"], quiet=args.quiet)
    session = None
    if args.view or args.foxglove is not None:
        from swarmactors.tools.see import view_session

        session = view_session(args)  # the web page or the Foxglove feed
    codes: list[int] = []

    def finish(result) -> None:  # while the world's session is open: robots hosts wait for it (run_world)
        progress.__exit__()
        codes.append(_finish(args, sc, result, out_dir, err))

    with progress:
        if session is not None:
            result = session.run(sc, out_dir, endpoints, run_id, sc["run"]["processes"], local, progress.on_tick)
        else:
            result = asyncio.run(run_world(sc, out_dir, endpoints, run_id, processes=sc["run"]["processes"],
                                           local_host=local, on_tick=progress.on_tick, return_on_signal=True,
                                           on_result=finish))
    if not codes:
        codes.append(_finish(args, sc, result, out_dir, err))
    if session is not None:
        session.linger()  # the page shows the run's trace until Ctrl-C
    return codes[0]


def _finish(args, sc: dict, result, out_dir: Path, err: Console) -> int:
    """After a run: the summary table, then the pictures and the files written; the exit code."""
    code, reason = run_exit(result.data)
    if args.json:
        print(json.dumps({**{k: result.data[k] for k in ("run_id", "ticks", "wall_s", "trace_hash", "world",
                                                          "metrics", "checks", "interrupted")},
                          "exit": int(code), "outcome": reason}))
    elif not args.quiet:
        _wide(err).print(summary_table(result.data))
    if args.quiet and code != EXIT_OK:  # one line, whatever else was asked
        print(f"{sc['run']['name']}: {reason} (exit {int(code)}; {out_dir / 'result.json'})", file=sys.stderr)
    if args.verbose:
        for text in crash_tracebacks(result.data["robots"]):
            print(text, file=sys.stderr)
    files = [p.name for p in (out_dir / "result.json", result.trace_path) if p is not None and p.exists()]
    if not args.no_plots and result["ticks"] > 0:  # a signal while they are drawn skips the rest (_plots)
        files += _plots(result, sc, out_dir, err)
    if not args.json and not args.quiet:  # plain lines, never wrapped: a path must survive a copy and paste
        print(f"output: {out_dir}", file=sys.stderr)
        print(f"files: {', '.join(files)}", file=sys.stderr)
    return int(code)


def _plots(result, sc: dict, out_dir: Path, err: Console) -> list[str]:
    """Draw the run's pictures beside result.json; the names of those written.

    SIGINT or SIGTERM while they are drawn (docker-compose stopping the world once its hosts have exited) skip
    the rest: the summary is still printed and the exit code stays the run's.
    """
    written: list[Path] = []
    field = _plot_field(sc)
    with _signals_interrupt():
        try:
            if result.trace_path is not None or result["robots"]:
                try:
                    from swarmactors.tools.plots import plot_run  # matplotlib is slow to import: only when plotting

                    written.append(plot_run(result, out_dir / "swarm.png", field))
                except Exception as exc:  # a plot must never cost the run its result
                    err.print(f"[yellow]plot skipped:[/] {exc}")
            if result.trace_path is not None:
                from swarmactors.tools.see import write_run_charts
                from swarmactors.tools.trajectories import write_trajectories

                written += write_run_charts(result, out_dir, field, err)
                written.append(write_trajectories(result, out_dir, err))
        except KeyboardInterrupt:
            err.print("[yellow]pictures skipped:[/] interrupted")
    return [p.name for p in written if p is not None and p.exists()]


@contextlib.contextmanager
def _signals_interrupt():
    """SIGINT and SIGTERM raise KeyboardInterrupt inside, whatever handled them before (even SIG_IGN)."""
    def stop(_signum, _frame):
        raise KeyboardInterrupt

    before = {}
    try:
        for signum in (signal.SIGINT, signal.SIGTERM):
            before[signum] = signal.signal(signum, stop)
    except ValueError:  # not the main thread
        pass
    try:
        yield
    finally:
        for signum, handler in before.items():
            signal.signal(signum, handler)


def loopback(endpoint: str) -> bool:
    """A Zenoh endpoint only this machine reaches: a Unix socket, or TCP/UDP/QUIC on a loopback address."""
    import ipaddress

    proto, _, rest = endpoint.partition("/")
    if proto.startswith("unixsock"):
        return True
    host = rest.rpartition(":")[0].strip("[]")
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def _world_endpoints(args, run_id: str) -> Endpoints:
    if args.secure is None:
        listen = args.listen or ["tcp/0.0.0.0:7447"]
        who = "any local user" if all(loopback(ep) for ep in listen) else "anyone who reaches it"
        print(INSECURE_WARNING.format(where=", ".join(listen), who=who), file=sys.stderr)
        return Endpoints(mode=args.mode, listen=listen, connect=args.connect)
    listen = args.listen or ["tls/0.0.0.0:7447"]
    plain = [ep for ep in listen if not ep.startswith("tls/")]
    if plain:
        raise UsageError(f"--listen {plain[0]}: with --secure the world listens on tls/HOST:PORT only")
    ensure_files(args.secure, args.tls_name)
    security = Security("world", args.secure)
    return Endpoints(mode="router", listen=listen, connect=args.connect, extra=security.zenoh_settings(run_id))


def _check(args, err: Console) -> int:
    """``swarmactors check``: run suites, print the report, write JSON/JUnit; exit 0 only if all passed."""
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )
    from rich.table import Table

    from swarmactors.runs import conformance as cf
    from swarmactors.runs.progress import check_counts, check_rows

    if args.jobs < 1:
        raise UsageError(f"--jobs {args.jobs}: must be >= 1")
    for option, path in (("--json", args.json), ("--junit", args.junit)):
        if path is not None and path.is_dir():
            raise UsageError(f"{option} {path}: is a directory (give a file name)")
    try:
        cases = [c for _, c in cf.select(args.family, args.mode)
                 if args.clock is None or c.scenario.get("run", {}).get("clock", "lockstep") == args.clock]
        asked = {c.name: c.checks for c in cases}
        with Progress(TextColumn("[bold]conformance"), BarColumn(), MofNCompleteColumn(),
                      TextColumn("{task.description}"), TimeElapsedColumn(), TextColumn("ETA"),
                      TimeRemainingColumn(), console=err) as bar:
            task = bar.add_task("", total=len(cases))

            def tick(r) -> None:
                bar.update(task, advance=1, description=f"{r.case} {'ok' if r.passed else 'FAILED'}")

            results = cf.check(args.family, args.behavior, args.mode, args.clock, args.jobs, args.out,
                               not args.no_determinism, progress=tick, cluster=args.cluster)
    except cf.ContractError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    behavior = args.behavior or "built-in"
    table = Table(title=f"conformance of {behavior} ({args.mode})")
    table.add_column("case", no_wrap=True)
    table.add_column("result")
    table.add_column("checks", no_wrap=True)
    table.add_column("verdict (value, bound)")
    table.add_column("seed")
    table.add_column("first tick")
    for r in results:
        rows = check_rows(r.outcomes, asked.get(r.case, [])) or [("", r.error or "")]
        mark = "[green]passed[/]" if r.passed else "[red]FAILED[/]"
        name = f"{r.family}/{r.case}" if not r.case.startswith(r.family) else r.case
        for k, (check, verdict) in enumerate(rows):
            first = "" if r.first_tick is None else str(r.first_tick)
            table.add_row(name if k == 0 else "", mark if k == 0 else "", check.removeprefix("check "), verdict,
                          str(r.seed) if k == 0 else "", first if k == 0 else "",
                          end_section=k == len(rows) - 1)
    _wide(err).print(table)
    for r in results:
        if not r.passed:
            for o in r.outcomes:
                if not o["passed"]:
                    print(f"FAILED {r.case}: {o['name']}: {o['detail']}", file=sys.stderr)
            if r.error:
                print(f"FAILED {r.case}: {r.error}", file=sys.stderr)
            if r.reproduce:
                print(f"  reproduce (seed {r.seed}, first tick {r.first_tick}): {r.reproduce_command}",
                      file=sys.stderr)
    if args.json:
        args.json.write_text(json.dumps([cf.as_dict(r) for r in results], indent=1))
    if args.junit:
        args.junit.write_text(cf.junit_xml(results, behavior))
    failed = sum(not r.passed for r in results)
    judged = check_counts([o for r in results for o in r.outcomes])
    print(f"{len(results) - failed} passed, {failed} failed (checks: {judged})", file=sys.stderr)
    return EXIT_OK if failed == 0 else EXIT_CHECK


def _wide(err: Console) -> Console:
    """Where tables go: the terminal, or off a terminal (CI logs, a pipe) a console without 80-column wrapping."""
    return err if err.is_terminal else Console(stderr=True, no_color=True, width=400, soft_wrap=True)


def _wait_for(path: Path, seconds: float) -> None:
    """Wait for a file the world creates (the credential in a shared volume); error if it never comes."""
    import time

    deadline = time.monotonic() + seconds
    while not path.exists():
        if time.monotonic() > deadline:
            raise UsageError(f"{path}: no such file (the world's --secure directory?)")
        time.sleep(0.2)


def _plot_field(sc: dict) -> str | None:
    for g in sc["robots"]:
        for b in g["behaviors"]:
            field = getattr(resolve(BEHAVIORS, b["use"]), "plot_field", None)
            if field:
                return field
    return None


def _first_line(obj) -> str:
    """A docstring's first line as plain text (reStructuredText's ``literal`` marks dropped)."""
    doc = (getattr(obj, "__doc__", None) or "").strip()
    return re.sub(r"``([^`]+)``", r"\1", doc.splitlines()[0]) if doc else ""


def scenario_folders() -> list[Path]:
    """Where ``list scenarios`` looks: the checkout beside the package, ./scenarios, then the installed copy.

    A wheel installs the shipped scenarios under ``<prefix>/share/swarmactors/scenarios`` (pyproject.toml's
    data-files), the user scheme's prefix too.
    """
    import sysconfig

    prefixes = {sysconfig.get_path("data"), sysconfig.get_path("data", f"{os.name}_user")}
    installed = [Path(p) / "share" / "swarmactors" / "scenarios" for p in sorted(prefixes) if p]
    return [Path(__file__).resolve().parents[1] / "scenarios", Path.cwd() / "scenarios", *installed]


def shipped_scenarios(folders: list[Path] | None = None) -> list[Path]:
    """The scenario files of ``scenario_folders()``: each file name once, from the first folder that has it."""
    seen: set[str] = set()
    out: list[Path] = []
    for folder in scenario_folders() if folders is None else folders:
        for path in sorted(folder.glob("*.toml")) if folder.is_dir() else []:
            if path.name not in seen:
                seen.add(path.name)
                out.append(path)
    return out


def scenario_family(path: Path) -> str:
    """The protocol family whose behaviours a scenario runs (``-`` for none, ``a+b`` for several)."""
    import tomllib

    from swarmactors.robot.plugins import families as registered
    from swarmactors.robot.plugins import family_of

    try:
        raw = tomllib.loads(path.read_text(errors="replace"))
    except (OSError, ValueError):
        return "?"
    by_target = {target: fam.name for fam in registered().values() for target in fam.behaviors.values()}
    found: list[str] = []
    for group in raw.get("robots", []) if isinstance(raw.get("robots"), list) else []:
        for spec in group.get("behaviors", []) if isinstance(group, dict) else []:
            use = spec.get("use", "") if isinstance(spec, dict) else ""
            family = family_of(BEHAVIORS, use) if isinstance(use, str) else None
            family = family or by_target.get(use)  # nothing imported
            if family and family not in found:
                found.append(family)
    return "+".join(found) or "-"


def _scenario_description(path: Path) -> str:
    """A scenario file's description: the first line of its leading comment."""
    for line in path.read_text(errors="replace").splitlines():
        if not line.startswith("#"):
            return ""
        text = line.lstrip("#").strip()
        if text:
            return text
    return ""


def _list(what: str) -> int:
    """``swarmactors list behaviors|checks|families|scenarios``: names and one-line descriptions."""
    from swarmactors.robot.plugins import CHECKS, FAMILIES, PluginError, available, broken_families, families, family_of

    rows: list[tuple[str, ...]] = []
    if what == "scenarios":
        paths = shipped_scenarios()
        if not paths:
            where = ", ".join(str(f) for f in scenario_folders())
            print(f"error: no scenario files found (looked in {where}); reinstall swarmactors, or run "
                  "from a checkout of its repository", file=sys.stderr)
            return EXIT_RUNTIME
        rows = sorted(((scenario_family(p), _shown_path(p), _scenario_description(p)) for p in paths),
                      key=lambda r: (r[0] == "-", r[0], r[1]))
    elif what == "families":  # what each registers, by name: nothing behind them is imported
        for name, fam in sorted(families().items()):
            has = [f"{len(getattr(fam, k))} {word}{'s' if len(getattr(fam, k)) > 1 else ''}"
                   for k, word in (("behaviors", "behaviour"), ("checks", "check"), ("commands", "subcommand"))
                   if getattr(fam, k)]
            has += ["conformance suite"] if fam.suite is not None else []
            rows.append((name, ", ".join(has) or "-", fam.description or _family_doc(available(FAMILIES)[name])))
        for name, why in sorted(broken_families().items()):
            rows.append((name, "NOT LOADED", why))
    else:
        group = {"behaviors": BEHAVIORS, "checks": CHECKS}[what]
        for name in sorted(available(group)):
            try:
                obj = resolve(group, name)
            except PluginError as exc:
                rows.append((name, family_of(group, name) or "-", f"(cannot load: {exc})"))
                continue
            rows.append((name, family_of(group, name) or "-", _first_line(obj)))
    widths = [max((len(r[i]) for r in rows), default=0) for i in range(len(rows[0]) - 1)] if rows else []
    for row in rows:
        print("  ".join([*(f"{c:<{w}}" for c, w in zip(row, widths, strict=False)), row[-1]]).rstrip())
    return EXIT_OK


def _family_doc(source: str) -> str:
    """The first line of the docstring of the package whose ``suite.py`` holds the family (imported already)."""
    package = sys.modules.get(source.partition(":")[0].rpartition(".")[0])
    return _first_line(package) if package is not None else ""


def _shown_path(path: Path) -> str:
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def _robots(args) -> int:
    if args.count is not None and args.count < 1:
        raise UsageError(f"--count {args.count}: must be >= 1")
    if args.wait <= 0:
        raise UsageError(f"--wait {args.wait}: must be > 0 seconds")
    Keys(args.run_id)
    if args.secure:
        _wait_for(args.secure / "host.credential", seconds=args.wait)
    extra = Security("host", args.secure).zenoh_settings(args.run_id) if args.secure else {}
    extra = {**lease_settings(), **extra}  # the lease of the default watchdog_s (2·10 + 5 s)
    endpoints = Endpoints(mode=args.mode, connect=args.connect, extra=extra)
    if not args.secure and not os.environ.get(RUN_SECRET_ENV) and not all(loopback(ep) for ep in args.connect):
        # on this machine the world's own warning said it already
        print(f"warning: running without --secure: this host trusts whoever answers at {', '.join(args.connect)} "
              f"(or set {RUN_SECRET_ENV}; docs/security.md)", file=sys.stderr)
    say = (lambda _line: None) if args.quiet else (lambda line: print(line, file=sys.stderr, flush=True))
    try:
        host = asyncio.run(serve_host(endpoints, args.run_id, args.count, args.allow, wait=args.wait, say=say,
                                      refuse=lambda line: print(f"error: {line}", file=sys.stderr, flush=True),
                                      linger=WORLD_GONE_S))
    except HostError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_RUNTIME
    if refusal_line(host):
        return EXIT_INPUT  # this host lacked an --allow, or was started where a scenario's module is not
    return EXIT_CHECK if any(r.error for r in host.robots.values()) else EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
