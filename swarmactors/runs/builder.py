"""``Scenario``: build a scenario in code (notebooks, tests) instead of a TOML file.

    sc = (Scenario("demo", seed=3, ticks=20)
          .radio(range=1.0, loss=0.1)
          .robots(count=30, placement="uniform", connected=True,
                  behaviors=[{"use": "flooding", "origin": 0, "at": 1, "expiry": 6}])
          .event(at=5, kill=[3])
          .check("flooding.delivered"))
    result = swarmactors.run(sc)

Every method returns the scenario, so calls chain; ``resolve()`` validates it
exactly as a file would be, ``to_toml()`` writes it out.
"""

from __future__ import annotations

import copy
from pathlib import Path

import tomli_w

from swarmactors.runs.scenario import resolve_scenario


class Scenario:
    """A scenario as data (the dict a TOML file parses to), built by chained calls."""

    def __init__(self, name: str = "run", **run):
        self.raw: dict = {"run": {"name": name, **run}, "robots": []}

    def run(self, **fields) -> Scenario:
        self.raw["run"].update(fields)
        return self

    def radio(self, **fields) -> Scenario:
        self.raw.setdefault("radio", {}).update(fields)
        return self

    def world(self, **fields) -> Scenario:
        self.raw.setdefault("world", {}).update(fields)
        return self

    def robots(self, **group) -> Scenario:
        """Add a ``[[robots]]`` group (count or positions, placement, behaviors, ...)."""
        self.raw["robots"].append(group)
        return self

    def event(self, at: int, **action) -> Scenario:
        self.raw.setdefault("events", []).append({"at": at, **action})
        return self

    def check(self, use: str, **params) -> Scenario:
        self.raw.setdefault("checks", []).append({"use": use, **params})
        return self

    def resolve(self, overrides: list[str] = ()) -> dict:
        """Validate and resolve (``ScenarioError`` names the key, as for a file)."""
        return resolve_scenario(copy.deepcopy(self.raw), f"<Scenario {self.raw['run'].get('name')}>", overrides)

    def to_toml(self) -> str:
        return tomli_w.dumps(self.raw)

    def save(self, path: str | Path) -> Path:
        path = Path(path)
        path.write_text(self.to_toml())
        return path
