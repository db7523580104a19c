"""The checks stream the trace (issue 28): no check of any shipped family reads ``Result.trace``.

Each shipped scenario with checks runs briefly at K = 0; its checks, judged as ``swarmactors run`` judges them,
must never build ``Result.trace`` (every record in memory), and must give the same outcomes when the records
come from memory instead of the file.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from swarmactors.oracle.result import Result
from swarmactors.runs.launcher import judge, run

pytestmark = pytest.mark.slow  # each case runs a world over Zenoh

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"
CASES = {  # scenario -> ticks: long enough for each check to have something to judge
    "flooding": 12, "cbaa": 30, "stigmergy": 120, "lambda2": 40, "biconnected-removal": 130,
    "biconnectivity-check": 60, "roles-patrol": 80, "leader-follower": 150, "secs-prominence": 60,
    "maze-flood": 20,
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_checks_never_read_the_whole_trace(name, tmp_path):
    out = tmp_path / name
    run(SCENARIOS / f"{name}.toml", out=out, processes=0, overrides=[f"run.ticks={CASES[name]}"])
    streamed = Result.load(out)
    specs = streamed["scenario"]["checks"]
    assert specs
    got = judge(streamed, specs)
    assert "trace" not in streamed.__dict__, "a check read Result.trace"
    assert not [o for o in got if o["detail"].startswith("check raised")], got
    in_memory = Result.load(out)
    in_memory.trace  # noqa: B018 — records() now yields from memory
    assert judge(in_memory, specs) == got
