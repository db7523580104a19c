"""Beacon's typed body: the bytes of the hand-written list, a round trip, undecodable bodies by cause."""

from __future__ import annotations

import pytest

from protocols.beacon.behavior import Beacon
from protocols.beacon.messages import BODIES, KIND, BeaconBody
from swarmactors import Frame
from transport.codec import pack


class Ctx:
    def __init__(self, tick=4, now=4):
        self.id, self.tick, self.now = 1, tick, now
        self.out = []

    def broadcast(self, kind, body, exclude=()):
        self.out.append((kind, body))


@pytest.mark.parametrize("now", [3, 2.75])
def test_bytes_are_the_hand_written_list_and_survive_a_round_trip(now):
    b = Beacon(size=4)
    ctx = Ctx(now=now)
    b.on_tick(ctx, [])
    (kind, body), = ctx.out
    assert kind == KIND and pack(body) == pack([now, b"\x00" * 4])
    back = BODIES.decode(Frame(0, KIND, [now, b"\x00" * 4], 1, 0))
    assert back == BeaconBody(now, b"\x00" * 4) and type(back.sent) is type(now)


@pytest.mark.parametrize(("body", "cause"), [
    ({"t": 1}, "not_an_array"),
    (None, "not_an_array"),
    ([1], "bad_length"),
    (["1", b""], "bad_field"),
    ([1, "pad"], "bad_field"),
])
def test_each_undecodable_body_is_counted_under_its_cause_and_heard_not(body, cause):
    b = Beacon()
    b.on_frame(Ctx(), Frame(0, KIND, body, 1, 0))
    rep = b.report()
    assert rep["heard"] == 0 and rep["malformed"] == {cause: 1}
    assert "malformed" not in Beacon().report()
