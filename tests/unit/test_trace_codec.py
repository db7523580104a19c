"""Trace encoding and hashing of ``swarmactors/oracle/trace.py``, without Zenoh.

Rules tested (docs/trace.md), against a canonical form and a digest computed here with msgpack and hashlib:

* canonical records: ``sent`` sorted by (src, seq), ``drop`` by (src, seq, dst), ``status`` keyed in robot-id
  order with each robot's fields sorted by name, ``ev`` and ``mal`` sorted by their msgpack encoding, ``pos``
  and ``del`` kept in the world's order; keys whose list or map would be empty are left out;
* ``trace_hash`` is BLAKE2b-128 over the msgpack encodings of the canonical tick records, concatenated in tick
  order; it is the same whatever order the record's lists and maps were built in (what the world's
  processing order can change), and changes when anything recorded changes, or the tick order does;
* the hash is the same with or without a trace file;
* a written trace reads back (``read_trace``, ``iter_trace``): the header with ``trace`` and ``version``, the
  canonical records (integer status keys intact), and the footer with the tick count and the hash;
  ``verify`` recomputes the hash and rejects a file whose records were changed after the footer.

Damaged files (truncated, corrupt, not a trace) are covered by tests/test_bad_input.py.
"""

from __future__ import annotations

import copy
import hashlib
import random

import msgpack
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmactors.oracle.trace import (
    VERSION,
    TraceError,
    TraceWriter,
    canonical,
    iter_trace,
    read_trace,
    record_problem,
    summarise,
    verify,
)

ORDER = ("t", "pos", "sent", "del", "ovh", "drop", "status", "ev", "mal")


def packb(obj) -> bytes:
    return msgpack.packb(obj, use_bin_type=True)


def my_canonical(rec: dict) -> dict:
    """docs/trace.md's canonical form, written out."""
    out = {"t": rec["t"]}
    sort_keys = {"sent": lambda r: (r[0], r[1]), "drop": lambda r: (r[0], r[1], r[2])}
    for key in ("pos", "sent", "del", "ovh", "drop"):
        if rec.get(key):
            out[key] = sorted(rec[key], key=sort_keys[key]) if key in sort_keys else list(rec[key])
    if rec.get("status"):
        out["status"] = {rid: {f: rec["status"][rid][f] for f in sorted(rec["status"][rid])}
                         for rid in sorted(rec["status"])}
    for key in ("ev", "mal"):
        if rec.get(key):
            out[key] = sorted(rec[key], key=packb)
    return out


def my_hash(records: list[dict]) -> str:
    return hashlib.blake2b(b"".join(packb(my_canonical(r)) for r in records), digest_size=16).hexdigest()


def writer_hash(records: list[dict]) -> str:
    w = TraceWriter(None, {})
    for r in records:
        w.record(copy.deepcopy(r))
    return w.trace_hash


# ------------------------------------------------------------------------------------------------ strategies

IDS = st.integers(min_value=0, max_value=30)
SEQ = st.integers(min_value=1, max_value=50)
COORD = st.integers(min_value=-10**7, max_value=10**7).map(lambda k: k / 10**6)
CAUSES = st.sampled_from(["range", "loss", "cut", "bandwidth", "dead"])
VALUE = st.none() | st.booleans() | st.integers(-1000, 1000) | COORD | st.text(max_size=5)
EVENTS = st.one_of(
    st.builds(lambda t, r: {"t": t, "kill": r, "source": "scenario"}, st.integers(0, 99), st.lists(IDS, max_size=3)),
    st.builds(lambda t, r: {"t": t, "robot": r, "failed": "killed"}, st.integers(0, 99), IDS),
    st.builds(lambda t, p: {"t": t, "loss": p, "source": "control"}, st.integers(0, 99), st.sampled_from([0.1, 0.5])),
    st.builds(lambda t, h: {"t": t, "host_lost": h, "cause": "host-lost"}, st.integers(0, 99), st.text(max_size=3)),
)


