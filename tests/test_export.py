"""``swarmactors export`` and the tables behind it (issue 26): round trips against result.json and the trace."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from swarmactors import export as ex
from swarmactors.cli import main
from swarmactors.result import Result

RECORDS = [
    {"t": 0, "pos": [[0, 0.0, 0.0], [1, 1.0, 0.0]], "status": {0: {"role": "leader"}},
     "sent": [[0, 1, "HI", None, 3]]},
    {"t": 1, "pos": [[0, 0.0, 0.5], [1, 1.0, 0.5]], "del": [[0, 1, 1, 0]], "status": {1: {"role": "x", "n": 2}},
     "sent": [[1, 1, "YO", 0, 4]], "drop": [[1, 1, 0, "loss"]]},
    {"t": 2, "pos": [[1, 1.0, 1.0]]},
]


def test_pose_rows_carry_status_forward():
    columns, rows = ex.pose_rows(RECORDS)
    assert columns == ["tick", "id", "x", "y", "n", "role"]
    assert len(rows) == 5
    assert rows[2] == {"tick": 1, "id": 0, "x": 0.0, "y": 0.5, "role": "leader"}
    assert rows[-1] == {"tick": 2, "id": 1, "x": 1.0, "y": 1.0, "role": "x", "n": 2}


def test_frame_rows():
    rows = ex.frame_rows(RECORDS)
    assert [r["outcome"] for r in rows] == ["sent", "delivered", "sent", "loss"]
    assert rows[1] == {"tick": 1, "src": 0, "seq": 1, "kind": "HI", "dst": 1, "size": 3, "outcome": "delivered",
                       "sent_tick": 0}
    assert rows[3]["kind"] == "YO" and rows[3]["sent_tick"] == 1


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
def test_parquet_and_dataframes(flooding_run, tmp_path):
    pd = pytest.importorskip("pandas")
    pytest.importorskip("pyarrow")
    ex.export(flooding_run, tmp_path, "parquet")
    poses = pd.read_parquet(tmp_path / "poses.parquet")
    frames = pd.read_parquet(tmp_path / "frames.parquet")
    df = ex.poses_frame(flooding_run)
    assert len(poses) == len(df) and list(poses.columns) == list(df.columns)
    assert len(frames) == len(ex.frames_frame(flooding_run / "result.json"))


@pytest.mark.slow
def test_result_dataframes(flooding_run):
    result = Result.load(flooding_run / "result.json")
    try:
        import pandas  # noqa: F401
    except ImportError:
        with pytest.raises(ex.ExportError, match="pip install pandas"):
            result.poses()
        return
    assert len(result.poses()) == sum(len(rec.get("pos", ())) for rec in result.trace)
    assert (result.frame_log()["outcome"] == "sent").sum() == result["world"]["frames_sent"]
