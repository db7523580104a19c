"""The conformance kit: built-ins pass their suites, mutants are caught, user code is checked."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from swarmactors import Scenario
from swarmactors.runs.conformance import case_by_name, families, run_case

TESTS = Path(__file__).resolve().parent


# -- the built-in implementations pass their own quick suites (one test per case, via the plugin) --------------
@pytest.mark.slow
@pytest.mark.conformance_family("flooding")
def test_builtin_flooding(conformance):
    conformance("flooding")


@pytest.mark.slow
@pytest.mark.conformance_family("biconnectivity")
def test_builtin_biconnectivity(conformance):
    conformance("biconnectivity")


@pytest.mark.slow
@pytest.mark.conformance_family("stigmergy")
def test_builtin_stigmergy(conformance):
    conformance("stigmergy")


@pytest.mark.slow
@pytest.mark.conformance_family("cbaa")
def test_builtin_cbaa(conformance):
    conformance("cbaa")


def test_every_family_has_a_quick_and_a_larger_full_suite():
    fams = families()
    assert {"flooding", "biconnectivity", "stigmergy", "cbaa"} <= set(fams)
    for fam in fams.values():
        quick, full = fam.suite("quick"), fam.suite("full")
        assert quick and len(full) > len(quick)
        assert {c.name for c in quick} <= {c.name for c in full}
        clocks = {c.scenario["run"].get("clock", "lockstep") for c in full}
        assert clocks == {"lockstep", "realtime"}, fam.name


# -- mutants: each deliberately broken variant fails the named case on the named check -------------------------
MUTANTS = [
    ("flooding", "FloodBackToSender", "flooding/ring-8", "flooding.not_to_sender"),
    ("flooding", "FloodIgnoresExpiry", "flooding/ring-8", "flooding.reach"),
    ("flooding", "FloodWithHiddenState", "flooding/rgg-20-s1", "determinism"),
    ("cbaa", "CBAAHigherIdWins", "cbaa/line-6-tied-tasks-5", "cbaa.greedy"),
    ("cbaa", "CBAAKeepsOutbidTask", "cbaa/ring-8-tasks-10", "cbaa.conflict_free"),
    ("stigmergy", "StigmergyNoRelay", "stigmergy/ring-10", "stigmergy.consistent"),
    ("stigmergy", "StigmergyLowerWriterWins", "stigmergy/ring-10", "stigmergy.consistent"),
    ("biconnectivity", "BiconNoRelay", "biconnectivity/ring-6", "biconnectivity.verdict"),
    ("biconnectivity", "BiconShortDCR", "biconnectivity/comb-7", "biconnectivity.lists"),
]


@pytest.mark.slow
@pytest.mark.parametrize("family,mutant,case,check", MUTANTS, ids=[m[1] for m in MUTANTS])
def test_mutant_is_caught_by_the_named_case(family, mutant, case, check, tmp_path):
    fam, c = case_by_name(family, case)
    result = run_case(fam, c, f"mutants:{mutant}", tmp_path, determinism=check == "determinism")
    assert not result.passed
    failed = {o["name"] for o in result.outcomes if not o["passed"]}
    assert check in failed, failed
    assert result.reproduce and Path(result.reproduce).exists()


@pytest.mark.slow
def test_mutants_of_a_family_fail_and_builtin_passes_the_same_case(builtin_case_run):
    fam, c = case_by_name("cbaa", "cbaa/line-6-tied-tasks-5")
    assert builtin_case_run(fam, c).passed  # control: its checks, and K = 2 agreeing (tests/conftest.py)


# -- the command line: a user's module, the report, JUnit, exit codes, reproduction ---------------------------
def check_cmd(*args, cwd=TESTS):
    return subprocess.run([sys.executable, "-m", "swarmactors", "check", *args], cwd=cwd, capture_output=True,
                          text=True, timeout=600)


@pytest.mark.slow
def test_user_behaviour_from_outside_the_project_runs_and_is_checked(tmp_path):
    (tmp_path / "myflood.py").write_text(textwrap.dedent("""
        from protocols.flooding.behavior import Flooding

        class MyFlood(Flooding):
            '''A user's copy of the protocol, in a module outside the project.'''
    """))
    out = check_cmd("flooding", "--behavior", "myflood:MyFlood", "--clock", "lockstep", "--out",
                    str(tmp_path / "o"), "--json", str(tmp_path / "r.json"), "--jobs", "2", cwd=tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    results = json.loads((tmp_path / "r.json").read_text())
    assert len(results) == 5 and all(r["passed"] for r in results)
    assert all(any(o["name"] == "determinism" and o["passed"] for o in r["outcomes"]) for r in results)


BAD_USERS = {
    "import": ("nosuchmodule:Thing", "cannot import 'nosuchmodule'"),
    "class": ("badflood:NotAClass", "is not a class"),
    "field": ("badflood:NoForwarded", "lacks field 'forwarded'"),
    "type": ("badflood:WrongType", "field 'received' is list, expected dict"),
}


@pytest.mark.slow
@pytest.mark.parametrize("kind", sorted(BAD_USERS))
def test_bad_user_behaviour_gives_a_clear_error_and_exit_2(kind, tmp_path):
    (tmp_path / "badflood.py").write_text(textwrap.dedent("""
        from protocols.flooding.behavior import Flooding

        NotAClass = 42

        class NoForwarded(Flooding):
            def report(self):
                rep = super().report()
                del rep["forwarded"]
                return rep

        class WrongType(Flooding):
            def report(self):
                return {**super().report(), "received": []}
    """))
    behavior, message = BAD_USERS[kind]
    out = check_cmd("flooding", "--behavior", behavior, "--out", str(tmp_path / "o"), cwd=tmp_path)
    assert out.returncode == 2, out.stderr[-2000:]
    assert message in out.stderr
    assert behavior.split(":")[0] in out.stderr  # names the module/class
    assert "Traceback" not in out.stderr


@pytest.mark.slow
def test_failure_report_junit_and_reproduction(tmp_path):
    junit = tmp_path / "report.xml"
    out = check_cmd("flooding", "--behavior", "mutants:FloodIgnoresExpiry", "--clock", "lockstep",
                    "--no-determinism", "--out", str(tmp_path / "o"), "--junit", str(junit),
                    "--json", str(tmp_path / "r.json"))
    assert out.returncode == 1
    assert "FAILED flooding/ring-8: flooding.reach" in out.stderr
    results = {r["case"]: r for r in json.loads((tmp_path / "r.json").read_text())}
    failed = results["flooding/ring-8"]
    assert failed["first_tick"] is not None and failed["seed"] == 1
    assert f"swarmactors run {failed['reproduce']}" in out.stderr
    # JUnit: valid XML, one testcase per case, failures where the report says
    suite = ET.parse(junit).getroot()
    cases = {tc.get("name"): tc for tc in suite.iter("testcase")}
    assert set(cases) == set(results)
    assert int(suite.get("failures")) == sum(not r["passed"] for r in results.values())
    assert cases["flooding/ring-8"].find("failure") is not None
    # the printed scenario file reproduces the failure: same check, same first tick
    repro = Path(failed["reproduce"])
    assert tomllib.loads(repro.read_text())["robots"][0]["behaviors"][0]["use"] == "mutants:FloodIgnoresExpiry"
    run = subprocess.run([sys.executable, "-m", "swarmactors", "run", str(repro), "--out", str(tmp_path / "re"),
                          "--quiet", "--json"], cwd=TESTS, capture_output=True, text=True, timeout=300)
    assert run.returncode == 1, run.stderr[-2000:]
    again = {c["name"]: c for c in json.loads(run.stdout)["checks"]}
    assert not again["flooding.reach"]["passed"]
    assert again["flooding.reach"]["first_tick"] == failed["first_tick"]


@pytest.mark.slow
def test_check_rejects_an_unknown_family():
    out = check_cmd("telepathy")
    assert out.returncode == 2 and "unknown family 'telepathy'" in out.stderr


# -- the Python API and the swarm_run fixture ------------------------------------------------------------------
@pytest.mark.slow
def test_scenario_builder_and_swarm_run_fixture(swarm_run):
    sc = (Scenario("api", seed=2, ticks=10)
          .robots(positions=[[0.0, 0.0], [0.8, 0.0], [1.6, 0.0]],
                  behaviors=[{"use": "flooding", "origin": 0, "at": 1, "expiry": 5}])
          .check("flooding.reach"))
    result = swarm_run(sc)
    assert result.passed and result.check("flooding.reach")["value"] == 3
    assert result.graph_at(1).number_of_edges() == 2
    lossy = swarm_run(sc.raw, radio__loss=1.0)  # overrides as keyword arguments
    assert lossy["world"]["dropped"]["loss"] > 0
    assert "loss = 1.0" in sc.radio(loss=1.0).to_toml()


# -- the pytest plugin in a user's own suite: the family comes from a marker or conformance_test ---------------
USER_TESTS = '''
import pytest
from swarmactors.pytest_plugin import conformance_test

test_flood_mutant = conformance_test("flooding", "mutants:FloodBackToSender", determinism=False)

@pytest.mark.conformance_family("flooding")
def test_flood_builtin(conformance):
    conformance("flooding", determinism=False)

def test_no_family(conformance):
    conformance("flooding")
'''


def _pytest_user_file(tmp_path, body: str, *args: str) -> subprocess.CompletedProcess:
    (tmp_path / "test_user.py").write_text(body)
    env = {**__import__("os").environ, "PYTHONPATH": str(TESTS)}
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "test_user.py", *args],
                          cwd=tmp_path, capture_output=True, text=True, timeout=300, env=env)


@pytest.mark.slow
def test_plugin_reads_the_family_from_the_marker_or_conformance_test(tmp_path):
    user = USER_TESTS.replace("def test_no_family", "def _unused")
    out = _pytest_user_file(tmp_path, user, "-k", "ring-8", "-rA")
    text = out.stdout + out.stderr
    assert ("test_flood_builtin[flooding/ring-8] PASSED" in text
            or "PASSED test_user.py::test_flood_builtin" in text), text
    assert "test_flood_mutant[flooding/ring-8]" in text and "1 failed, 1 passed" in text, text
    assert "flooding.not_to_sender" in text, text  # the oracle's report names the failed check


@pytest.mark.slow
def test_plugin_without_a_family_is_a_usage_error(tmp_path):
    out = _pytest_user_file(tmp_path, USER_TESTS, "-k", "no_family")
    text = out.stdout + out.stderr
    assert out.returncode != 0
    assert "test_no_family" in text and "conformance_family" in text, text
