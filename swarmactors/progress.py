"""Live progress of a run in the terminal (rich), and the closing summary table."""

from __future__ import annotations

import re
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
        c = world.sim.counters
        self.progress.update(self.task, completed=world.tick + 1, frames=c.sent, delivered=c.delivered,
                             dropped=sum(c.dropped.values()))


CRASHED_SHOWN = 10  # crashed robots listed by id in the summary; the rest are counted


def summary_table(result: dict, out_dir) -> Table:
    """The table printed at the end of ``run``: how the run ended, what it measured, each check's verdict."""
    w = result["world"]
    robots = result["robots"]
    alive = sum(1 for r in robots.values() if r["alive"])
    title = f"{result['scenario']['run']['name']} ({result['clock']}, seed {result['seed']})"
    t = Table(title=title, show_header=False)
    t.add_column(style="bold")
    t.add_column()
    ticks = f"{result['ticks']} in {result['wall_s']:.2f} s"
    if result.get("interrupted"):
        t.add_row("ticks", f"[yellow]interrupted at tick {max(result['ticks'] - 1, 0)}[/] "
                           f"(of {result['scenario']['run']['ticks']}; {ticks}); checks not run")
    else:
        t.add_row("ticks", ticks)
    t.add_row("robots", f"{len(robots)} ({alive} alive at the end)")
    for line in crashed_lines(robots):
        t.add_row("", line)
    t.add_row("frames sent", str(w["frames_sent"]))
    t.add_row("deliveries", str(w["deliveries"]))
    t.add_row("dropped", ", ".join(f"{k} {v}" for k, v in w["dropped"].items() if v) or "none")
    for name, m in result.get("metrics", {}).items():
        t.add_row(name, ", ".join(f"{k} {fmt(v)}" for k, v in m.items()))
    for row in check_rows(result.get("checks", []), result["scenario"].get("checks", [])):
        t.add_row(*row)
    if result.get("checks"):
        t.add_row("checks", check_counts(result["checks"]))
    t.add_row("trace hash", result["trace_hash"])
    t.add_row("output", str(out_dir))
    return t


def crashed_lines(robots: dict) -> list[str]:
    """One line per failed robot (id, cause, tick, the first line of its error), at most CRASHED_SHOWN."""
    out = []
    failed = [(rid, r) for rid, r in sorted(robots.items(), key=lambda kv: int(kv[0])) if r.get("failed")]
    for rid, r in failed[:CRASHED_SHOWN]:
        f = r["failed"]
        error = (r.get("error") or f.get("error") or "").strip()
        first = error.splitlines()[0] if error else ""
        out.append(f"[red]{f.get('cause', 'failed')}[/] robot {rid} at tick {f.get('tick')}"
                   + (f": {first}" if first else ""))
    if len(failed) > CRASHED_SHOWN:
        out.append(f"... and {len(failed) - CRASHED_SHOWN} more (result.json: robots.<id>.failed)")
    return out


def check_rows(outcomes: list[dict], asked: list[dict]) -> list[tuple[str, str]]:
    """Checks as the scenario asked for them, each outcome under the check that produced it."""
    rows = []
    for name, parts in group_outcomes(outcomes, asked):
        if len(parts) == 1:
            shown = name if parts[0]["name"] == name else f"{name} ({parts[0]['name']})"
            rows.append((f"check {shown}", verdict(parts[0])))
            continue
        status = _group_status(parts)
        rows.append((f"check {name}", status))
        for o in parts:
            rows.append((f"  {o['name']}", verdict(o)))
    return rows