@st.composite
def tick_records(draw, t=None):
    t = draw(st.integers(0, 1000)) if t is None else t
    ids = sorted(draw(st.sets(IDS, max_size=6)))
    rec = {"t": t, "pos": [[i, draw(COORD), draw(COORD)] for i in ids]}
    # unique sort keys, as the world guarantees: (src, seq) per frame, (src, seq, dst) per drop
    frames = draw(st.lists(st.tuples(IDS, SEQ), unique=True, max_size=6))
    rec["sent"] = [[s, q, draw(st.sampled_from(["B", "FLOOD"])), draw(st.none() | IDS), draw(st.integers(0, 99))]
                   for s, q in frames]
    rec["del"] = [list(x) for x in draw(st.lists(st.tuples(IDS, SEQ, IDS, st.integers(0, 99)), max_size=6))]
    rec["ovh"] = [list(x) for x in draw(st.lists(st.tuples(IDS, SEQ, IDS, st.integers(0, 99)), max_size=3))]
    rec["drop"] = [[s, q, d, draw(CAUSES)] for s, q, d in draw(st.lists(st.tuples(IDS, SEQ, IDS), unique=True,
                                                                          max_size=6))]
    rec["status"] = draw(st.dictionaries(IDS, st.dictionaries(st.text(min_size=1, max_size=4), VALUE, min_size=1,
                                                                max_size=3), max_size=4))
    rec["ev"] = draw(st.lists(EVENTS, max_size=4))
    rec["mal"] = draw(st.lists(st.text(max_size=8), max_size=3))
    return rec


def shuffled(rec: dict, rnd: random.Random) -> dict:
    """The same record built in another processing order: lists shuffled, maps filled in another order."""
    out = {}
    keys = list(rec)
    rnd.shuffle(keys)
    for k in keys:
        v = rec[k]
        if k in ("sent", "drop", "ev", "mal"):
            v = list(v)
            rnd.shuffle(v)
        elif k == "status":
            rids = list(v)
            rnd.shuffle(rids)
            v = {rid: dict(rnd.sample(list(v[rid].items()), len(v[rid]))) for rid in rids}
        out[k] = copy.deepcopy(v)
    return out


# ------------------------------------------------------------------------------------------------ canonical


@settings(max_examples=50, deadline=None)
@given(tick_records())
def test_canonical_matches_the_documented_form(rec):
    got = canonical(copy.deepcopy(rec))
    want = my_canonical(rec)
    assert got == want
    assert list(got) == [k for k in ORDER if k in got]  # key order is fixed, so it is hashed the same way
    assert packb(got) == packb(want)
    for k in ("pos", "sent", "del", "ovh", "drop", "status", "ev", "mal"):
        assert (k in got) == bool(rec.get(k))  # empty lists and maps are left out


def test_pos_and_del_keep_the_worlds_order():
    rec = {"t": 1, "pos": [[2, 0.0, 0.0], [1, 0.0, 0.0]], "del": [[5, 1, 3, 0], [0, 1, 2, 0]]}
    assert canonical(rec) == rec
    assert writer_hash([rec]) != writer_hash([{**rec, "del": rec["del"][::-1]}])


@settings(max_examples=30, deadline=None)
@given(st.lists(tick_records(), min_size=1, max_size=3), st.randoms(use_true_random=False))
def test_hash_is_the_documented_digest_and_ignores_processing_order(records, rnd):
    h = writer_hash(records)
    assert h == my_hash(records)
    assert len(h) == 32 and int(h, 16) >= 0
    assert writer_hash([shuffled(r, rnd) for r in records]) == h


def _mutations(rec: dict):
    """One-field changes of a record (each must change the hash)."""
    yield "t", {**rec, "t": rec["t"] + 1}
    if rec.get("pos"):
        p = copy.deepcopy(rec["pos"])
        p[0][1] = round(p[0][1] + 1e-6, 6)
        yield "position by 1e-6", {**rec, "pos": p}
        yield "a robot gone", {**rec, "pos": p[1:]}
    if rec.get("sent"):
        s = copy.deepcopy(rec["sent"])
        s[0][4] += 1
        yield "frame size", {**rec, "sent": s}
    if rec.get("drop"):
        d = copy.deepcopy(rec["drop"])
        d[0][3] = "loss" if d[0][3] != "loss" else "cut"
        yield "drop cause", {**rec, "drop": d}
    if rec.get("del"):
        yield "one delivery fewer", {**rec, "del": rec["del"][1:]}
    if rec.get("status"):
        rid = next(iter(rec["status"]))
        yield "status value", {**rec, "status": {**rec["status"], rid: {**rec["status"][rid], "field": 1}}}
    yield "an event", {**rec, "ev": [*rec.get("ev", []), {"t": rec["t"], "heal": True, "source": "scenario"}]}
    yield "a malformed reason", {**rec, "mal": [*rec.get("mal", []), "bad frame"]}


@settings(max_examples=30, deadline=None)
@given(tick_records(), tick_records())
def test_hash_changes_when_anything_recorded_changes(rec, other):
    h = writer_hash([rec, other])
    for what, changed in _mutations(rec):
        assert writer_hash([changed, other]) != h, what
    if my_canonical(rec) != my_canonical(other):
        assert writer_hash([other, rec]) != h  # tick order matters


