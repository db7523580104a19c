"""The core's typed frame bodies (swarmactors.robot.bodies): decoding into the union, causes, encoding, sending."""

from __future__ import annotations

from collections import Counter

import msgspec
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmactors import Frame
from swarmactors.robot.bodies import UNSET, Bodies, Body, Num, UnsetType, cause_of
from transport.codec import pack


class Ping(Body, kw_only=True):
    KIND = "PING"
    n: int = msgspec.field(name="n")
    at: Num = msgspec.field(name="t")
    note: str | UnsetType = UNSET

    def __post_init__(self):
        if self.n < 0:
            raise ValueError("negative")


class Pair(Body, array_like=True):
    KIND = "PAIR"
    a: int
    b: list[int]


BODIES = Bodies(Ping, Pair)


def test_kinds_and_a_kind_given_twice():
    assert BODIES.kinds == ("PING", "PAIR")
    with pytest.raises(ValueError):
        Bodies(Ping, Ping)


def test_encode_is_the_plain_value_in_field_order_and_unset_is_left_out():
    assert BODIES.encode(Ping(n=1, at=2)) == {"n": 1, "t": 2}
    assert pack(BODIES.encode(Ping(n=1, at=2.5, note="x"))) == pack({"n": 1, "t": 2.5, "note": "x"})
    assert pack(BODIES.encode(Pair(3, [4, 5]))) == pack([3, [4, 5]])


def test_an_integer_stays_an_integer_through_a_round_trip():
    got = BODIES.decode(Frame(1, "PING", {"n": 1, "t": 7}, 1, 0.0))
    assert got == Ping(n=1, at=7) and type(got.at) is int
    assert pack(BODIES.encode(got)) == pack({"n": 1, "t": 7})


@pytest.mark.parametrize(("kind", "body", "cause"), [
    ("PONG", {"n": 1, "t": 0}, "unknown_kind"),
    ("PING", [1, 0], "not_a_map"),
    ("PING", None, "not_a_map"),
    ("PING", {"t": 0}, "missing_field"),
    ("PING", {"n": "1", "t": 0}, "bad_field"),
    ("PING", {"n": True, "t": 0}, "bad_field"),
    ("PING", {"n": -1, "t": 0}, "negative"),
    ("PAIR", {"a": 1}, "not_an_array"),
    ("PAIR", [1], "bad_length"),
    ("PAIR", [1, [2, "x"]], "bad_field"),
])
def test_each_undecodable_body_is_counted_under_its_cause(kind, body, cause):
    counts: Counter = Counter()
    assert BODIES.decode(Frame(1, kind, body, 1, 0.0), counts) is None
    assert counts == {cause: 1}


def test_a_message_from_msgspec_is_never_taken_for_a_cause():
    err = msgspec.ValidationError("Expected `int`, got `str` - at `$.n`")
    assert cause_of(err) == "bad_field"


class FakeCtx:
    def __init__(self):
        self.out = []

    def broadcast(self, kind, body, exclude=()):
        self.out.append(("*", kind, body, tuple(exclude)))

    def send(self, dst, kind, body):
        self.out.append((dst, kind, body, ()))


def test_broadcast_and_send_name_the_kind_and_refuse_a_foreign_struct():
    ctx = FakeCtx()
    BODIES.broadcast(ctx, Ping(n=1, at=0), exclude=[3])
    BODIES.send(ctx, 4, Pair(1, []))
    assert ctx.out == [("*", "PING", {"n": 1, "t": 0}, (3,)), (4, "PAIR", [1, []], ())]

    class Other(Body):
        KIND = "PING"

    with pytest.raises(TypeError):
        BODIES.broadcast(ctx, Other())


class Blob(Body, array_like=True):
    KIND = "BLOB"
    data: bytes
    keys: dict[int, str]


def test_bytes_stay_msgpack_bin_and_integer_keys_stay_integers():
    typed = Blob(b"\x00\x01", {2: "x"})
    assert pack(Bodies(Blob).encode(typed)) == pack([b"\x00\x01", {2: "x"}])


def test_numpy_floats_pack_as_the_plain_floats_msgpack_made_of_them():
    import numpy as np

    assert pack(BODIES.encode(Ping(n=1, at=np.float64(0.1) * 3))) == pack({"n": 1, "t": np.float64(0.1) * 3})


_scalars = st.none() | st.booleans() | st.integers(-5, 5) | st.floats(allow_nan=False) | st.text(max_size=3)
_values = st.recursive(_scalars, lambda inner: st.lists(inner, max_size=3)
                       | st.dictionaries(st.sampled_from("ntab"), inner, max_size=3), max_leaves=6)
_pings = st.builds(lambda n, t: {"n": n, "t": t}, st.integers(-2, 3), st.integers() | st.floats())
_pairs = st.builds(lambda a, b: [a, b], st.integers(-2, 2) | st.text(max_size=1), st.lists(st.integers(-2, 2),
                                                                                            max_size=2))
_bodies = _values | _pings | _pairs


class _Shaped(Bodies):
    """A subclass with shapes of its own: a bare int is a Pair with no list."""

    def decode_body(self, kind, body, counts=None):
        return super().decode_body(kind, [body, []] if isinstance(body, int) and kind == "PAIR" else body, counts)


@settings(max_examples=200, deadline=None)
@given(kind=st.sampled_from(["PING", "PAIR", "PONG"]), body=_bodies)
def test_decode_is_decode_body_of_the_frames_kind_and_body(kind, body):
    for bodies in (BODIES, _Shaped(Ping, Pair)):
        got, want = Counter(), Counter()
        assert bodies.decode(Frame(1, kind, body, 1, 0.0), got) == bodies.decode_body(kind, body, want)
        assert got == want
    assert _Shaped(Ping, Pair).decode(Frame(1, "PAIR", 4, 1, 0.0)) == Pair(4, [])  # the subclass's shape
