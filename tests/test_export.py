"""``swarmactors export`` and the tables behind it (issue 26): round trips against result.json and the trace."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from swarmactors.cli import main
from swarmactors.oracle.result import Result
from swarmactors.tools import export as ex

RECORDS = [
    {"t": 0, "pos": [[0, 0.0, 0.0], [1, 1.0, 0.0]], "status": {0: {"role": "leader"}},
     "sent": [[0, 1, "HI", None, 3]]},
    {"t": 1, "pos": [[0, 0.0, 0.5], [1, 1.0, 0.5]], "del": [[0, 1, 1, 0]], "status": {1: {"role": "x", "n": 2}},
     "sent": [[1, 1, "YO", 0, 4]], "drop": [[1, 1, 0, "loss"]]},
    {"t": 2, "pos": [[1, 1.0, 1.0]]},
]


def test_pose_rows_carry_status_forward():
    columns, rows = ex.pose_rows(RECORDS, {0: 0.25, 1: 0.0})
    assert columns == ["tick", "id", "x", "y", "heading", "n", "role"]
    assert len(rows) == 5
    assert rows[2] == {"tick": 1, "id": 0, "x": 0.0, "y": 0.5, "heading": pytest.approx(math.pi / 2),
                       "role": "leader"}
    assert rows[-1] == {"tick": 2, "id": 1, "x": 1.0, "y": 1.0, "heading": pytest.approx(math.pi / 2), "role": "x",
                        "n": 2}


def test_heading_is_the_last_move_and_the_scenario_heading_before_any():
    recs = [{"t": 0, "pos": [[0, 0.0, 0.0], [1, 5.0, 5.0]]},
            {"t": 1, "pos": [[0, 1.0, 1.0], [1, 5.0, 5.0], [2, 9.0, 9.0]]},  # robot 2 added during the run
            {"t": 2, "pos": [[0, 1.0, 1.0], [1, 4.0, 5.0], [2, 9.0, 8.0]]},
            {"t": 3, "pos": [[0, 1.0, 1.0], [1, 4.0, 5.0], [2, 9.0, 8.0]]}]
    got = list(ex.iter_pose_rows(recs, {0: 0.5, 1: -1.0}))
    table = {(r["tick"], r["id"]): r["heading"] for r in got}
    assert table[0, 0] == 0.5 and table[0, 1] == -1.0  # no move yet: the scenario's heading
    assert table[1, 0] == pytest.approx(math.pi / 4) and table[1, 1] == -1.0 and table[1, 2] is None
    assert table[2, 1] == pytest.approx(math.pi) and table[2, 2] == pytest.approx(-math.pi / 2)
    assert table[3, 0] == pytest.approx(math.pi / 4) and table[3, 1] == pytest.approx(math.pi)  # carried forward


def test_frame_rows():
    rows = ex.frame_rows(RECORDS)
    assert [r["outcome"] for r in rows] == ["sent", "delivered", "sent", "loss"]
    assert rows[1] == {"tick": 1, "src": 0, "seq": 1, "kind": "HI", "dst": 1, "size": 3, "outcome": "delivered",
                       "sent_tick": 0}
    assert rows[3]["kind"] == "YO" and rows[3]["sent_tick"] == 1


def test_frames_are_forgotten_once_no_row_can_name_them():
    recs = [{"t": 0, "sent": [[0, 1, "A", None, 3]]}, {"t": 1, "del": [[0, 1, 1, 0]]},
            {"t": 3, "del": [[0, 1, 2, 0]], "drop": [[0, 1, 3, "dead"]]}]
    kept = [r["kind"] for r in ex.iter_frame_rows(recs)]
    assert kept == ["A", "A", "A", "A"]
    assert [r["kind"] for r in ex.iter_frame_rows(recs, within=1)] == ["A", "A", None, None]  # gone after tick 1
    assert ex.frame_window({"run": {"clock": "lockstep"}, "radio": {"latency": 2}}) == 2
    assert ex.frame_window({"run": {"clock": "realtime"}, "radio": {"latency": 2}}) is None


def test_bad_format_and_missing_trace(tmp_path):
    with pytest.raises(ex.ExportError, match="choose one of"):
        ex.export(tmp_path, tmp_path, "xlsx")
    with pytest.raises(ex.ExportError, match="no such trace"):
        ex.export(tmp_path, tmp_path, "csv")


def test_parquet_without_pyarrow_says_how_to_install(tmp_path, monkeypatch):
    import builtins

    real = builtins.__import__

    def no_pyarrow(name, *a, **k):
        if name.startswith("pyarrow") or name.startswith("pandas"):
            raise ImportError(name)
        return real(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", no_pyarrow)
    with pytest.raises(ex.ExportError, match=r"swarmactors\[export\]"):
        ex.export(tmp_path, tmp_path, "parquet")
    with pytest.raises(ex.ExportError, match="pip install pandas"):
        ex.poses_frame(tmp_path)


@pytest.fixture(scope="module")
def flooding_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("flood")
    scenario = Path(__file__).resolve().parent.parent / "scenarios" / "flooding.toml"
    code = main(["run", str(scenario), "--out", str(out), "--quiet", "--no-plots", "--set", "radio.loss=0.2",
                 "--set", "run.ticks=8"])
    assert code in (0, 1)
    return out


@pytest.mark.slow
def test_lockstep_export_forgets_frames_without_losing_a_name(flooding_run):
    result = Result.load(flooding_run)
    window = ex.frame_window(result["scenario"])
    assert window == 1
    full = list(ex.iter_frame_rows(result.records()))
    assert list(ex.iter_frame_rows(result.records(), window)) == full
    assert all(r["kind"] == "FLOOD" for r in full) and any(r["outcome"] == "loss" for r in full)


@pytest.mark.slow
def test_no_plots_writes_no_picture(flooding_run):
    assert not list(flooding_run.glob("*.png"))


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["csv", "json"])
def test_export_round_trips(flooding_run, tmp_path, fmt, capsys):
    assert main(["export", str(flooding_run), "--format", fmt, "--out", str(tmp_path)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"frames.{fmt}", f"poses.{fmt}"]
    if fmt == "csv":
        with (tmp_path / "poses.csv").open() as f:
            poses = list(csv.DictReader(f))
        with (tmp_path / "frames.csv").open() as f:
            frames = list(csv.DictReader(f))
    else:
        poses = json.loads((tmp_path / "poses.json").read_text())
        frames = json.loads((tmp_path / "frames.json").read_text())
    result = Result.load(flooding_run / "result.json")
    trace = result.trace
    assert len(poses) == sum(len(rec.get("pos", ())) for rec in trace)
    last = trace[-1]["t"]
    for row in poses:
        if int(row["tick"]) == last:
            rid = int(row["id"])
            assert [float(row["x"]), float(row["y"])] == pytest.approx(result.robots[rid]["pose"][:2])
            hop = result.robots[rid].get("status", {}).get("hop")
            assert (row.get("hop") in ("", None)) if hop is None else int(row["hop"]) == hop
    outcome = [r["outcome"] for r in frames]
    world = result["world"]
    assert outcome.count("sent") == world["frames_sent"]
    assert outcome.count("delivered") == world["deliveries"]
    assert outcome.count("loss") == world["dropped"]["loss"] > 0


@pytest.mark.slow
def test_parquet_reads_back_as_the_csv(flooding_run, tmp_path):
    pd = pytest.importorskip("pandas")  # the test extra installs pandas and pyarrow
    pytest.importorskip("pyarrow")
    ex.export(flooding_run, tmp_path / "pq", "parquet")
    ex.export(flooding_run, tmp_path / "csv", "csv")
    for name in ("poses", "frames"):
        pq = pd.read_parquet(tmp_path / "pq" / f"{name}.parquet")
        text = pd.read_csv(tmp_path / "csv" / f"{name}.csv")
        assert list(pq.columns) == list(text.columns) and len(pq) == len(text) > 0
        for col in pq.columns:
            a, b = pq[col], text[col]
            if pd.api.types.is_numeric_dtype(a) and pd.api.types.is_numeric_dtype(b):
                assert a.astype(float).fillna(-1e300).tolist() == pytest.approx(b.astype(float).fillna(-1e300).tolist())
            else:
                assert a.fillna("").astype(str).tolist() == b.fillna("").astype(str).tolist(), col
    poses = pd.read_parquet(tmp_path / "pq" / "poses.parquet")
    assert str(poses["tick"].dtype) == "int64" and str(poses["x"].dtype) == "float64"
    frames = pd.read_parquet(tmp_path / "pq" / "frames.parquet")
    result = Result.load(flooding_run)
    assert (frames["outcome"] == "sent").sum() == result["world"]["frames_sent"]
    assert (frames["outcome"] == "delivered").sum() == result["world"]["deliveries"]


@pytest.mark.slow
def test_dataframes_are_the_exported_tables(flooding_run, tmp_path):
    pd = pytest.importorskip("pandas")
    ex.export(flooding_run, tmp_path, "csv")
    result = Result.load(flooding_run / "result.json")
    poses, frames = result.poses_table(), result.frames_table()
    assert "trace" not in result.__dict__  # streamed: Result.trace was never built
    text = pd.read_csv(tmp_path / "poses.csv")
    assert list(poses.columns) == list(text.columns) and len(poses) == len(text)
    assert poses["x"].tolist() == pytest.approx(text["x"].tolist())
    assert len(poses) == sum(len(rec.get("pos", ())) for rec in result.records())
    assert (frames["outcome"] == "sent").sum() == result["world"]["frames_sent"]
    assert len(frames) == len(ex.frames_frame(flooding_run / "result.json"))
    assert result.poses().equals(poses) and result.frame_log().equals(frames)  # the first release's names


@pytest.mark.slow
def test_export_streams_and_never_reads_the_whole_trace(flooding_run, tmp_path):
    result = Result.load(flooding_run / "result.json")
    ex.export(result, tmp_path, "json")
    assert "trace" not in result.__dict__


WALK = {
    "run": {"name": "walk", "seed": 5, "ticks": 30},
    "world": {"bounds": [[0.0, 0.0], [6.0, 6.0]]},
    "robots": [{"count": 20, "placement": "uniform", "heading": 0.7,
                "behaviors": [{"use": "random_walk", "area": [[0.0, 0.0], [6.0, 6.0]], "speed": 0.2,
                               "turn_every": 7}]}],
}


@pytest.mark.slow
def test_exported_heading_is_the_worlds_for_robots_away_from_the_bounds(tmp_path):
    from swarmactors.runs.launcher import run

    result = run(WALK, out=tmp_path / "walk", processes=0)
    _, rows = ex.tables(result)["poses"]
    first = min(r["tick"] for r in rows)
    assert all(r["heading"] == 0.7 for r in rows if r["tick"] == first)  # the scenario's heading before any move
    last = max(r["tick"] for r in rows)
    judged = 0
    for r in rows:
        if r["tick"] != last or min(r["x"], r["y"], 6.0 - r["x"], 6.0 - r["y"]) < 0.25:
            continue  # a robot at the bounds may have had its step cut: the trace cannot tell its heading
        truth = result.robots[r["id"]]["pose"][-1]  # result.json: the world's own heading
        assert abs((r["heading"] - truth + math.pi) % (2 * math.pi) - math.pi) < 1e-4, (r, truth)
        judged += 1
    assert judged >= 10
