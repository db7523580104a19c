"""The registries built from the families: one ``swarmactors.families`` entry point per family.

Third-party packages are installed here the way pip does it: a ``.dist-info`` directory with an
``entry_points.txt``, on ``sys.path``.
"""

from __future__ import annotations

import warnings

import pytest

from swarmactors.robot import plugins
from swarmactors.robot.family import Family
from swarmactors.robot.plugins import BEHAVIORS, CHECKS, COMMANDS, PluginError


@pytest.fixture
def install(tmp_path, monkeypatch):
    """``install(dist, {group: {name: value}}, {module: source})``: a package, as pip would leave it."""
    monkeypatch.syspath_prepend(str(tmp_path))
    plugins.forget()

    def go(dist: str, groups: dict, modules: dict | None = None) -> None:
        info = tmp_path / f"{dist}-1.0.dist-info"
        info.mkdir()
        (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: 1.0\n")
        (info / "entry_points.txt").write_text("".join(
            f"[{g}]\n" + "".join(f"{k} = {v}\n" for k, v in eps.items()) for g, eps in groups.items()))
        for name, source in (modules or {}).items():
            (tmp_path / f"{name}.py").write_text(source)
        plugins.forget()

    yield go
    plugins.forget()


def test_the_shipped_families_register_what_the_per_name_groups_did():
    assert {"core", "flooding", "relays", "tsc", "beacon", "mobility", "secs"} <= set(plugins.families())
    assert not plugins.broken_families()
    assert plugins.available(BEHAVIORS)["relays"] == "protocols.relays.behavior:Relays"
    assert plugins.available(CHECKS)["world.no_collisions"] == "swarmactors.oracle.world_checks:no_collisions"
    assert plugins.available(COMMANDS) == {"schedule": "protocols.tsc.schedule_cli"}
    assert plugins.family_of(CHECKS, "relays.healed") == "relays" and plugins.family_of(BEHAVIORS, "rl") == "core"
    assert len(plugins.available(BEHAVIORS)) == 16 and len(plugins.available(CHECKS)) == 39


def test_a_family_object_refuses_what_is_not_a_name_and_a_path():
    with pytest.raises(ValueError, match="module:attribute"):
        Family(name="x", checks={"x.a": "no_colon"})
    with pytest.raises(ValueError, match="not one of its behaviours"):
        Family(name="x", behavior="y", behaviors={"x": "m:X"})
    with pytest.raises(ValueError, match="identifier"):
        Family(name="not a name")


def test_a_name_two_families_register_is_refused_naming_both(install):
    install("clash", {"swarmactors.families": {"aaa": "clash_fam:FAMILY"}},
            {"clash_fam": "from swarmactors.robot.family import Family\n"
                          "FAMILY = Family(name='aaa', behaviors={'flooding': 'clash_fam:X'})\n"})
    broken = plugins.broken_families()
    assert "'flooding'" in broken["aaa"] and "'aaa'" in broken["aaa"] and "'flooding' refused" not in broken["aaa"]
    assert "family 'flooding'" in broken["aaa"]
    assert plugins.available(BEHAVIORS)["flooding"] == "protocols.flooding.behavior:Flooding"  # the shipped one
    assert "aaa" not in plugins.families()


def test_a_family_that_cannot_load_is_reported_and_the_others_work(install):
    install("bad", {"swarmactors.families": {"bad": "bad_fam:FAMILY", "notfam": "bad_fam2:FAMILY"}},
            {"bad_fam": "raise RuntimeError('on purpose')\n", "bad_fam2": "FAMILY = 3\n"})
    broken = plugins.broken_families()
    assert "RuntimeError: on purpose" in broken["bad"] and "not a swarmactors.robot.family.Family" in broken["notfam"]
    assert "relays" in plugins.families()
    with pytest.raises(PluginError, match="family 'bad' not loaded: .*on purpose"):
        plugins.resolve(BEHAVIORS, "nothing_such")


def test_the_old_per_name_groups_still_work_with_a_deprecation_warning(install):
    install("old-plugin", {"swarmactors.behaviors": {"oldbeh": "old_mod:Old"},
                           "swarmactors.checks": {"old.check": "old_mod:check"}},
            {"old_mod": "from swarmactors import Behavior\nclass Old(Behavior):\n    pass\n"
                        "def check(result):\n    return []\n"})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert plugins.available(BEHAVIORS)["oldbeh"] == "old_mod:Old"
    assert any(issubclass(w.category, DeprecationWarning) and "swarmactors.families" in str(w.message)
               for w in caught)
    assert plugins.resolve_behavior("oldbeh").__name__ == "Old"
    assert plugins.family_of(CHECKS, "old.check") == "old_plugin"


def test_a_family_contributes_a_subcommand_and_the_core_imports_no_protocol(capsys):
    from swarmactors.cli import build_parser

    parser = build_parser()
    args = parser.parse_args(["schedule", "tasks.toml", "--no-plot"])
    assert args.handler.__module__ == "protocols.tsc.schedule_cli"


def test_reading_every_family_imports_no_oracle_nor_the_scenario_loader():
    """A robot host reads every family's suite.py to know the behaviour names; that must stay light."""
    import subprocess
    import sys

    code = ("import sys\nfrom swarmactors.robot.plugins import BEHAVIORS, available\navailable(BEHAVIORS)\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in {'networkx', 'scipy', 'matplotlib'}"
            " or m.startswith(('swarmactors.runs.conformance', 'swarmactors.runs.scenario', 'protocols.tsc.schedule'))"
            " or m.endswith('.oracle')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout
