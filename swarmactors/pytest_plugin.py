"""pytest plugin (registered through the ``pytest11`` entry point): run swarms and conformance suites.

Fixtures:

* ``swarm_run`` - ``swarm_run(scenario, **overrides) -> Result``: run a scenario
  (a dict as parsed from TOML, a ``Scenario`` or a path) with output in the
  test's temporary directory; overrides as for ``swarmactors.run``.
* ``conformance`` - ``conformance(family, BehaviorClass)``: run one case of the
  family's suite against the class and fail with the oracle's report. The test
  is parametrised over the family's cases, so::

      def test_my_bicon(conformance):
          conformance("biconnectivity", MyBicon)

  gives one test per case. The family is read from the call in the test's
  body (or from ``@pytest.mark.conformance_family("name")``); the suite is the
  quick one unless ``--swarm-full`` is given.
"""

from __future__ import annotations

import ast
import inspect
import textwrap

import pytest


def pytest_addoption(parser):
    parser.addoption("--swarm-full", action="store_true", help="conformance fixture: run the full suites")


def pytest_configure(config):
    config.addinivalue_line("markers", "conformance_family(name): the family the conformance fixture runs")


def _family_of(function) -> str | None:
    """The first string literal passed to ``conformance(...)`` in the test's body."""
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(function)))
    except (OSError, TypeError, SyntaxError):
        return None
    for node in ast.walk(tree):
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "conformance"
                and node.args and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)):
            return node.args[0].value
    return None


def pytest_generate_tests(metafunc):
    if "conformance" not in metafunc.fixturenames:
        return
    from swarmactors.conformance import select

    marker = metafunc.definition.get_closest_marker("conformance_family")
    family = marker.args[0] if marker else _family_of(metafunc.function)
    if family is None:
        raise pytest.UsageError(f"{metafunc.function.__name__}: cannot tell which family the conformance fixture "
                                f"runs; call conformance(\"family\", Class) or mark conformance_family(\"name\")")
    mode = "full" if metafunc.config.getoption("--swarm-full") else "quick"
    cases = [case.name for _, case in select(family, mode)]
    metafunc.parametrize("conformance", [(family, mode, c) for c in cases], ids=cases, indirect=True)


@pytest.fixture
def conformance(request, tmp_path):
    family_name, mode, case_name = request.param

    def run(family: str, behavior=None, determinism: bool = True):
        from swarmactors.conformance import behavior_path, case_by_name, run_case

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
    from swarmactors.launcher import run

    counter = iter(range(1_000_000))

    def go(scenario, **overrides):
        return run(scenario, out=tmp_path / f"run{next(counter)}", **overrides)

    return go