def test_empty_lists_are_the_same_as_absent_keys():
    bare = {"t": 3, "pos": [[0, 1.0, 2.0]]}
    padded = {**bare, "sent": [], "del": [], "drop": [], "status": {}, "ev": [], "mal": []}
    assert writer_hash([bare]) == writer_hash([padded])


# ------------------------------------------------------------------------------------------------ files


HEADER = {"run_id": "unit-1", "clock": "lockstep", "seed": 7, "pos_digits": 6, "scenario": {"run": {"ticks": 3}}}


@settings(max_examples=25, deadline=None)
@given(st.lists(tick_records(), max_size=3))
def test_write_read_round_trip_and_verify(tmp_path_factory, records):
    records = [{**r, "t": k} for k, r in enumerate(records)]
    path = tmp_path_factory.mktemp("trace") / "trace.msgpack"
    w = TraceWriter(path, HEADER)
    for r in records:
        w.record(copy.deepcopy(r))
    w.close()
    assert w.error is None and w.ticks == len(records)
    header, got, footer = read_trace(path)
    assert header == {"trace": "swarmactors", "version": VERSION, **HEADER}
    assert got == [my_canonical(r) for r in records]  # integer status keys come back as integers
    header_hash = hashlib.blake2b(packb(header), digest_size=16).hexdigest()  # the header as written
    assert footer == {"end": True, "ticks": len(records), "trace_hash": my_hash(records), "header_hash": header_hash}
    assert verify(path) == w.trace_hash == my_hash(records) == writer_hash(records)
    assert list(iter_trace(path)) == [header, *got, footer]


def test_verify_rejects_a_record_changed_after_the_footer(tmp_path):
    records = [{"t": 0, "pos": [[0, 0.0, 0.0], [1, 0.5, 0.0]]}, {"t": 1, "pos": [[0, 0.0, 0.0], [1, 0.5, 0.1]]}]
    path = tmp_path / "trace.msgpack"
    w = TraceWriter(path, HEADER)
    for r in records:
        w.record(r)
    w.close()
    header, got, footer = read_trace(path)
    got[1]["pos"][1][2] = 0.2
    path.write_bytes(b"".join(packb(x) for x in [header, *got, footer]))
    with pytest.raises(TraceError, match="hash mismatch") as info:
        verify(path)
    assert str(path) in str(info.value)


def test_hash_without_a_file_equals_hash_with_a_file(tmp_path):
    records = [{"t": 0, "sent": [[1, 1, "B", None, 4], [0, 1, "B", None, 4]], "status": {2: {"b": 1, "a": 2}}}]
    with_file = TraceWriter(tmp_path / "t.msgpack", HEADER)
    without = TraceWriter(None, HEADER)
    for w in (with_file, without):
        w.record(copy.deepcopy(records[0]))
        w.close()
    assert with_file.trace_hash == without.trace_hash == my_hash(records)


def test_version_1_and_2_traces_are_read_and_others_refused(tmp_path):
    """Version 2 added ``ovh`` (overheard copies, issue 23); a version 1 trace reads as before."""
    rec = {"t": 0, "del": [[0, 1, 2, 0]], "ovh": [[0, 1, 3, 0]]}
    assert record_problem(rec) is None
    assert record_problem({"t": 0, "ovh": [[0, 1]]}) is not None  # a short row
    assert summarise(canonical(dict(rec))) == {"t": 0, "ndel": 1, "novh": 1}
    for version, readable in ((1, True), (2, True), (3, False)):
        path = tmp_path / f"v{version}.msgpack"
        path.write_bytes(packb({"trace": "swarmactors", "version": version, "run_id": "x"}) + packb(rec))
        if readable:
            header, records, footer = read_trace(path)
            assert header["version"] == version and records == [rec] and footer is None
        else:
            with pytest.raises(TraceError, match="trace version 3, this reader knows 1, 2"):
                read_trace(path)


SCALARS = st.one_of(st.integers(min_value=-2**63, max_value=2**64 - 1), st.floats(allow_nan=True),
                    st.text(max_size=300), st.none(), st.booleans())


@settings(max_examples=200, deadline=None)
@given(st.lists(st.lists(SCALARS, max_size=6), max_size=20))
def test_row_lists_pack_to_msgpacks_bytes(rows):
    """The world's row lists (ints, floats, strings, None) are packed by msgspec: the bytes must be msgpack's."""
    from swarmactors.oracle.trace import pack_record

    rec = {"t": 1, "pos": rows, "sent": rows, "drop": rows}
    assert pack_record(rec) == packb(rec)