def group_outcomes(outcomes: list[dict], asked: list[dict]) -> list[tuple[str, list[dict]]]:
    """Pair outcomes with the ``[[checks]]`` entry that produced them.

    Outcomes written by ``launcher.judge`` name it (``check``). Older result files are paired by order:
    run_checks appends a check's outcomes in the order of the scenario's checks; an outcome whose name does not
    start with the asked check's family is still that check's (``flooding.forwarding`` returns
    ``flooding.forward_once`` and ``flooding.not_to_sender``). Without the scenario's list, each outcome alone.
    """
    if any("check" in o for o in outcomes):  # outcomes name their check (launcher.judge)
        by_check: dict[str, list[dict]] = {}
        for o in outcomes:
            by_check.setdefault(o.get("check", o["name"]), []).append(o)
        return list(by_check.items())
    if not asked:
        return [(o["name"], [o]) for o in outcomes]
    groups: list[tuple[str, list[dict]]] = []
    names = [c["use"] for c in asked]
    i = 0
    for k, name in enumerate(names):
        nxt = names[k + 1] if k + 1 < len(names) else None
        parts: list[dict] = []
        while i < len(outcomes):
            if parts and (outcomes[i]["name"] == nxt or parts[-1]["name"] == name):
                break  # the next check's outcome, or this check returned itself by name
            parts.append(outcomes[i])
            i += 1
        groups.append((name, parts))
    groups += [(o["name"], [o]) for o in outcomes[i:]]
    return groups


def status(o: dict) -> str:
    """passed, FAILED, or "nothing to judge" (a check that passed with nothing to measure)."""
    if not o["passed"]:
        return "FAILED"
    return "nothing to judge" if nothing_to_judge(o) else "passed"


_NONE_OF_NONE = re.compile(r"(?<![\d.])0 of 0(?![\d.])")


def nothing_to_judge(o: dict) -> bool:
    """A passed outcome that measured nothing: no value and no bound, or a detail saying "0 of 0" (an empty set).

    It does not fail the run; the summary counts it apart from the passed checks.
    """
    if not o.get("passed"):
        return False
    if o.get("value") is None and o.get("bound") is None:
        return True
    return bool(_NONE_OF_NONE.search(str(o.get("detail") or "")))


def check_counts(outcomes: list[dict]) -> str:
    """``3 passed, 1 nothing to judge, 0 failed``: every outcome counted once, by its status."""
    states = [status(o) for o in outcomes]
    return (f"{states.count('passed')} passed, {states.count('nothing to judge')} nothing to judge, "
            f"{states.count('FAILED')} failed")


_MARK = {"passed": "[green]passed[/]", "FAILED": "[red]FAILED[/]", "nothing to judge": "[yellow]nothing to judge[/]"}


def _group_status(parts: list[dict]) -> str:
    states = [status(o) for o in parts]
    if "FAILED" in states:
        return _MARK["FAILED"]
    return _MARK["nothing to judge"] if states and all(s == "nothing to judge" for s in states) else _MARK["passed"]


def verdict(o: dict) -> str:
    """``passed  value 30 (bound = 30)  detail``, the bound written with its direction."""
    s = status(o)
    text = _MARK[s]
    if o.get("value") is not None or o.get("bound") is not None:
        text += f"  value {fmt(o.get('value'))} (bound {bound_text(o)})"
    if o.get("detail"):
        text += f"  {o['detail']}"
    return text


_OPS = {"<=": "≤", ">=": "≥", "=": "=", "==": "=", "<": "<", ">": ">"}


def bound_text(o: dict) -> str:
    """The bound with its direction: the outcome's ``op`` when the check declares it, else read from the verdict.

    A passed outcome with a value below its bound met an upper bound (≤), above it a lower one (≥), equal to it
    ``=``; a failed one equal to its bound was an equality (of sets, say). A failed one on one side of its
    bound could have broken an inequality or an equality: its bound is shown without a direction.
    """
    bound = o.get("bound")
    op = _OPS.get(o.get("op") or "", o.get("op"))
    if op is None:
        value = o.get("value")
        numbers = all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in (value, bound))
        if not numbers:
            return fmt(bound)
        if value == bound:
            op = "="
        elif o["passed"]:
            op = "≤" if value < bound else "≥"
        else:
            return fmt(bound)
    return f"{op} {fmt(bound)}"


def fmt(v) -> str:
    """A value for the table: floats to 4 significant digits, also inside lists and maps."""
    if isinstance(v, bool) or v is None:
        return str(v)
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k}: {fmt(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(fmt(x) for x in v) + "]"
    return str(v)


_fmt = fmt  # the name other modules import
