"""After a run, the pictures stream the trace: no picture reads every tick record into memory (issue 28)."""

from __future__ import annotations

import pytest

from swarmactors.oracle.result import Result
from swarmactors.oracle.trace import read_trace
from swarmactors.tools.charts import write_charts
from swarmactors.tools.plots import plot_run
from swarmactors.tools.trajectories import plot_result_trajectories, status_track, thinned_records

pytestmark = pytest.mark.slow  # runs a world over Zenoh for its trace

ROLES = {
    "run": {"name": "stream", "seed": 3, "ticks": 40},
    "world": {"bounds": [[0.0, 0.0], [3.0, 3.0]]},
    "robots": [{"count": 6, "placement": "grid", "spacing": 0.6, "speed": 0.2,
                "behaviors": [{"use": "tests_support:RandomWalk"}, {"use": "beacon", "every": 3}]}],
}


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    from swarmactors.runs.launcher import run

    return run(ROLES, out=tmp_path_factory.mktemp("stream") / "run", processes=0)


def test_pictures_never_read_the_whole_trace(finished, tmp_path):
    result = Result.load(finished.path)
    plot_run(result, tmp_path / "swarm.png", "moved")
    write_charts(result, tmp_path)
    plot_result_trajectories(result, tmp_path / "trajectories.png")
    assert "trace" not in result.__dict__  # Result.trace (every record as Python objects) was never built
    for name in ("swarm.png", "connectivity.png", "messages.png", "trajectories.png"):
        assert (tmp_path / name).stat().st_size > 0


def test_streamed_records_are_the_trace_and_the_last_one_is_the_last_tick(finished):
    result = Result.load(finished.path)
    _, records, _ = read_trace(result.trace_path)
    assert list(result.records()) == records
    assert result.last_record() == records[-1]
    assert result.last_state() == (records[-1], result.severed_at(records[-1]["t"]))
    assert result.record(17) == records[17]
    assert result.final_graph().edges == Result.load(finished.path).graph_at(records[-1]["t"]).edges


def test_thinned_records_keep_every_status_change_up_to_each_kept_tick(finished):
    result = Result.load(finished.path)
    _, records, _ = read_trace(result.trace_path)
    kept = thinned_records(result, most=7)
    every = -(-len(records) // 7)
    assert [r["t"] for r in kept] == [r["t"] for r in records[::every]] + (
        [records[-1]["t"]] if (len(records) - 1) % every else [])
    ids = sorted({row[0] for r in records for row in r["pos"]})
    full = status_track(records, ids, "moved")
    thin = status_track(kept, ids, "moved")
    index = {r["t"]: k for k, r in enumerate(records)}
    for k, rec in enumerate(kept):
        assert all(thin[rid][k] == full[rid][index[rec["t"]]] for rid in ids)
    assert any(v is not None for rid in ids for v in thin[rid])  # the status field is there to compare
