"""CBAA's typed body: the bytes of the hand-written dicts, a round trip, undecodable bodies by cause."""

from __future__ import annotations

import pytest

from protocols.cbaa.behavior import CBAA
from protocols.cbaa.messages import BODIES, KIND, Bid
from swarmactors import Frame
from transport.codec import pack


class Ctx:
    def __init__(self, rid=1, tick=0, now=0, clock="lockstep"):
        self.id, self.tick, self.now, self.clock = rid, tick, now, clock
        self.position = [0.0, 0.0]
        self.out = []

    def broadcast(self, kind, body, exclude=()):
        self.out.append((kind, body))

    def set_status(self, **kw):
        pass


def robot(consensus="max", rid=1):
    c = CBAA(tasks=[[0.0, 1.0], [1.0, 1.0], [5.0, 0.0]], consensus=consensus)
    ctx = Ctx(rid=rid, clock="realtime" if consensus == "table" else "lockstep")
    c.on_start(ctx)
    return c, ctx


@pytest.mark.parametrize("consensus", ["max", "table"])
def test_the_sent_bid_is_the_hand_written_dict(consensus):
    c, ctx = robot(consensus)
    c.s = {0: 2.5, 3: 1}
    c.on_tick(ctx, [])
    (kind, body), = ctx.out
    plain = {"t": c.x, "y": c.y, "z": c.z}
    if consensus == "table":
        plain["s"] = [[k, v] for k, v in c.s.items()]
    assert kind == KIND and pack(body) == pack(plain)


@pytest.mark.parametrize("plain", [
    {"t": 0, "y": [1.0, 0.0, 0.0], "z": [3, None, None]},
    {"t": None, "y": [0.5, 2, 0.0], "z": [4, 0, None], "s": [[4, 2.5], [0, 1]]},
])
def test_round_trip_keeps_the_bytes(plain):
    back = BODIES.decode(Frame(3, KIND, plain, 1, 0))
    assert isinstance(back, Bid) and pack(BODIES.encode(back)) == pack(plain)


@pytest.mark.parametrize(("body", "cause"), [
    ([1, 2, 3], "not_a_map"),
    ({"t": None, "y": [0.0] * 3}, "missing_field"),
    ({"t": None, "y": [0.0] * 3, "z": "abc"}, "bad_field"),
    ({"t": 0, "y": [-1.0] * 3, "z": [3] * 3}, "bad_field"),
    ({"t": 0, "y": [float("nan"), 0.0, 0.0], "z": [3, None, None]}, "bad_field"),
    ({"t": 0, "y": [1.0, 0.0, 0.0], "z": [-3, None, None]}, "bad_field"),
    ({"t": -1, "y": [0.0] * 3, "z": [None] * 3}, "bad_field"),
    ({"t": None, "y": [0.0] * 3, "z": [None] * 3, "s": [[1]]}, "bad_field"),
    ({"t": None, "y": [0.0] * 4, "z": [None] * 4}, "wrong_length"),
    ({"t": 7, "y": [9.0] * 3, "z": [3] * 3}, "unknown_task"),
    ({"t": 0, "y": [1.0, 0.0, 0.0], "z": [2, None, None]}, "inconsistent"),  # t is not the sender's
    ({"t": None, "y": [1.0, 0.0, 0.0], "z": [None, None, None]}, "inconsistent"),  # a bid without a winner
])
def test_each_bad_body_is_dropped_under_its_cause(body, cause):
    c, ctx = robot()
    c.on_frame(ctx, Frame(3, KIND, body, 1, 0))
    assert c.received == 0 and c.report()["dropped"] == {cause: 1}
