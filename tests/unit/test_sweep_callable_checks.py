"""A callable sweep's trial that returns ``"checks": {name: passed}`` gets a verdict, as a scenario run does."""

from __future__ import annotations

import textwrap

from swarmactors.tools.sweep import plan, run_sweep

TRIAL = '''
def trial(params, seed, trial):
    """Fails its one check on the grid point x = 2."""
    return {"x": params["x"], "checks": {"demo.small": params["x"] < 2}}
'''


def test_a_failed_returned_check_counts_as_a_failed_trial(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(tmp_path))  # as the command line does: modules beside the sweep file
    (tmp_path / "checked_trial.py").write_text(textwrap.dedent(TRIAL))
    spec = tmp_path / "checked.toml"
    spec.write_text('[sweep]\ntrial = "checked_trial:trial"\ngrid = { x = [1, 2] }\ntrials = 1\n')
    outcome = run_sweep(plan(spec, [], [], None, tmp_path / "out"), workers=1, keep="none")
    assert outcome.errors == 0 and outcome.ran == 2
    assert outcome.failed == 1 and outcome.failed_by_check == {"demo.small": 1}
    rows = outcome.csv.read_text().splitlines()
    header = rows[0].split(",")
    assert "passed" in header and "check.demo.small" in header and "metric.checks.demo.small" in header
    by_x = {r.split(",")[0]: dict(zip(header, r.split(","), strict=True)) for r in rows[1:]}
    assert by_x["1"]["passed"] == "true" and by_x["1"]["check.demo.small"] == "pass"
    assert by_x["2"]["passed"] == "false" and by_x["2"]["check.demo.small"] == "fail"


def test_a_check_with_several_outcomes_fails_if_any_outcome_fails():
    # One outcome per chain (relays.reached) or per robot: a trial's {name: passed} must not keep only the last.
    from swarmactors.oracle.result import Result

    outcomes = [{"name": "relays.reached", "passed": True}, {"name": "relays.reached", "passed": False},
                {"name": "relays.reached", "passed": True}, {"name": "relays.links_within_db", "passed": True}]
    assert Result({"checks": outcomes}).verdicts() == {"relays.reached": False, "relays.links_within_db": True}
    assert Result({"checks": []}).verdicts() == {}
