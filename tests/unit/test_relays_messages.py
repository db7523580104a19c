"""Swarm Relays' typed bodies: the bytes of the hand-written maps, a round trip, bad bodies by cause."""

from __future__ import annotations

import pytest

from protocols.relays.behavior import Relays
from protocols.relays.messages import BID, BODIES, CHAIN, JOIN, NEED, TASK, Bid, Chain, Join, Need, Task
from swarmactors import Frame
from transport.codec import pack


class Ctx:
    """The part of the robot's context the receiving side uses."""

    clock, dt = "lockstep", 0.2

    def __init__(self, rid: int = 1):
        self.id, self.tick, self.now = rid, 10, 10
        self.position = [0.0, 0.0]
        self.out: list = []

    def broadcast(self, kind, body, exclude=()):
        self.out.append((None, kind, body))

    def send(self, dst, kind, body):
        self.out.append((dst, kind, body))

    def set_status(self, **kw):
        pass

    def log(self, text):
        pass


CHAIN_MAP = {"r": "networker", "c": 0, "p": 1, "ch": 3, "d": 2, "up": [2, 1, 0], "dn": [2, 3], "ok": False, "n": 2}


@pytest.mark.parametrize(("typed", "plain"), [
    (Chain("networker", 0, 1, 3, 2, [2, 1, 0], [2, 3], False, 2), CHAIN_MAP),
    (Chain("free", None, None, None, None, [], [], False, 1),
     {"r": "free", "c": None, "p": None, "ch": None, "d": None, "up": [], "dn": [], "ok": False, "n": 1}),
    (Chain("root", None, None, None, 0, [0], [0], True, 1),
     {"r": "root", "c": None, "p": None, "ch": None, "d": 0, "up": [0], "dn": [0], "ok": True, "n": 1}),
    (Task("2:1", [1.25, -0.5], 15, 0, False), {"key": "2:1", "pos": [1.25, -0.5], "close": 15, "c": 0, "fly": False}),
    (Task("0:3", [0.0, 0.0, 0.7], 15, 1, True),
     {"key": "0:3", "pos": [0.0, 0.0, 0.7], "close": 15, "c": 1, "fly": True}),
    (Bid({"2:1": (0.5, 4), "0:3": (0.25, 7)}), {"bids": {"2:1": [0.5, 4], "0:3": [0.25, 7]}}),
    (Bid({}), {"bids": {}}),
    (Join(0, 1, 2, "2:1"), {"c": 0, "parent": 1, "child": 2, "key": "2:1"}),
    (Need(3), {"c": 3}),
])
def test_bytes_are_the_hand_written_maps_and_survive_a_round_trip(typed, plain):
    assert pack(BODIES.encode(typed)) == pack(plain)
    back = BODIES.decode(Frame(2, typed.KIND, plain, 1, 0))
    assert type(back) is type(typed) and pack(BODIES.encode(back)) == pack(plain)


def test_every_kind_is_typed_and_a_robot_takes_them_all():
    assert set(BODIES.kinds) == {CHAIN, TASK, BID, JOIN, NEED} and set(BODIES.kinds) <= set(Relays.kinds)


def robot(rid: int = 1) -> tuple[Relays, Ctx]:
    r, ctx = Relays([[8.0, 0.0]], root=0), Ctx(rid)
    r.on_start(ctx)
    return r, ctx


def test_a_free_robot_takes_a_slot_a_bid_and_a_call():
    r, ctx = robot(4)
    r.on_frame(ctx, Frame(2, TASK, {"key": "2:1", "pos": [1.25, -0.5], "close": 15, "c": 0, "fly": False}, 1, 0))
    assert r.slots["2:1"]["pos"] == [1.25, -0.5] and r.slots["2:1"]["chain"] == 0
    r.on_frame(ctx, Frame(5, BID, {"bids": {"2:1": [0.5, 5]}}, 1, 0))
    assert (r.slots["2:1"]["y"], r.slots["2:1"]["z"]) == (0.5, 5)
    r.on_frame(ctx, Frame(2, JOIN, {"c": 0, "parent": 1, "child": 2, "key": "2:1"}, 1, 0))
    assert (r.role, r.chain, r.parent, r.child) == ("networker", 0, 1, 2)
    assert r.heard[1][1].role is None and r.heard[2][1].role is None  # new links, not heard yet
    r.on_frame(ctx, Frame(2, CHAIN, CHAIN_MAP, 1, 0))
    assert r.heard[2][1] == Chain("networker", 0, 1, 3, 2, [2, 1, 0], [2, 3], False, 2)
    assert r.report()["malformed"] == {}


@pytest.mark.parametrize(("kind", "body", "cause"), [
    (CHAIN, [1, 2], "not_a_map"),
    (CHAIN, {"c": 0}, "missing_field"),
    (CHAIN, {**CHAIN_MAP, "r": "boss"}, "bad_field"),
    (CHAIN, {**CHAIN_MAP, "r": 3}, "bad_field"),
    (CHAIN, {**CHAIN_MAP, "up": ["a"]}, "bad_field"),
    (CHAIN, {**CHAIN_MAP, "n": -1}, "bad_field"),
    (CHAIN, {**CHAIN_MAP, "d": 1.5}, "bad_field"),
    (TASK, {"key": "2:1", "pos": [1.0], "close": 15, "c": 0}, "bad_field"),
    (TASK, {"key": "2:1", "pos": [1.0, float("nan")], "close": 15, "c": 0}, "bad_field"),
    (TASK, {"key": 2, "pos": [1.0, 0.0], "close": 15, "c": 0}, "bad_field"),
    (TASK, {"key": "2:1", "pos": [1.0, 0.0], "c": 0}, "missing_field"),
    (BID, {"bids": {"2:1": [0.5]}}, "bad_field"),
    (BID, {"bids": {"2:1": [0.5, "z"]}}, "bad_field"),
    (BID, {"bids": [["2:1", 0.5, 4]]}, "bad_field"),
    (BID, "bids", "not_a_map"),
    (JOIN, {"c": 0, "parent": 1, "child": "2", "key": "2:1"}, "bad_field"),
    (JOIN, {"c": 0, "parent": 1, "key": "2:1"}, "missing_field"),
    (NEED, {"c": None}, "bad_field"),
    (NEED, {}, "missing_field"),
])
def test_each_bad_body_is_counted_under_its_cause_and_changes_nothing(kind, body, cause):
    r, ctx = robot(4)
    r.on_frame(ctx, Frame(2, kind, body, 1, 0))
    rep = r.report()
    assert rep["malformed"] == {cause: 1} and rep["role"] == "free"
    assert r.heard == {} and r.slots == {} and ctx.out == []
