"""Checks: oracle verdicts on a finished run.

A check is a function ``fn(result: Result, **params)`` registered by a family
(``swarmactors.robot.family.Family.checks``; ``protocols`` registers its families'
checks), or named by its ``module:function`` path. It returns one ``Outcome`` or a list of them. Checks run in
the runner, over result.json and the trace, never in the world.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from swarmactors.oracle.result import Result
from swarmactors.robot.plugins import CHECKS, resolve


@dataclass
class Outcome:
    """One check's verdict: the measured value against the bound."""

    name: str
    passed: bool
    value: Any = None
    bound: Any = None
    detail: str = ""
    first_tick: int | None = None
    op: str | None = None  # how value meets bound: "<=", ">=" or "=" (shown as ≤, ≥, =); None: not declared


def run_checks(result: Result, specs: list[dict]) -> list[dict]:
    """Run the scenario's ``[[checks]]`` on ``result``; an exception fails that check."""
    outcomes: list[dict] = []
    for spec in specs:
        name = spec["use"]
        params = {k: v for k, v in spec.items() if k != "use"}
        try:
            got = resolve(CHECKS, name)(result, **params)
            for o in got if isinstance(got, list) else [got]:
                outcomes.append(asdict(o))
        except Exception as exc:
            outcomes.append(asdict(Outcome(name, False, detail=f"check raised {exc.__class__.__name__}: {exc}")))
    return outcomes
