"""A host's batched decoding of frame copies equals decoding each copy on its own (no Zenoh)."""

from __future__ import annotations

import msgspec
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmactors.robot.inputs import FrameTable, decode_copies
from transport.messages import FrameIn

_scalars = st.none() | st.booleans() | st.integers(-(2**63), 2**64 - 1) | st.floats(allow_nan=False) | st.text(
    max_size=5) | st.binary(max_size=5)
_values = st.recursive(_scalars, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=3),
                                                                                             inner, max_size=3),
                       max_leaves=8)
# valid bodies, an invalid one, and one with a trailing byte (one value and more: undecodable on its own)
_bodies = _values.map(msgspec.msgpack.encode) | st.sampled_from([b"\xc1", b"\x92\x01\x02\x03", b""])


def _mutables(value, out: list) -> list:
    if isinstance(value, (list, dict)):
        out.append(value)
        for v in value.values() if isinstance(value, dict) else value:
            _mutables(v, out)
    return out


@settings(max_examples=150, deadline=None)
@given(bodies=st.lists(_bodies, min_size=1, max_size=5), data=st.data())
def test_batched_copies_equal_one_decoding_per_copy(bodies, data):
    frames = [FrameIn(k, "K", k, b, float(k)) for k, b in enumerate(bodies)]
    k_ = st.integers(0, len(frames) - 1)
    inboxes = data.draw(st.lists(st.lists(k_, max_size=6, unique=True), max_size=8))
    counts = [sum(k in box for box in inboxes) for k in range(len(frames))]
    # counts may be short of the truth (a receiver beyond its count decodes its own copy)
    counts = [max(0, c - data.draw(st.integers(0, 1))) for c in counts]
    batched, plain = FrameTable(frames, counts), FrameTable(frames)
    held: list = []  # every mutable object handed out, held so that no id is reused
    for box in inboxes:
        got = batched.inbox(box)
        assert got == plain.inbox(box)
        held += [o for f in got[0] for o in _mutables(f.body, [])]
    assert len({id(o) for o in held}) == len(held)  # no list or map is shared between two receivers


@given(value=_values, n=st.sampled_from([1, 2, 15, 16, 17]))
@settings(max_examples=30, deadline=None)
def test_decode_copies_is_n_independent_decodings(value, n):
    body = msgspec.msgpack.encode(value)
    copies = decode_copies(body, n)
    assert len(copies) == n and copies[0] == copies[-1] == msgspec.msgpack.decode(body)
    if isinstance(value, (list, dict)) and n > 1:
        assert copies[0] is not copies[1]


def test_decode_copies_with_long_array_headers():
    body = msgspec.msgpack.encode([1])
    for n in (0xFFFF, 0x10000):
        copies = decode_copies(body, n)
        assert len(copies) == n and copies[-1] == [1] and copies[0] is not copies[-1]
