"""``swarmactors new NAME``: a family as a wing of its own, whose tests and conformance check pass as generated.

Adding a family touches only its wing and one entry-point line: here the wing is generated in a temporary
folder and the line registered the way pip registers a package's entry points (a ``.dist-info`` directory with
an ``entry_points.txt``, on ``PYTHONPATH``), so every process of a run (the world, the host processes of the
determinism case) finds the family by name. Nothing in swarmactors/ or protocols/ names it.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from swarmactors.cli import main
from swarmactors.tools.newproject import check_name, entry_point_line, generate

ROOT = Path(__file__).resolve().parents[1]
WING = ["__init__.py", "behavior.py", "experiments/README.md", "messages.py", "oracle.py", "rules.py",
        "scenarios/{n}.toml", "suite.py", "tests/__init__.py", "tests/test_{n}.py"]


def test_names_are_python_identifiers():
    assert check_name("my_proto") == "my_proto"
    for bad in ("My-Proto", "1x", "class", ""):
        with pytest.raises(ValueError):
            check_name(bad)


def test_refuses_to_overwrite(tmp_path, capsys):
    assert main(["new", "gossip", "--dir", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    assert 'gossip = "gossip.suite:FAMILY"' in err and '[project.entry-points."swarmactors.families"]' in err
    assert main(["new", "gossip", "--dir", str(tmp_path)]) == 2
    assert "already exists" in capsys.readouterr().err
    assert main(["new", "gossip", "--dir", str(tmp_path), "--force"]) == 0
    assert main(["new", "Bad-Name", "--dir", str(tmp_path)]) == 2


def test_the_wing_and_its_package_path(tmp_path):
    paths = generate("max_g", tmp_path)
    assert sorted(str(p.relative_to(tmp_path / "max_g")) for p in paths) == sorted(w.format(n="max_g") for w in WING)
    # inside a package (a checkout's protocols/), the entry point names the full package path
    (tmp_path / "protocols").mkdir()
    (tmp_path / "protocols" / "__init__.py").write_text("")
    generate("max_g", tmp_path / "protocols")
    assert entry_point_line("max_g", tmp_path / "protocols") == 'max_g = "protocols.max_g.suite:FAMILY"'
    assert '"max_g": "protocols.max_g.behavior:MaxG"' in (tmp_path / "protocols/max_g/suite.py").read_text()


def test_the_generated_code_is_ruff_clean_under_the_projects_rules(tmp_path):
    """As if generated in a checkout's protocols/ (swarmactors first-party; docstrings, imports, bugbear)."""
    ruff = Path(sys.executable).parent / "ruff"
    if not ruff.exists():
        pytest.skip("ruff is not installed beside this interpreter")
    generate("max_g", tmp_path)
    done = subprocess.run([str(ruff), "check", "--no-cache", "--config", str(ROOT / "pyproject.toml"),
                           str(tmp_path / "max_g")], capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 0, done.stdout + done.stderr


def _register(tmp_path: Path, name: str) -> dict:
    """The family's one entry-point line, installed as pip would; the environment that sees it."""
    dist = tmp_path / f"{name}-0.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.0\n")
    line = entry_point_line(name, tmp_path).replace('"', "")  # entry_points.txt is INI: values unquoted
    (dist / "entry_points.txt").write_text(f"[swarmactors.families]\n{line}\n")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(tmp_path), *filter(None, [env.get("PYTHONPATH")])])
    return env


def test_an_unregistered_family_is_unknown_and_a_broken_one_is_reported(tmp_path):
    generate("max_g", tmp_path)
    env = _register(tmp_path, "max_g")
    (tmp_path / "max_g" / "suite.py").write_text("raise ImportError('broken on purpose')\n")
    done = subprocess.run([sys.executable, "-m", "swarmactors", "list", "families"], env=env, cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    line = next(ln for ln in done.stdout.splitlines() if ln.startswith("max_g"))
    assert "NOT LOADED" in line and "broken on purpose" in line
    assert any(ln.startswith("relays ") for ln in done.stdout.splitlines())  # the others still load


@pytest.mark.slow  # generated tests (real runs, the quick suite twice each) then `swarmactors check`: ~1-2 min
def test_a_generated_family_passes_its_tests_and_its_check(tmp_path):
    name = "max_g"
    generate(name, tmp_path)
    env = _register(tmp_path, name)
    listed = subprocess.run([sys.executable, "-m", "swarmactors", "list", "families"], env=env, cwd=tmp_path,
                            capture_output=True, text=True, timeout=120)
    assert any(ln.split()[:4] == [name, "1", "behaviour,", "2"] for ln in listed.stdout.splitlines()), listed.stdout
    tests = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", f"{name}/tests"],
                           env=env, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert tests.returncode == 0, tests.stdout + tests.stderr
    assert "7 passed" in tests.stdout, tests.stdout  # 5 tests, and the quick conformance suite's 2 cases
    check = subprocess.run([sys.executable, "-m", "swarmactors", "check", name, "--out", str(tmp_path / "out"),
                            "--json", str(tmp_path / "check.json")], env=env, cwd=tmp_path, capture_output=True,
                           text=True, timeout=600)
    assert check.returncode == 0, check.stdout + check.stderr

    results = json.loads((tmp_path / "check.json").read_text())
    cases = results["cases"] if isinstance(results, dict) else results
    assert len(cases) == 2 and all(c["passed"] for c in cases)
    names = {o["name"] for c in cases for o in c["outcomes"]}
    assert {f"{name}.agreed", f"{name}.clean", "determinism"} <= names
    # the checks can fail: an implementation that ignores what it hears and sends a body that does not decode
    (tmp_path / "wrong.py").write_text(
        "from max_g.behavior import MaxG\n\n\nclass Deaf(MaxG):\n"
        "    def on_frame(self, ctx, frame):\n        pass\n\n"
        "    def on_start(self, ctx):\n        super().on_start(ctx)\n"
        "        ctx.broadcast('max_g.best', ['not a number'])\n\n\n"
        "class Garbled(MaxG):\n    def on_start(self, ctx):\n        super().on_start(ctx)\n"
        "        ctx.broadcast('max_g.best', ['not a number'])\n")
    for cls, failing in (("Deaf", {f"{name}.agreed"}), ("Garbled", {f"{name}.clean"})):
        bad = subprocess.run([sys.executable, "-m", "swarmactors", "check", name, "--behavior", f"wrong:{cls}",
                              "--no-determinism", "--out", str(tmp_path / cls),
                              "--json", str(tmp_path / f"{cls}.json")],
                             env=env, cwd=tmp_path, capture_output=True, text=True, timeout=600)
        assert bad.returncode == 1, bad.stdout + bad.stderr
        got = json.loads((tmp_path / f"{cls}.json").read_text())
        got = got["cases"] if isinstance(got, dict) else got
        assert {o["name"] for c in got for o in c["outcomes"] if not o["passed"]} == failing
