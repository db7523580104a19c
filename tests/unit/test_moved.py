"""The flat module paths of earlier releases: they still import, warn, and are the new modules themselves.

This file names the old paths on purpose; every other module of the repository uses the new ones, which the last
test checks.
"""

from __future__ import annotations

import ast
import importlib
import re
import sys
import warnings
from pathlib import Path

import pytest

from swarmactors._moved import MOVED

ROOT = Path(__file__).resolve().parents[2]
SCANNED = ["swarmactors", "protocols", "world", "transport", "tests", "benchmarks"]
GROUPS = {"swarmactors.checks"}  # an entry-point group that shares its name with an old module path
OLD_LEAVES = "|".join(sorted((old.split(".", 1)[1] for old in MOVED), key=len, reverse=True))
CODE_IN_STRING = re.compile(rf"\b(?:import\s+swarmactors\.|from\s+swarmactors\.)({OLD_LEAVES})\b"
                            rf"|\bfrom\s+swarmactors\s+import\s+({OLD_LEAVES})\b")
MODULE_PATH = re.compile(r"swarmactors(?:\.\w+)+(?::\w+)?")


def _forget(monkeypatch, name: str) -> None:
    """Import ``name`` afresh in this test: out of sys.modules and off its package."""
    monkeypatch.delitem(sys.modules, name, raising=False)
    package, _, leaf = name.rpartition(".")
    monkeypatch.delattr(sys.modules[package], leaf, raising=False)


def test_an_old_path_imports_the_new_module_with_a_deprecation_warning(monkeypatch):
    _forget(monkeypatch, "swarmactors.scenario")
    with pytest.warns(DeprecationWarning, match="swarmactors.scenario moved to swarmactors.runs.scenario; the old "
                                                "path goes in a later release") as caught:
        import swarmactors.scenario as old
    import swarmactors.runs.scenario as new

    assert old is new
    assert old.__name__ == "swarmactors.runs.scenario" and old.__spec__.name == "swarmactors.runs.scenario"
    assert caught[0].filename == __file__  # the warning points at the importing line


def test_from_an_old_path_import_a_name(monkeypatch):
    _forget(monkeypatch, "swarmactors.result")
    with pytest.warns(DeprecationWarning, match="swarmactors.result moved to swarmactors.oracle.result"):
        from swarmactors.result import Result
    from swarmactors.oracle.result import Result as NewResult

    assert Result is NewResult


@pytest.mark.parametrize("old", sorted(MOVED))
def test_every_old_path_is_its_new_module(monkeypatch, old):
    _forget(monkeypatch, old)
    with pytest.warns(DeprecationWarning, match=f"{re.escape(old)} moved to {re.escape(MOVED[old])}"):
        module = importlib.import_module(old)
    assert module is importlib.import_module(MOVED[old])


def test_the_new_paths_and_the_public_api_import_without_a_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for new in MOVED.values():
            importlib.import_module(new)
        from swarmactors import Behavior, Context, Outcome, Result, Scenario  # noqa: F401


def _old_module(path: str) -> str | None:
    module = path.partition(":")[0]
    for old in MOVED:
        if module == old or module.startswith(old + "."):
            return old
    return None


def _old_paths_in(source: str) -> list[str]:
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [a.name for a in node.names if _old_module(a.name)]
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            if _old_module(node.module):
                found.append(node.module)
            elif node.module == "swarmactors":
                found += [f"swarmactors.{a.name}" for a in node.names if f"swarmactors.{a.name}" in MOVED]
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            text = node.value
            if MODULE_PATH.fullmatch(text) and text not in GROUPS and _old_module(text):
                found.append(text)
            found += [m.group(0) for m in CODE_IN_STRING.finditer(text)]
    return found


def test_no_module_of_the_repository_uses_an_old_path():
    this = Path(__file__).resolve()
    offenders = {}
    for top in SCANNED:
        for path in sorted((ROOT / top).rglob("*.py")):
            if path.resolve() == this or path.name == "_moved.py":
                continue
            if found := _old_paths_in(path.read_text(encoding="utf-8")):
                offenders[str(path.relative_to(ROOT))] = found
    assert offenders == {}
