"""A full disk for the trace does not lose the run: the hash and result.json survive."""

from __future__ import annotations

import os

import pytest

from tests_support_runs import small_flood

pytestmark = pytest.mark.slow  # runs a world over Zenoh


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full to simulate a full disk")
def test_full_disk_for_trace_keeps_the_result(run, tmp_path):
    reference = run(small_flood(), name="ref")
    out = tmp_path / "full"
    out.mkdir()
    (out / "trace.msgpack").symlink_to("/dev/full")
    result = run(small_flood(), name="full")
    assert "No space left" in result["trace_error"]
    assert result["trace"] is None
    assert result["trace_hash"] == reference["trace_hash"]  # hashing does not depend on the file
    assert result.reports("flooding") == reference.reports("flooding")


# ------------------------------------------------------------------------------------------------ issue 28
def test_zstd_trace_has_the_same_hash_and_reads_back(tmp_path):
    from swarmactors.oracle.trace import ZSTD_MAGIC, read_trace, verify
    from swarmactors.runs.launcher import run

    raw = {"run": {"name": "z", "ticks": 30},
           "robots": [{"count": 12, "placement": "line", "behaviors": [{"use": "beacon"}]}]}
    plain = run(raw, out=tmp_path / "plain", processes=0)
    packed = run(raw, out=tmp_path / "zstd", processes=0, run__trace_compression="zstd")
    assert packed.trace_path.read_bytes()[:4] == ZSTD_MAGIC
    assert packed["trace_hash"] == plain["trace_hash"] == verify(packed.trace_path)
    assert read_trace(packed.trace_path)[1] == read_trace(plain.trace_path)[1]
    assert packed.trace_path.stat().st_size < plain.trace_path.stat().st_size / 3


def test_the_trace_writer_flushes_at_least_once_per_second(tmp_path, monkeypatch):
    import swarmactors.oracle.trace as trace_mod

    clock = [100.0]
    monkeypatch.setattr(trace_mod.time, "monotonic", lambda: clock[0])
    for compression in (None, "zstd"):
        path = tmp_path / f"t-{compression}.msgpack"
        writer = trace_mod.TraceWriter(path, {"run_id": "x"}, compression=compression)
        writer.record({"t": 0, "pos": [[0, 0.0, 0.0]]})
        clock[0] += trace_mod.FLUSH_S  # a second later, the next record goes to disk with everything before it
        writer.record({"t": 1, "pos": [[0, 1.0, 0.0]]})
        header, records, footer = trace_mod.read_trace(path)  # read while the writer is still open
        assert footer is None and [r["t"] for r in records] == [0, 1], compression
        writer.close()
        assert trace_mod.read_trace(path)[2]["ticks"] == 2
