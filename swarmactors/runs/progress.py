"""Live progress of a run in the terminal (rich), and the closing summary table."""

from __future__ import annotations

import re
import sys
import time

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from swarmactors.robot.hosting import id_ranges


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
        """Stop the bar (once: the summary may stop it before the ``with`` block ends)."""
        if self.task is not None:
            self.progress.stop()
            self.task = None

    def on_tick(self, world) -> None:
        if self.task is None:
            return
        now = time.monotonic()
        if now - self._last < 0.1 and world.tick + 1 < world.ticks:
            return
        self._last = now
        c = world.sim.counters
        self.progress.update(self.task, completed=world.tick + 1, frames=c.sent, delivered=c.delivered,
                             dropped=sum(c.dropped.values()))


FAILURE_KINDS_SHOWN = 5  # kinds of robot failure (cause and first error line) listed in the summary


def summary_table(result: dict) -> Table:
    """The table printed at the end of ``run``: how the run ended, what it measured, each check's verdict.

    Nothing is said passed that did not run: an interrupted run's checks are "not run", a world that no host
    joined says its robots never ran, crashed robots are counted in one line per kind of failure, and the last
    row gives the exit code and why (``swarmactors.exitcodes.run_exit``).
    """
    from swarmactors.exitcodes import run_exit

    w = result["world"]
    robots = result["robots"]
    title = f"{result['scenario']['run']['name']} ({result['clock']}, seed {result['seed']})"
    t = Table(title=title, show_header=False)
    t.add_column(style="bold", no_wrap=True)
    t.add_column()
    ticks = f"{result['ticks']} in {result['wall_s']:.2f} s"
    if result.get("interrupted"):
        ticks = (f"[yellow]interrupted at tick {max(result['ticks'] - 1, 0)}[/] "
                 f"(of {result['scenario']['run']['ticks']}; {ticks})")
    t.add_row("ticks", ticks)
    t.add_row("robots", robots_text(robots))
    for line in failure_lines(robots):
        t.add_row("", line)
    t.add_row("frames sent", str(w["frames_sent"]))
    t.add_row("deliveries", str(w["deliveries"]))
    t.add_row("dropped", ", ".join(f"{k} {v}" for k, v in w["dropped"].items() if v) or "none")
    for name, m in result.get("metrics", {}).items():
        for label, text in metric_rows(name, m):
            t.add_row(label, text)
    asked = result["scenario"].get("checks", [])
    if result.get("interrupted"):
        for spec in asked:
            t.add_row(f"check {spec['use']}", "[yellow]not run[/] (the run was interrupted)")
    else:
        for row in check_rows(result.get("checks", []), asked):
            t.add_row(*row)
        if result.get("checks"):
            t.add_row("checks", check_counts(result["checks"]))
    t.add_row("trace hash", result["trace_hash"])
    code, reason = run_exit(result)
    colour = {0: "green", 130: "yellow"}.get(int(code), "red")
    t.add_row("outcome", f"[{colour}]{reason}[/] (exit {int(code)})")
    return t


def robots_text(robots: dict) -> str:
    """The ``robots`` row: how many, how many alive; robots that never ran said so (no host joined, say)."""
    from swarmactors.exitcodes import never_ran

    n = len(robots)
    unclaimed = sum(r.get("host") is None for r in robots.values())
    idle = sum(never_ran(r) for r in robots.values())
    if n and unclaimed == n:
        return f"{n}, [red]none ran[/]: no robot host joined the world"
    if n and idle == n:
        return f"{n}, [red]none ran[/]: every robot failed before its first step"
    alive = sum(1 for r in robots.values() if r["alive"])
    return f"{n} ({alive} alive at the end" + (f", {idle} never ran)" if idle else ")")


def failure_lines(robots: dict) -> list[str]:
    """Failed robots, one line per kind (cause and first line of the error): how many, which, when, why.

    Crashed robots (any cause but ``killed``) are counted first and loudly; robots the scenario killed come last.
    """
    from swarmactors.exitcodes import crashed

    kinds: dict[tuple[str, str], list[tuple[int, int | None]]] = {}
    for rid, r in robots.items():
        f = r.get("failed")
        if f:
            error = (r.get("error") or f.get("error") or "").strip()
            key = (f.get("cause") or "failed", error.splitlines()[0] if error else "")
            kinds.setdefault(key, []).append((int(rid), f.get("tick")))
    broken = sum(crashed(r) for r in robots.values())
    out = [f"[bold red]{broken} robot{'s' if broken != 1 else ''} crashed[/] (result.json: robots.<id>.failed, "
           "traceback with -v)"] if broken else []
    ordered = sorted(kinds.items(), key=lambda kv: (kv[0][0] == "killed", min(kv[1])))
    for (cause, first), who in ordered[:FAILURE_KINDS_SHOWN]:
        ids = id_ranges(sorted(rid for rid, _ in who))
        ticks = sorted({t for _, t in who if t is not None})
        when = "" if not ticks else (f" at tick {ticks[0]}" if len(ticks) == 1 else f" at ticks {ticks[0]}-{ticks[-1]}")
        mark = "yellow" if cause == "killed" else "red"
        why = f": {first}" if first else ""
        out.append(f"[{mark}]{cause}[/] robot{'s' if len(who) > 1 else ''} {ids}{when}{why}")
    if len(ordered) > FAILURE_KINDS_SHOWN:
        rest = sum(len(who) for _, who in ordered[FAILURE_KINDS_SHOWN:])
        out.append(f"... and {rest} more robots failed otherwise (result.json: robots.<id>.failed)")
    return out


