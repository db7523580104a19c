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
