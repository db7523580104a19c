"""The paper experiments written as sweep files: each plans, and its trial and post run.

The files: benchmarks/*.toml and protocols/*/experiments/*.toml.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from swarmactors.sweep import plan, read_spec, returned_values, run_sweep

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "benchmarks"
TABLE2 = ROOT / "protocols" / "tsc" / "experiments" / "tsc-table2.toml"
# beside their scripts: in benchmarks/, or in a family's wing (protocols/<family>/experiments/)
SWEEP_FILES = sorted(p for p in [*BENCH.glob("*.toml"), *ROOT.glob("protocols/*/experiments/*.toml")]
                     if read_spec(p) is not None)


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
