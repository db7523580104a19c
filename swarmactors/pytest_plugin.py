"""pytest plugin (registered through the ``pytest11`` entry point): run swarms and conformance suites.

Fixtures:

* ``swarm_run`` - ``swarm_run(scenario, **overrides) -> Result``: run a scenario
  (a dict as parsed from TOML, a ``Scenario`` or a path) with output in the
  test's temporary directory; overrides as for ``swarmactors.run``.
* ``conformance`` - ``conformance(family, BehaviorClass)``: run one case of the
  family's suite against the class and fail with the oracle's report. The test
  is parametrised over the family's cases (one test per case). The family is
  named where pytest sees it when it collects the test, by the marker
  ``@pytest.mark.conformance_family("name")`` (on the test, its class or the
  module's ``pytestmark``)::

      @pytest.mark.conformance_family("biconnectivity")
      def test_my_bicon(conformance):
          conformance("biconnectivity", MyBicon)

  or, in one line, ``test_my_bicon = conformance_test("biconnectivity", MyBicon)``.
  The suite is the quick one unless ``--swarm-full`` is given.
"""

from __future__ import annotations

import pytest

MARKER = "conformance_family"


def pytest_addoption(parser):
    parser.addoption("--swarm-full", action="store_true", help="conformance fixture: run the full suites")


def pytest_configure(config):
    config.addinivalue_line("markers", f"{MARKER}(name): the family the conformance fixture runs")


def conformance_test(family: str, behavior=None, determinism: bool = True):
    """A test function that runs ``family``'s suite (one test per case) against ``behavior``.

    ``behavior`` is a Behavior class, a ``module:Class`` path, or None for the family's built-in
    implementation. Assign the result to a ``test_...`` name in a test module.
    """

    @pytest.mark.conformance_family(family)
    def test(conformance):
        conformance(family, behavior, determinism=determinism)

    name = getattr(behavior, "__name__", behavior or "the built-in behaviour")
    test.__doc__ = f"The {family} conformance suite against {name}."
    return test


def pytest_generate_tests(metafunc):
    if "conformance" not in metafunc.fixturenames:
        return
    from swarmactors.runs.conformance import select

    marker = metafunc.definition.get_closest_marker(MARKER)
    if marker is None or len(marker.args) != 1 or not isinstance(marker.args[0], str):
        raise pytest.UsageError(
            f"{metafunc.function.__name__}: the conformance fixture needs the family: mark the test "
            f"@pytest.mark.{MARKER}(\"name\") or write test_x = conformance_test(\"name\", Class)")
    family = marker.args[0]
    mode = "full" if metafunc.config.getoption("--swarm-full") else "quick"
    cases = [case.name for _, case in select(family, mode)]
    metafunc.parametrize("conformance", [(family, mode, c) for c in cases], ids=cases, indirect=True)


@pytest.fixture
def conformance(request, tmp_path):
    family_name, mode, case_name = request.param

    def run(family: str, behavior=None, determinism: bool = True):
        from swarmactors.runs.conformance import behavior_path, case_by_name, run_case

        if family != family_name:
            raise pytest.UsageError(f"conformance({family!r}) but the test is parametrised for {family_name!r}")
        fam, case = case_by_name(family_name, case_name, mode)
        path = None if behavior is None else behavior_path(behavior)
        result = run_case(fam, case, path, tmp_path, determinism=determinism)
        if not result.passed:
            lines = [f"{case_name} failed (seed {result.seed}, first tick {result.first_tick})"]
            lines += [f"  {o['name']}: value {o['value']} bound {o['bound']}: {o['detail']}"
                      for o in result.outcomes if not o["passed"]]
            if result.reproduce:
                lines.append(f"  reproduce: swarmactors run {result.reproduce}")
            pytest.fail("\n".join(lines), pytrace=False)
        return result

    return run


@pytest.fixture
def swarm_run(tmp_path):
    from swarmactors.runs.launcher import run

    counter = iter(range(1_000_000))

    def go(scenario, **overrides):
        return run(scenario, out=tmp_path / f"run{next(counter)}", **overrides)

    return go
