"""Replay reads its records from the file by offset (issue 28): every scene equals one fed from the start."""

from __future__ import annotations

import random

import pytest

from swarmactors.oracle.trace import TraceWriter, iter_trace
from swarmactors.tools import replay as rp
from swarmactors.tools.scene import Scene

SCENARIO = {"run": {"name": "stream"}, "radio": {"range": 2.0}, "world": {"bounds": [[0.0, 0.0], [9.0, 9.0]]}}


def _write(path, ticks: int, compression=None) -> list[dict]:
    """A trace of 5 robots walking, with frames in some ticks (so scenes keep recent records) and one failure."""
    w = TraceWriter(path, {"run_id": "r1", "clock": "lockstep", "seed": 1, "pos_digits": 6, "scenario": SCENARIO},
                    compression)
    for t in range(ticks):
        alive = range(5) if t < ticks // 2 else range(1, 5)
        rec = {"t": t, "pos": [[i, round(0.1 * t + i, 6), float(i)] for i in alive],
               "status": {i: {"n": t} for i in alive if (t + i) % 3 == 0}}
        if t % 3 == 0:
            rec["sent"] = [[i, t, "B", None, 4] for i in alive]
        if t % 3 == 1:
            rec["del"] = [[1, t - 1, 2, t - 1]]
            rec["drop"] = [[1, t - 1, 3, "loss"]]
        if t == ticks // 2:
            rec["ev"] = [{"t": t, "robot": 0, "failed": "killed"}]
        w.record(rec)
    w.close()
    return [obj for obj in iter_trace(path) if "t" in obj and not obj.get("end")]


def _fed(records: list[dict], t: int, base: Scene) -> Scene:
    scene = base.copy()
    for rec in records:
        if rec["t"] > t:
            break
        scene.feed_record(rec)
    return scene


@pytest.mark.parametrize("compression", [None, "zstd"])
def test_every_seek_equals_a_scene_fed_from_the_start(tmp_path, monkeypatch, compression):
    monkeypatch.setattr(rp, "CHECKPOINT_EVERY", 4)
    path = tmp_path / "trace.msgpack"
    records = _write(path, 60, compression)
    replay = rp.Replay(path)
    assert len(replay.records) == 60 and replay.records[17] == records[17] and replay.records[-1] == records[-1]
    assert list(replay.records) == records and replay.records[10:13] == records[10:13]
    order = list(range(60)) + random.Random(3).sample(range(60), 60)  # forward, then jumping about
    for t in order:
        got, want = replay.scene_at(t), _fed(records, t, replay._base)
        want.finished = t == 59  # the replay's own flag: the footer was reached
        assert got.frame() == want.frame(), t
        assert list(got.recent) == list(want.recent) and got.t == want.t and got.events == want.events, t
    assert 1 < len(replay._checkpoints) <= rp.CHECKPOINTS_MAX
    assert all(cp.recent == type(cp.recent)() for _, cp, _ in replay._checkpoints)  # indices kept, not records


def test_checkpoints_are_spaced_to_stay_few(tmp_path, monkeypatch):
    monkeypatch.setattr(rp, "CHECKPOINT_EVERY", 2)
    monkeypatch.setattr(rp, "CHECKPOINTS_MAX", 5)
    path = tmp_path / "trace.msgpack"
    records = _write(path, 90)
    replay = rp.Replay(path)
    replay.scene_at(89)
    assert len(replay._checkpoints) == 5  # every 18 records, not every 2
    assert replay.scene_at(40).frame() == _fed(records, 40, replay._base).frame()