def crash_tracebacks(robots: dict) -> list[str]:
    """``-v``: each distinct traceback of a crashed robot once, under the robots that raised it."""
    by_text: dict[str, list[int]] = {}
    for rid, r in robots.items():
        if r.get("traceback"):
            by_text.setdefault(r["traceback"].rstrip(), []).append(int(rid))
    return [f"robot{'s' if len(ids) > 1 else ''} {id_ranges(sorted(ids))} crashed with:\n{text}"
            for text, ids in sorted(by_text.items(), key=lambda kv: min(kv[1]))]


def metric_rows(name: str, metrics: dict) -> list[tuple[str, str]]:
    """A behaviour's metrics: its plain values on one row, each nested map on a row of its own below it.

    A nested map is written flat (``mean_received.CR 191.6``), so no row shows a dict inside a dict.
    """
    if not isinstance(metrics, dict):
        return [(name, fmt(metrics))]
    plain = [f"{k} {fmt(v)}" for k, v in metrics.items() if not (isinstance(v, dict) and v)]
    rows = [(name, ", ".join(plain))] if plain else []
    for k, v in metrics.items():
        if not (isinstance(v, dict) and v):
            continue
        label = f"  {k}" if plain else f"{name} {k}"
        if all(isinstance(x, dict) and x for x in v.values()):  # a map of maps (per period, say): a row each
            rows += [(f"{label} {k2}", _flat_text(x)) for k2, x in v.items()]
        else:
            rows.append((label, _flat_text(v)))
    return rows


def _flat_text(d: dict) -> str:
    return ", ".join(f"{path} {fmt(x)}" for path, x in _flat_items(d))


def _flat_items(d: dict, prefix: str = ""):
    for k, v in d.items():
        if isinstance(v, dict) and v:
            yield from _flat_items(v, f"{prefix}{k}.")
        else:
            yield f"{prefix}{k}", v


def check_rows(outcomes: list[dict], asked: list[dict]) -> list[tuple[str, str]]:
    """Checks as the scenario asked for them, each outcome under the check that produced it."""
    rows = []
    for name, parts in group_outcomes(outcomes, asked):
        if not parts:  # asked for, and no outcome: it did not run
            rows.append((f"check {name}", "[yellow]not run[/]"))
            continue
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
    """``passed  value 30 (bound = 30)  detail``: the bound with its direction, numbers in the detail rounded.

    An outcome without a bound shows its value alone; one without either, its detail alone.
    """
    s = status(o)
    text = _MARK[s]
    if o.get("bound") is not None:
        text += f"  value {fmt(o.get('value'))} (bound {bound_text(o)})"
    elif o.get("value") is not None:
        text += f"  value {fmt(o.get('value'))}"
    if o.get("detail"):
        text += f"  {round_numbers(str(o['detail']))}"
    return text


_OPS = {"<=": "≤", ">=": "≥", "=": "=", "==": "=", "<": "<", ">": ">"}


def bound_text(o: dict) -> str:
    """The bound with its direction: the outcome's ``op`` when the check declares it, else read from the verdict.

    A value equal to its bound met (or broke) an equality. A passed value below its bound met an upper bound (≤),
    above it a lower one (≥); a failed value above its bound broke an upper bound (≤), below it a lower one (≥).
    (A failed count short of its total, ``value 10 (bound ≥ 12)``, says the same as ``= 12``: a count cannot
    exceed its total.)
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
            op = "≤" if value > bound else "≥"
    return f"{op} {fmt(bound)}"


_LONG_DECIMAL = re.compile(r"(?<![\w.])-?\d+\.\d{5,}(?:[eE][-+]?\d+)?(?![\w.])")


def round_numbers(text: str) -> str:
    """A check's detail with its long decimals (5 or more digits after the point) to 4 significant digits."""
    return _LONG_DECIMAL.sub(lambda m: f"{float(m.group()):.4g}", text)


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
