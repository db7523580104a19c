"""Live progress of a run in the terminal (rich), and the closing summary table."""

from __future__ import annotations

import sys
import time

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table


class RunProgress:
    """A progress bar fed by the world's per-tick callback, at most ~10 refreshes a second."""

    def __init__(self, total: int, name: str, quiet: bool = False):
        self.console = Console(stderr=True, no_color=not sys.stderr.isatty())
        self.quiet = quiet
        self.progress = Progress(
            TextColumn("[bold]{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn(
                "frames {task.fields[frames]}  delivered {task.fields[delivered]}  dropped {task.fields[dropped]}"
            ),
            TimeElapsedColumn(),
            console=self.console,
            disable=quiet,
            transient=False,
        )
        self.task = self.progress.add_task(name, total=total, frames=0, delivered=0, dropped=0)
        self._last = 0.0

    def __enter__(self) -> RunProgress:
        self.progress.start()
        return self

    def __exit__(self, *exc) -> None:
        self.progress.stop()

    def on_tick(self, world) -> None:
        now = time.monotonic()
        if now - self._last < 0.1 and world.tick + 1 < world.ticks:
            return
        self._last = now
        c = world.counters
        self.progress.update(self.task, completed=world.tick + 1, frames=c.sent, delivered=c.delivered,
                             dropped=sum(c.dropped.values()))


def summary_table(result: dict, out_dir) -> Table:
    """The table printed at the end of ``run``."""
    w = result["world"]
    robots = result["robots"]
    alive = sum(1 for r in robots.values() if r["alive"])
    title = f"{result['scenario']['run']['name']} ({result['clock']}, seed {result['seed']})"
    t = Table(title=title, show_header=False)
    t.add_column(style="bold")
    t.add_column()
    t.add_row("ticks", f"{result['ticks']} in {result['wall_s']:.2f} s")
    t.add_row("robots", f"{len(robots)} ({alive} alive at the end)")
    t.add_row("frames sent", str(w["frames_sent"]))
    t.add_row("deliveries", str(w["deliveries"]))
    t.add_row("dropped", ", ".join(f"{k} {v}" for k, v in w["dropped"].items() if v) or "none")
    for name, m in result.get("metrics", {}).items():
        t.add_row(name, ", ".join(f"{k} {_fmt(v)}" for k, v in m.items()))
    for c in result.get("checks", []):
        mark = "[green]passed[/]" if c["passed"] else "[red]FAILED[/]"
        t.add_row(f"check {c['name']}", f"{mark}  value {c['value']} bound {c['bound']}  {c['detail']}")
    t.add_row("trace hash", result["trace_hash"])
    t.add_row("output", str(out_dir))
    return t


def _fmt(v) -> str:
    return f"{v:.3g}" if isinstance(v, float) else str(v)
