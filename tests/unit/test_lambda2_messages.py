"""The λ2 frame body (msgspec Struct): what is sent, what is refused and why."""

from __future__ import annotations

import math

import pytest

from protocols.lambda2.messages import L2, decode, encode


def test_encode_leaves_out_absent_fields_and_round_trips():
    assert encode(L2(k=3, v=0.5)) == {"k": 3, "v": 0.5}
    assert encode(L2(k=-2, v=0.5, dm=4)) == {"k": -2, "v": 0.5, "dm": 4}
    assert encode(L2(k=3, v=0.5, n=(1, 2.0, 40))) == {"k": 3, "v": 0.5, "n": [1, 2.0, 40]}
    msg = L2(k=7, v=-0.25, a=0.1, m=0.9)
    assert decode(encode(msg), flood=12) == msg


@pytest.mark.parametrize("body,cause", [
    ({"k": 1, "v": math.nan}, "nonfinite"),
    ({"k": 1, "v": 0.5, "a": math.inf}, "nonfinite"),
    ({"k": 1}, "malformed"),
    ({"k": 1, "v": "x"}, "malformed"),
    ({"k": True, "v": 1.0}, "malformed"),
    ({"k": 1, "v": 1.0, "n": [0, -1.0, 30]}, "malformed"),  # a norm that is not > 0
    ({"k": 1, "v": 1.0, "n": [0, 1.0, 14]}, "malformed"),  # a period not longer than flood + 2
    ({"k": 1, "v": 1.0, "q": 2.0}, "malformed"),  # an unknown field
    ("garbage", "malformed"),
    (None, "malformed"),
])
def test_bad_bodies_give_their_cause(body, cause):
    assert decode(body, flood=12) == cause


def test_an_integer_value_is_a_number():
    assert decode({"k": 1, "v": 1}, flood=12) == L2(k=1, v=1.0)
