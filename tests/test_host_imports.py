"""Robot hosts run without the oracle: no networkx, no scipy, no ``swarmactors.runs.conformance`` (issue 13).

Nor the ``[foxglove]`` extra (foxglove-sdk, mcap): the MCAP export and the live Foxglove feed run beside the world.
Nor the ``[rl]`` extra (pettingzoo, gymnasium): the ``rl`` behaviour loads without it (swarmactors/rl/behavior.py).
Nor a family's experiments (``protocols/<family>/experiments``: the paper figures' scripts, matplotlib and all).

The world process may import scipy (KD-trees); a robot host process (K >= 1) runs behaviours only. Every
built-in behaviour runs in some shipped scenario; each is run for a few ticks with one host process, and a
test behaviour reports from inside that process what it has imported.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"
# between them, every built-in behaviour: beacon, biconnectivity, cbaa, flooding, aat, roles, stigmergy, election
SHIPPED = ["beacon", "biconnectivity-check", "cbaa", "flooding", "roles-aat", "roles-patrol", "stigmergy"]
ORACLE = ("sorted(m for m in sys.modules"
          " if m.split('.')[0] in {'networkx', 'scipy', 'foxglove', 'mcap', 'pettingzoo', 'gymnasium'}"
          " or m.startswith('swarmactors.runs.conformance')"
          " or (m.startswith('protocols.') and '.experiments' in m))")  # a family's paper experiments


def test_the_behavior_api_and_every_builtin_behaviour_load_without_the_oracle():
    """As a host does: the registry loads every family (its suite.py) to know the behaviour names."""
    from swarmactors.robot.plugins import BEHAVIORS, available

    modules = sorted({target.split(":")[0] for target in available(BEHAVIORS).values()})
    assert "protocols.relays.behavior" in modules and "swarmactors.rl.behavior" in modules
    code = ("import sys\nfrom swarmactors import Behavior, Context, Frame\nimport swarmactors.robot.host\n"
            "from swarmactors.robot.plugins import BEHAVIORS, available, broken_families\n"
            "assert available(BEHAVIORS) and not broken_families(), broken_families()\n"
            + "".join(f"import {m}\n" for m in modules) + f"print({ORACLE})")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout


@pytest.mark.slow
@pytest.mark.parametrize("name", SHIPPED)
def test_a_host_process_that_ran_the_behaviour_imported_no_oracle(run, name):
    raw = tomllib.loads((SCENARIOS / f"{name}.toml").read_text())
    raw["robots"][0].setdefault("behaviors", []).append({"use": "behaviors_for_tests:HostImports"})
    result = run(raw, overrides=["run.ticks=4", "checks=[]"], processes=1)
    reports = [r["host_imports"] for r in result.robots.values() if "host_imports" in r]
    assert reports
    for rep in reports:
        assert rep["pid"] != os.getpid()  # reported from the host process, not this one
        assert rep["modules"] == []  # neither networkx, scipy, the conformance kit nor the foxglove extra
