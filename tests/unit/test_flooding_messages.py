"""Flooding's typed bodies: the bytes of the hand-written dicts, a round trip, undecodable bodies by cause."""

from __future__ import annotations

import pytest

from protocols.flooding.behavior import Flooding
from protocols.flooding.messages import BODIES, KIND, Flood
from swarmactors import Frame
from swarmactors.robot.bodies import UNSET
from transport.codec import pack


class Ctx:
    def __init__(self, rid=1, tick=3, now=3, clock="lockstep"):
        self.id, self.tick, self.now, self.clock, self.dt = rid, tick, now, clock, 1.0
        self.out = []

    def broadcast(self, kind, body, exclude=()):
        self.out.append((kind, body, tuple(exclude)))

    def set_status(self, **kw):
        pass


@pytest.mark.parametrize(("typed", "plain"), [
    (Flood(msg="0/0", deadline=12, hop=1, payload=None), {"m": "0/0", "dl": 12, "h": 1, "p": None}),
    (Flood(msg="0/0", deadline=12.5, hop=3, payload="hi"), {"m": "0/0", "dl": 12.5, "h": 3, "p": "hi"}),
    (Flood(msg="4/0", deadline=None, hop=2, payload=[1, 2]), {"m": "4/0", "dl": None, "h": 2, "p": [1, 2]}),
    (Flood(msg="0/0", remaining=2.0, hop=1, payload=None), {"m": "0/0", "rl": 2.0, "h": 1, "p": None}),
])
def test_bytes_are_the_hand_written_dicts_and_survive_a_round_trip(typed, plain):
    assert pack(BODIES.encode(typed)) == pack(plain)
    back = BODIES.decode(Frame(0, KIND, plain, 1, 0))
    assert back == typed and pack(BODIES.encode(back)) == pack(plain)


def test_a_forwarded_copy_keeps_the_bytes_it_had():
    """F1: the deadline travels unchanged (an integer stays one), the hop count grows by one."""
    f = Flooding(origin=0, expiry=9)
    ctx = Ctx()
    f.on_frame(ctx, Frame(0, KIND, {"m": "0/0", "dl": 9, "h": 1, "p": None}, 1, 0))
    (kind, body, excl), = ctx.out
    assert kind == KIND and excl == (0,) and pack(body) == pack({"m": "0/0", "dl": 9, "h": 2, "p": None})


@pytest.mark.parametrize(("body", "cause"), [
    ([1, 2], "not_a_map"),
    ("FLOOD", "not_a_map"),
    ({"dl": 9, "h": 1}, "missing_field"),
    ({"m": "0/0", "dl": 9}, "missing_field"),
    ({"m": "0/0", "rl": 9, "h": 1}, "missing_field"),  # a copy of the other lifetime's rule
    ({"m": "0/0", "dl": "soon", "h": 1}, "bad_field"),
    ({"m": "0/0", "dl": 9, "h": 1.5}, "bad_field"),
    ({"m": 7, "dl": 9, "h": 1}, "bad_field"),
])
def test_each_undecodable_body_is_counted_under_its_cause_and_changes_nothing(body, cause):
    f = Flooding(origin=0, expiry=9)
    ctx = Ctx()
    f.on_frame(ctx, Frame(0, KIND, body, 1, 0))
    assert ctx.out == [] and f.received == {} and f.report()["malformed"] == {cause: 1}
    assert BODIES.decode(Frame(0, KIND, {"m": "0/0", "dl": 9, "h": 1}, 1, 0)).remaining is UNSET
