"""A newcomer's pass over every shipped scenario (issue 43): ``swarmactors run`` writes each picture it lists.

Every file in scenarios/ (scenarios/relays.toml included) runs through the command line for a few ticks, without
its checks, in two processes side by side (each runs half the scenarios one after another, importing once). Each
run must end with exit 0 (no robot crashed), list its files on the summary's ``files:`` line, and every PNG
listed must be there and be a picture; the pictures every traced run draws (swarm, connectivity, messages,
trajectories, and convergence for a behaviour with a ``plot_field``) must be among them, and ``roles.png`` only
when a robot reported a role.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from swarmactors.robot.plugins import BEHAVIORS, resolve

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parent.parent
SCENARIOS = sorted((REPO / "scenarios").glob("*.toml"))
TICKS = 12
PNG = b"\x89PNG\r\n\x1a\n"

RUNNER = """
import contextlib, io, json, sys
from swarmactors.cli import main

out, ticks, paths = sys.argv[1], sys.argv[2], sys.argv[3:]
results = {}
for path in paths:
    name = path.rsplit("/", 1)[-1].removesuffix(".toml")
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = main(["run", path, "--set", f"run.ticks={ticks}", "--set", "checks=[]", "--out", f"{out}/{name}"])
    results[name] = {"code": code, "stderr": err.getvalue()}
print(json.dumps(results))
"""


def expected_pictures(path: Path) -> set[str]:
    """What every run of this scenario draws: swarm.png, and with a trace the charts and the trajectories."""
    sc = tomllib.loads(path.read_text())
    pictures = {"swarm.png"}
    if sc.get("run", {}).get("trace", True) not in (False, "off"):
        pictures |= {"connectivity.png", "messages.png", "trajectories.png"}
        uses = [b["use"] for g in sc.get("robots", []) for b in g.get("behaviors", [])]
        if any(getattr(resolve(BEHAVIORS, u), "plot_field", None) for u in uses):
            pictures.add("convergence.png")
    return pictures


def test_every_shipped_scenario_writes_every_picture_it_lists(tmp_path):
    assert "relays.toml" in {p.name for p in SCENARIOS}
    halves = [SCENARIOS[0::2], SCENARIOS[1::2]]
    procs = [subprocess.Popen([sys.executable, "-c", RUNNER, str(tmp_path), str(TICKS), *map(str, half)],
                              cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for half in halves]
    results: dict[str, dict] = {}
    for proc in procs:
        out, err = proc.communicate(timeout=600)
        assert proc.returncode == 0, err[-3000:]
        results.update(json.loads(out))
    assert set(results) == {p.stem for p in SCENARIOS}
    for path in SCENARIOS:
        run = results[path.stem]
        assert run["code"] == 0, (path.name, run["stderr"][-2000:])
        files_line = [ln for ln in run["stderr"].splitlines() if ln.startswith("files: ")]
        assert len(files_line) == 1, (path.name, run["stderr"][-2000:])
        listed = files_line[0].removeprefix("files: ").split(", ")
        pictures = {f for f in listed if f.endswith(".png")}
        folder = tmp_path / path.stem
        for name in pictures:
            data = (folder / name).read_bytes()
            assert data.startswith(PNG) and len(data) > 5000, (path.name, name)
        assert expected_pictures(path) <= pictures, (path.name, pictures)
        roles = (folder / "trace.msgpack").exists() and _reports_a_role(folder)
        assert ("roles.png" in pictures) == roles, (path.name, pictures)
        assert {p.name for p in folder.glob("*.png")} == pictures, path.name  # listed only when written


def _reports_a_role(folder: Path) -> bool:
    from swarmactors.oracle.result import Result

    return any("role" in changes for rec in Result.load(folder).records()
               for changes in rec.get("status", {}).values())
