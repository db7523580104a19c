"""``swarmactors new NAME`` (issue 26): the skeleton's own test passes as generated."""

from __future__ import annotations

import subprocess
import sys

import pytest

from swarmactors.cli import main
from swarmactors.newproject import check_name


def test_names_are_python_identifiers():
    assert check_name("my_proto") == "my_proto"
    for bad in ("My-Proto", "1x", "class", ""):
        with pytest.raises(ValueError):
            check_name(bad)


def test_refuses_to_overwrite(tmp_path, capsys):
    assert main(["new", "gossip", "--dir", str(tmp_path)]) == 0
    assert main(["new", "gossip", "--dir", str(tmp_path)]) == 2
    assert "already exists" in capsys.readouterr().err
    assert main(["new", "gossip", "--dir", str(tmp_path), "--force"]) == 0
    assert main(["new", "Bad-Name", "--dir", str(tmp_path)]) == 2


@pytest.mark.slow
def test_generated_test_passes(tmp_path):
    assert main(["new", "my_gossip", "--dir", str(tmp_path)]) == 0
    folder = tmp_path / "my_gossip"
    assert sorted(p.name for p in folder.iterdir()) == ["my_gossip.py", "my_gossip.toml", "test_my_gossip.py"]
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(folder)],
                          cwd=folder, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "2 passed" in done.stdout
