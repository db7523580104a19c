"""The ``view``, ``replay`` and ``sweep`` commands, and the ``--view`` and chart parts of ``run``/``world``.

Kept apart from ``cli.py`` so that the command line imports aiohttp and
matplotlib only for the commands that need them. Exit codes as for ``run``:
0 done, 2 bad input (a bad option, scenario or trace file), 3 the command could
not do its work (no such run, world unreachable, port taken), 130 interrupted.
"""

from __future__ import annotations

import asyncio
import json
import sys
from pathlib import Path

from rich.console import Console

from swarmactors.exitcodes import EXIT_INPUT, EXIT_INTERRUPTED, EXIT_OK, EXIT_RUNTIME


def _say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def command(args, err: Console) -> int:
    from swarmactors.oracle.trace import TraceError
    from swarmactors.runs.scenario import ScenarioError
    from swarmactors.tools.viewer import ViewerError, warn_if_exposed

    try:
        if args.command == "sweep":
            return _sweep(args, err)
        if getattr(args, "view_host", None):
            warn_if_exposed(args.view_host)
        if args.command == "view":
            return _view(args)
        return _replay(args, err)
    except (TraceError, ScenarioError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except ViewerError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_RUNTIME
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED


# ---------------------------------------------------------------- view
def _view(args) -> int:
    from swarmactors.tools.viewer import serve_remote

    if args.foxglove is not None:
        from swarmactors.tools.foxglove_live import serve_remote as serve_foxglove

        check_foxglove(args)
        asyncio.run(serve_foxglove(args.connect, args.run_id, args.foxglove_host, args.foxglove, announce=_say))
        return EXIT_OK
    asyncio.run(serve_remote(args.connect, args.run_id, args.view_host, args.view_port, announce=_say))
    return EXIT_OK


class _Session:
    """``run/world --view``: wraps viewer.ViewSession; no lingering after an interrupted run."""

    def __init__(self, args):
        from swarmactors.tools.viewer import ViewSession, warn_if_exposed

        warn_if_exposed(args.view_host)
        self.inner = ViewSession(args.view_host, args.view_port, announce=_say)
        self.result = None

    def run(self, sc, out_dir, endpoints, run_id, processes, local_host, on_tick):
        self.result = self.inner.run(sc, out_dir, endpoints, run_id, processes, local_host, on_tick)
        return self.result

    def linger(self) -> None:
        if self.result is not None and self.result["interrupted"]:
            self.inner.loop.run_until_complete(self.inner.server.close())
            self.inner.loop.close()
            return
        self.inner.linger()


def view_session(args):
    """The session of ``run/world --view`` (the web page) or ``--foxglove`` (the Foxglove feed)."""
    if getattr(args, "foxglove", None) is not None:
        from swarmactors.tools.foxglove_live import FoxgloveSession, warn_if_exposed

        warn_if_exposed(args.foxglove_host)
        return FoxgloveSession(args.foxglove_host, args.foxglove, announce=_say)
    return _Session(args)


def check_foxglove(args) -> None:
    """``--foxglove`` can be served: the extra is installed (else ValueError naming it), no ``--view`` beside it."""
    from swarmactors.tools.foxglove_topics import sdk

    if getattr(args, "view", False):
        raise ValueError("--view and --foxglove: choose one (the web page or the Foxglove feed)")
    if args.foxglove < 0 or args.foxglove > 65535:
        raise ValueError(f"--foxglove {args.foxglove}: not a port number (0 to 65535; 0 picks a free one)")
    sdk()


# ---------------------------------------------------------------- charts
def write_run_charts(result, out_dir: Path, field: str | None, err: Console) -> list[Path]:
    """The per-run charts (swarmactors.tools.charts); a failure is reported, never fatal."""
    try:
        from swarmactors.tools.charts import write_charts

        return write_charts(result, out_dir, field)
    except Exception as exc:
        err.print(f"[yellow]charts skipped:[/] {exc.__class__.__name__}: {exc}")
        return []


# ---------------------------------------------------------------- replay
def _trace_path(path: Path) -> Path:
    if path.is_dir():
        path = path / "trace.msgpack"
    if not path.exists():
        raise ValueError(f"{path}: no such trace file")
    return path


def _replay(args, err: Console) -> int:
    from swarmactors.tools.replay import Replay, render

    trace = _trace_path(args.trace)
    verify = not getattr(args, "no_verify", False)
    if not verify:
        note = Replay(trace, verify=False).note
        if note:
            _say(note)
    if args.events:
        from swarmactors.tools.scene import events_toml

        replay = Replay(trace, verify=verify)
        print(events_toml(replay.full_scene().control_events(), replay.header.get("run_id", "")), end="")
        return EXIT_OK
    out = args.gif or args.mp4
    if out is not None:
        if args.gif is not None and out.suffix.lower() != ".gif":
            raise ValueError(f"--gif {out}: the file name must end in .gif")
        if args.mp4 is not None and out.suffix.lower() != ".mp4":
            raise ValueError(f"--mp4 {out}: the file name must end in .mp4")
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        with Progress(TextColumn(f"[bold]rendering {out.name}"), BarColumn(), MofNCompleteColumn(),
                      TimeElapsedColumn(), console=err, disable=args.quiet) as bar:
            task = bar.add_task("", total=None)
            frames = render(trace, out, every=args.every, fps=args.fps, field=args.field,
                            progress=lambda i, n: bar.update(task, completed=i, total=n), verify=verify)
        if not args.quiet:
            _say(f"wrote {out} ({frames} frames)")
        return EXIT_OK
    from swarmactors.tools.viewer import serve_replay

    Replay(trace, verify=verify)  # read it now: a bad file is an error before the server starts
    if args.foxglove is not None:
        from swarmactors.tools.foxglove_live import serve_replay as serve_foxglove

        check_foxglove(args)
        if not args.rate > 0:
            raise ValueError(f"--rate {args.rate}: must be a positive number of ticks per second")
        asyncio.run(serve_foxglove(trace, args.foxglove_host, args.foxglove, args.rate, announce=_say,
                                   verify=verify))
        return EXIT_OK
    asyncio.run(serve_replay(trace, args.view_host, args.view_port, announce=_say, verify=verify))
    return EXIT_OK


# ---------------------------------------------------------------- sweep
def _sweep(args, err: Console) -> int:
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    from swarmactors.tools import sweep as sw

    overrides = list(args.set)
    if args.seed is not None:
        overrides.append(f"run.seed={args.seed}")
    if args.clock is not None:
        overrides.append(f'run.clock="{args.clock}"')
    plan = sw.plan(args.scenario, overrides, args.grid, args.trials, args.out)
    with Progress(TextColumn(f"[bold]{plan.name} sweep"), BarColumn(), MofNCompleteColumn(),
                  TextColumn("{task.fields[note]}"), TimeElapsedColumn(), TimeRemainingColumn(),
                  console=err, disable=args.quiet or args.json) as bar:
        task = bar.add_task("", total=None, note="")

        def progress(done: int, total: int, counts: dict) -> None:
            note = ", ".join(f"{v} {k}" for k, v in (("running", counts.get("running", 0)),
                                                       ("with a failed check", counts["failed"]),
                                                       ("with crashed robots", counts.get("crashed", 0)),
                                                       ("errors", counts["errors"])) if v)
            bar.update(task, completed=done, total=total, note=note)

        try:
            outcome = sw.run_sweep(plan, workers=args.workers, keep=args.keep, progress=progress,
                                   cluster=args.cluster)
        except RuntimeError as exc:  # swarmactors.runs.cluster.ClusterError: the scheduler unreachable or gone
            print(f"error: {exc}", file=sys.stderr)
            return EXIT_RUNTIME
    if args.json:
        print(json.dumps(outcome.as_dict()))
    elif not args.quiet:
        from rich.table import Table

        t = Table(title=f"sweep of {plan.scenario}", show_header=False)
        t.add_column(style="bold")
        t.add_column()
        t.add_row("trials", f"{outcome.total} ({outcome.skipped} already done, {outcome.ran} run now)")
        t.add_row("grid", "; ".join(f"{k} = {', '.join(map(sw.cell, v))}" for k, v in plan.grid) or "none")
        named = ", ".join(f"{name} {n}" for name, n in outcome.failed_by_check.items())
        t.add_row("failed checks", f"[red]{outcome.failed} trials[/] ({named})" if outcome.failed else "none")
        t.add_row("crashed robots", f"[red]in {outcome.crashed} trials[/] (trials.csv: crashed)"
                  if outcome.crashed else "none")
        t.add_row("errors", f"[red]{outcome.errors} trials could not run[/]: {outcome.first_error}"
                  if outcome.errors else "none")
        t.add_row("csv", str(outcome.csv))
        for p in outcome.plots:
            t.add_row("file", str(p))
        if outcome.interrupted:
            t.add_row("interrupted", "run the same command again to finish the sweep")
        err.print(t)
    return outcome.exit_code
