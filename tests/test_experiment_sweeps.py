"""The paper experiments written as sweep files: each plans, and its trial and post run.

A family's experiments live in its wing (protocols/<family>/experiments/*.toml, the trial and post functions named
by their full package path); the ones not moved yet are in benchmarks/*.toml.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

import pytest

from swarmactors.tools.sweep import plan, read_spec, returned_values, run_sweep

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "benchmarks"
TABLE2 = ROOT / "protocols" / "tsc" / "experiments" / "tsc-table2.toml"
WING_FILES = sorted(ROOT.glob("protocols/*/experiments/*.toml"))
SWEEP_FILES = sorted(p for p in BENCH.glob("*.toml") if read_spec(p) is not None) + WING_FILES


@pytest.fixture(autouse=True)
def _benchmarks_importable(monkeypatch):
    monkeypatch.syspath_prepend(str(BENCH))  # as the command line does: modules beside the sweep file


def test_there_are_experiment_sweep_files():
    assert {p.relative_to(ROOT).as_posix() for p in SWEEP_FILES} >= {
        "protocols/tsc/experiments/tsc-table2.toml", "protocols/lambda2/experiments/fig2.toml"}


@pytest.mark.parametrize("path", SWEEP_FILES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_each_experiment_sweep_file_plans(path):
    sw = plan(path, [], [], None, None)  # loads the trial and post functions, validates the grid
    assert sw.trial_fn or sw.scenario.exists()
    assert sw.post and len(sw.all_trials()) >= 2


def test_every_family_wing_with_experiments_has_them():
    wings = {p.parent.parent.name for p in WING_FILES}
    assert wings >= {"relays", "roles", "biconnectivity", "stigmergy", "cbaa", "leader_follower", "secs"}


@pytest.mark.parametrize("path", WING_FILES, ids=lambda p: str(p.relative_to(ROOT)))
def test_a_wing_sweep_file_names_its_own_package(path, monkeypatch):
    """Trial and post are ``protocols.<family>.experiments.<module>:<function>``, importable without sys.path help."""
    monkeypatch.setattr(sys, "path", [p for p in sys.path if Path(p or ".").resolve() not in (BENCH, path.parent)])
    spec = read_spec(path)
    family = path.parent.parent.name
    for key in ("trial", "post"):
        module, _, name = spec[key].partition(":")
        assert module.startswith(f"protocols.{family}.experiments."), (key, spec[key])
        assert callable(getattr(importlib.import_module(module), name))


@pytest.mark.parametrize("wing", sorted({p.parent for p in WING_FILES}), ids=lambda p: p.parent.name)
def test_a_wing_experiments_folder_is_a_package_with_its_commands(wing):
    """experiments/ is a package, and its README gives the command of each script and each sweep file."""
    assert (wing / "__init__.py").is_file()
    readme = (wing / "README.md").read_text()
    package = f"protocols.{wing.parent.name}.experiments"
    for script in wing.glob("*.py"):
        if script.name != "__init__.py":
            assert f"python -m {package}.{script.stem}" in readme, script.name
    for toml in wing.glob("*.toml"):
        assert f"swarmactors sweep {toml.relative_to(ROOT)}" in readme, toml.name


@pytest.mark.slow
def test_the_table2_sweep_solves_and_draws_from_its_csv(tmp_path):
    """Two tiny instances through the sweep engine (in one worker process), then the post step from the CSV."""
    sw = plan(TABLE2, ["quick=true", "time_limit=5"], ["class=1", "density=0.05,0.5"], 1, tmp_path / "t2")
    assert sw.trial_fn == "protocols.tsc.experiments.tsc_experiments:sweep_trial"  # by its full package path
    outcome = run_sweep(sw, workers=1, keep="none")
    assert outcome.errors == 0 and outcome.ran == 2
    records = returned_values(outcome.csv)
    assert [(r["class"], r["density"], r["index"]) for r in records] == [(1, 0.05, 0), (1, 0.5, 0)]
    assert all(r["violations"] == [] and r["tctm"]["status"] in ("optimal", "time_limit") for r in records)
    made = {p.name for p in outcome.plots}
    assert {"table2.json", "tsc-times.png", "tsc-dislocation.png", "tsc-arms.png"} <= made
