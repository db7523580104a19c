"""Shared fixtures: running scenarios given as dicts, in a temporary directory; runs shared by a whole session."""

from __future__ import annotations

import asyncio
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from swarmactors.oracle.result import Result
from swarmactors.runs.conformance import run_case as _run_case
from swarmactors.runs.launcher import new_run_id, run_world
from swarmactors.runs.scenario import resolve_scenario
from transport import Endpoints

CHECKOUT_OUT = Path(__file__).resolve().parent.parent / "out"  # where runs without an output directory go
SHIPPED = Path(__file__).resolve().parent.parent / "scenarios"


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
    assert not new, (f"this test wrote into the checkout's out/: {new[:5]} (give the run an output directory; "
                     "or another process ran in this checkout meanwhile, e.g. an experiment without --out)")


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


# -- runs that several tests judge: each computed once per session, on first use ------------------------------
@pytest.fixture(scope="session")
def shipped_run(tmp_path_factory):
    """``shipped_run(name, processes)`` -> the Result of ``scenarios/<name>`` run to its end, once per session.

    tests/test_pins.py pins its trace hash; other tests judge the same run's checks and metrics.
    """
    from swarmactors.runs.launcher import run as run_file

    done: dict[tuple[str, int], Result] = {}

    def get(name: str, processes: int) -> Result:
        if (name, processes) not in done:
            out = tmp_path_factory.mktemp(f"shipped-{name.removesuffix('.toml')}-k{processes}")
            done[name, processes] = run_file(SHIPPED / name, out=out, processes=processes)
        return done[name, processes]

    return get


@pytest.fixture(scope="session")
def shipped_inprocess(tmp_path_factory):
    """``shipped_inprocess(name, hosts)`` -> ``run_inprocess`` of ``scenarios/<name>`` (no Zenoh), once per session.

    tests/test_pins.py pins its trace hash (hosts = 2); tests/unit/test_inprocess.py judges the same run's checks.
    """
    from swarmactors.runs.inprocess import run_inprocess

    done: dict[tuple[str, int], Result] = {}

    def get(name: str, hosts: int) -> Result:
        if (name, hosts) not in done:
            out = tmp_path_factory.mktemp(f"inprocess-{name.removesuffix('.toml')}-h{hosts}")
            done[name, hosts] = run_inprocess(SHIPPED / name, out=out, hosts=hosts)
        return done[name, hosts]

    return get


@pytest.fixture(scope="session")
def builtin_case_run(tmp_path_factory):
    """``builtin_case_run(family, case)`` -> ``run_case(family, case, None, out, determinism=True)``, once per session.

    The built-in behaviour on a conformance case (K = 0, then K = 2 for a lockstep case): tests/test_pins.py pins
    its trace hash and the conformance fixture judges its checks, from the same run.
    """
    done: dict[tuple, object] = {}

    def get(family, case):
        key = (family.name, case.name, json.dumps(case.scenario, sort_keys=True, default=repr))
        if key not in done:
            done[key] = _run_case(family, case, None, tmp_path_factory.mktemp("case"), determinism=True)
        return done[key]

    return get


@pytest.fixture
def conformance(conformance, builtin_case_run, monkeypatch):
    """The plugin's fixture, with the built-in behaviour's runs (determinism judged) shared with tests/test_pins.py."""
    import swarmactors.runs.conformance as kit

    own = kit.run_case

    def run_case(family, case, behavior, out_dir, clock=None, determinism=True):
        if behavior is None and clock is None and determinism:
            return builtin_case_run(family, case)
        return own(family, case, behavior, out_dir, clock=clock, determinism=determinism)

    monkeypatch.setattr(kit, "run_case", run_case)
    return conformance



@pytest.fixture(scope="session")
def clean_flood(tmp_path_factory):
    """test_bad_input.py's FLOOD_RAW, undisturbed, through its WireRun harness (pause and resume included).

    Once per session: the wire-garbage tests there and the attack tests (tests/test_attacks.py) compare their
    disturbed runs with it.
    """
    from test_bad_input import FLOOD_RAW, WireRun

    return WireRun(FLOOD_RAW, tmp_path_factory.mktemp("clean") / "run").run()


@pytest.fixture(scope="session")
def image():
    """Build (or reuse) the base image and the project image, once per session; the compose command.

    tests/test_docker.py and tests/test_cluster.py's compose profile test run containers of it.
    """
    from needs import require_docker

    compose = require_docker()
    env = {**os.environ, "PYTHON": sys.executable}
    out = subprocess.run([str(SHIPPED.parent / "docker" / "build-image.sh")], env=env, capture_output=True,
                         text=True, timeout=1200)
    assert out.returncode == 0, out.stderr + out.stdout
    return compose
