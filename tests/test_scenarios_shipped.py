"""Every file in scenarios/ is loaded, validated, and run for a few ticks under both clocks.

The pinned-hash tests (tests/test_pins.py) run the lockstep scenarios to the end; these make sure that no
shipped scenario can rot under the other clock or by a change of the scenario format. A scenario whose own
clock is lockstep is run here under realtime only: its lockstep run is the pin's (same file, same clock, the
trace hash asserted), and test_pins.py checks that every such scenario is pinned.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from swarmactors.runs.launcher import run
from swarmactors.runs.scenario import load

SCENARIOS = sorted((Path(__file__).resolve().parent.parent / "scenarios").glob("*.toml"))


def _own_clock(path: Path) -> str:
    return tomllib.loads(path.read_text()).get("run", {}).get("clock", "lockstep")


# (scenario, clock) for a few ticks: the other clock than the file's own, and a realtime file's own clock too
FEW_TICKS = [(p, clock) for p in SCENARIOS for clock in ("lockstep", "realtime")
             if clock == "realtime" or _own_clock(p) != "lockstep"]


def test_there_are_shipped_scenarios():
    assert len(SCENARIOS) >= 9


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.name for p in SCENARIOS])
def test_shipped_scenario_loads_and_validates(path):
    sc = load(path)
    assert sc["run"]["name"] and sc["run"]["ticks"] > 0 and sc["robots"]
    assert all(b.get("use") for group in sc["robots"] for b in group.get("behaviors", []))


@pytest.mark.slow
@pytest.mark.parametrize("path,clock", FEW_TICKS, ids=[f"{clock}-{p.name}" for p, clock in FEW_TICKS])
def test_shipped_scenario_runs_a_few_ticks(path, clock, tmp_path):
    overrides = ["run.ticks=4", f"run.clock={clock}", "run.trace=true", "checks=[]"]
    if clock == "realtime":
        overrides.append("run.dt=0.02")
    result = run(path, out=tmp_path, overrides=overrides)
    assert result["ticks"] == 4
    assert result["stop_reason"] is None
    assert result.trace_path is not None and result.trace_path.exists()
    alive = [r for r in result["robots"].values() if r["alive"]]
    assert alive, "every robot failed"
    failed = {rid: r["failed"] for rid, r in result["robots"].items()
              if r["failed"] and r["failed"]["cause"] != "killed"}
    assert not failed, failed
