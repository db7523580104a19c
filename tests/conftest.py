"""Shared fixtures: running scenarios given as dicts, in a temporary directory."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

from swarmactors.launcher import new_run_id, run_world
from swarmactors.result import Result
from swarmactors.scenario import resolve_scenario
from transport import Endpoints


def run_scenario(raw: dict, out: Path, overrides: list[str] = (), processes: int | None = None) -> Result:
    """Resolve and run a scenario dict to completion; return its Result (checks included)."""
    sc = resolve_scenario(raw, "<test>", list(overrides))
    k = sc["run"]["processes"] if processes is None else processes
    return asyncio.run(
        run_world(sc, out, Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]), new_run_id(sc["run"]["name"]),
                  processes=k)
    )


@pytest.fixture
def run(tmp_path):
    """``run(raw_scenario_dict, overrides=[], processes=None, name="r")`` -> Result."""
    counter = iter(range(10_000))

    def _run(raw: dict, overrides: list[str] = (), processes: int | None = None, name: str | None = None) -> Result:
        out = tmp_path / (name or f"run{next(counter)}")
        return run_scenario(raw, out, overrides, processes)

    return _run
