"""Shared fixtures: running scenarios given as dicts, in a temporary directory."""

from __future__ import annotations

import asyncio
import os
from pathlib import Path

import pytest

from swarmactors.oracle.result import Result
from swarmactors.runs.launcher import new_run_id, run_world
from swarmactors.runs.scenario import resolve_scenario
from transport import Endpoints

CHECKOUT_OUT = Path(__file__).resolve().parent.parent / "out"  # where runs without an output directory go


def _runs_in(folder: Path) -> set[str]:
    """The run directories under ``out/`` (``out/<name>/<run>``): two levels, nothing read."""
    if not folder.is_dir():
        return set()
    return {f"{name}/{run}" for name in os.listdir(folder) if (folder / name).is_dir()
            for run in os.listdir(folder / name)}


@pytest.fixture(autouse=True)
def _quick_tests_keep_the_checkout_clean(request):
    """A test of the quick tier (not ``slow``) must not write runs into the checkout's ``out/``."""
    if request.node.get_closest_marker("slow"):
        yield
        return
    before = _runs_in(CHECKOUT_OUT)
    yield
    new = sorted(_runs_in(CHECKOUT_OUT) - before)
    assert not new, f"this test wrote into the checkout's out/: {new[:5]} (give the run an output directory)"


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
