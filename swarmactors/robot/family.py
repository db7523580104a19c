"""A protocol family as one object: what it registers, by name, with nothing imported until it is used.

Every family (``protocols/<family>/`` in this project, or an installed package) declares one entry point in
the group ``swarmactors.families`` naming its ``Family``::

    [project.entry-points."swarmactors.families"]
    relays = "protocols.relays.suite:FAMILY"

and the ``Family`` lists the family's behaviours (short name -> ``module:Class``), its oracle checks (name ->
``module:function``), its conformance suite and its command-line subcommands (name -> a module with
``add_parser(subparsers)`` and ``command(args)``). Checks and subcommands are strings, imported only when a
scenario or the command line asks for them: a robot host reads every family to know the behaviour names, and
never loads an oracle (networkx) by doing so. This module imports nothing but the standard library, so a
family's ``suite.py`` that imports it stays as light.

``swarmactors.robot.plugins`` builds the registries of behaviours, checks and subcommands from the families.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

__all__ = ["CORE", "Case", "Family", "comb", "ladder", "line", "ring"]


@dataclass
class Case:
    """One conformance case: a scenario and the checks it must pass."""

    name: str
    scenario: dict
    checks: list[dict]
    determinism: bool = True  # lockstep cases: also run with 2 host processes, same trace hash


@dataclass
class Family:
    """A protocol family: its behaviours, checks, conformance suite and subcommands, all by name.

    ``name`` is the name reports go under and the prefix of its checks (``relays.connected``). ``behavior`` is
    the built-in behaviour that the conformance suite replaces with a user's (``swarmactors check NAME
    --behavior mine:Mine``); ``report`` its report contract (``report()`` field -> type or tuple of types);
    ``suite(mode) -> list[Case]`` for ``mode`` "quick" or "full". A family without a suite (beacons, mobility
    models, the task scheduler) only registers what it has.
    """

    name: str
    behavior: str | None = None  # the built-in behaviour the conformance suite runs (a key of ``behaviors``)
    report: dict[str, type | tuple[type, ...]] = field(default_factory=dict)  # report() field -> type(s)
    suite: Callable[[str], list[Case]] | None = None
    behaviors: Mapping[str, str] = field(default_factory=dict)  # short name -> "module:Class"
    checks: Mapping[str, str] = field(default_factory=dict)  # check name -> "module:function"
    commands: Mapping[str, str] = field(default_factory=dict)  # subcommand -> "package.module"
    description: str = ""  # one line for ``swarmactors list families`` (default: the package's docstring)

    def __post_init__(self):
        problems = []
        if not isinstance(self.name, str) or not self.name.isidentifier():
            problems.append(f"name {self.name!r} is not a Python identifier")
        for what, table, colon in (("behaviour", self.behaviors, True), ("check", self.checks, True),
                                   ("subcommand", self.commands, False)):
            if not isinstance(table, Mapping):
                problems.append(f"{what}s must be a mapping of names to import paths, not {type(table).__name__}")
                continue
            for key, target in table.items():
                ok = isinstance(key, str) and key and isinstance(target, str) and (":" in target) == colon
                if not ok:
                    form = "module:attribute" if colon else "package.module"
                    problems.append(f"{what} {key!r} -> {target!r}: give a name and a {form!r} string")
        if self.behavior is not None and self.behavior not in self.behaviors:
            problems.append(f"behavior {self.behavior!r} is not one of its behaviours ({', '.join(self.behaviors)})")
        if self.suite is not None and not callable(self.suite):
            problems.append("suite must be a function suite(mode) -> list[Case]")
        if problems:
            raise ValueError(f"family {self.name!r}: " + "; ".join(problems))


# The core's own family: the checks every scenario may use, and the behaviour a reinforcement-learning
# environment drives (swarmactors.rl). Always registered, whatever is installed.
CORE = Family(
    name="core",
    behaviors={"rl": "swarmactors.rl.behavior:RLBehavior"},
    checks={"world.no_collisions": "swarmactors.oracle.world_checks:no_collisions"},
    description="The core: the world's checks (world.no_collisions) and the behaviour swarmactors.rl drives",
)


# ------------------------------------------------------------------ placements for conformance cases
# (a connected random geometric graph, which draws until connected, is swarmactors.runs.conformance.random_geometric)
def ring(n: int, spacing: float = 0.8) -> list[list[float]]:
    """A ring of n robots on a circle, neighbours ``spacing`` apart (a cycle when range >= spacing)."""
    radius = spacing / (2 * math.sin(math.pi / n))
    return [[radius * math.cos(2 * math.pi * i / n), radius * math.sin(2 * math.pi * i / n)] for i in range(n)]


def line(n: int, spacing: float = 0.8) -> list[list[float]]:
    """A path of n robots."""
    return [[i * spacing, 0.0] for i in range(n)]


def ladder(n: int, spacing: float = 0.8) -> list[list[float]]:
    """Two rails of n/2 robots with rungs (a biconnected graph without long cycles inside)."""
    half = n // 2
    return [[i * spacing, 0.0] for i in range(half)] + [[i * spacing, spacing] for i in range(half)]


def comb(n: int, spacing: float = 0.8) -> list[list[float]]:
    """A tree: a spine with a tooth on every other spine robot (range between spacing and spacing*sqrt 2)."""
    spine = (n + 1) // 2 + (n + 1) // 4
    pts = [[i * spacing, 0.0] for i in range(spine)]
    i = 0
    while len(pts) < n:
        pts.append([i * spacing, spacing])
        i += 2
    return pts[:n]

