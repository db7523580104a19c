"""Trace modes (``run.trace`` = full, summary, off; swarmactors/oracle/trace.py's writer): the same hash in every mode.

Records with delivery rows as ``IntRows`` (as the world builds them) and as plain lists go through the writer in
each mode: ``trace_hash`` is the same everywhere and equals the digest of the records packed by msgpack itself;
``full`` writes them as they are; ``summary`` writes them without ``del``/``drop`` but with their counts, marks
its header and adds ``summary_hash`` (the digest of what it wrote); ``off`` writes no file.
"""

from __future__ import annotations

import hashlib

import msgpack
import numpy as np
import pytest

from swarmactors.oracle.trace import TraceWriter, read_trace
from transport.rows import IntRows


def records(as_arrays: bool) -> list[dict]:
    out = []
    for t in range(4):
        rows = [[s, t + 1, d, t - 1] for s in range(3) for d in range(3) if s != d and t > 0]
        rec = {"t": t, "pos": [[i, 0.5 * i, 1.0] for i in range(3)],
               "sent": [[i, t + 1, "B", None, 4] for i in range(3)]}
        if rows:
            rec["del"] = IntRows(np.array(rows)) if as_arrays else rows
        if t == 2:
            rec["drop"] = [[0, 3, 2, "loss"], [1, 3, 0, "cut"], [2, 3, 1, "loss"]]
        out.append(rec)
    return out


def plain_hash(recs: list[dict]) -> str:
    h = hashlib.blake2b(digest_size=16)
    for rec in recs:
        h.update(msgpack.packb({k: rec[k] for k in ("t", "pos", "sent", "del", "drop") if k == "t" or rec.get(k)},
                               use_bin_type=True))
    return h.hexdigest()


@pytest.mark.parametrize("mode", ["full", "summary", "off"])
@pytest.mark.parametrize("as_arrays", [True, False])
def test_every_mode_gives_the_full_records_hash(tmp_path, mode, as_arrays):
    path = tmp_path / "trace.msgpack"
    w = TraceWriter(path, {"run_id": "r"}, mode=mode)
    for rec in records(as_arrays):
        w.record(rec)
    w.close()
    assert w.trace_hash == plain_hash(records(False))
    if mode == "off":
        assert not path.exists() and w.path is None
        return
    header, recs, footer = read_trace(path)
    assert footer["trace_hash"] == w.trace_hash
    if mode == "full":
        assert "mode" not in header and "summary_hash" not in footer
        assert [r.get("del", []) for r in recs] == [r.get("del", []) for r in records(False)]
    else:
        assert header["mode"] == "summary"
        assert [r.get("ndel", 0) for r in recs] == [0, 6, 6, 6]
        assert recs[2]["ndrop"] == {"cut": 1, "loss": 2} and all("del" not in r and "drop" not in r for r in recs)
        h = hashlib.blake2b(digest_size=16)
        for r in recs:
            h.update(msgpack.packb(r, use_bin_type=True))
        assert footer["summary_hash"] == h.hexdigest()


def test_an_unknown_mode_is_refused():
    with pytest.raises(ValueError, match="trace mode 'some'"):
        TraceWriter(None, {}, mode="some")


@pytest.mark.parametrize("mode", ["full", "summary"])
def test_a_trace_of_either_mode_verifies_and_an_edited_one_does_not(tmp_path, mode):
    from swarmactors.oracle.trace import TraceError, verify

    path = tmp_path / "trace.msgpack"
    w = TraceWriter(path, {"run_id": "r"}, mode=mode)
    for rec in records(True):
        w.record(rec)
    w.close()
    assert verify(path) == w.trace_hash  # a summary trace is checked against its summary_hash
    header, recs, footer = read_trace(path)
    recs[1]["pos"][0][1] = 9.0  # one coordinate edited
    with open(path, "wb") as f:
        for obj in (header, *recs, footer):
            f.write(msgpack.packb(obj, use_bin_type=True))
    with pytest.raises(TraceError, match="hash mismatch"):
        verify(path)
