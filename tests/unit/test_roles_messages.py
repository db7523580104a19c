"""Role switching's typed bodies: the bytes of the hand-written dicts, a round trip, bad bodies by cause."""

from __future__ import annotations

import msgspec
import pytest

from protocols.roles import messages as msg
from protocols.roles.behavior import RoleSwitching
from protocols.roles.messages import BODIES
from protocols.roles.rules import EX, LL, RP
from swarmactors import Frame
from transport.codec import pack

# each typed body beside the dict the behaviour wrote by hand before it had types
CASES = [
    (msg.State(RP, [1.0, 2.5], [0.0, 0.1], [0.2, 0.0], 2, 3, 0),
     {"r": RP, "p": [1.0, 2.5], "v": [0.0, 0.1], "u": [0.2, 0.0], "n": 2, "e": 3, "pa": 0}),
    (msg.State(EX, [1.0, 2.5], [0.0, 0.1], [0.2, 0.0], 1, 0, None),
     {"r": EX, "p": [1.0, 2.5], "v": [0.0, 0.1], "u": [0.2, 0.0], "n": 1, "e": 0, "pa": None}),
    (msg.LeaderInfo(4, 7, 12, 1, 3, [1.0, 2.0], [0.1, 0.0]),
     {"o": 4, "s": 7, "dl": 12, "h": 1, "e": 3, "x": [1.0, 2.0], "u": [0.1, 0.0]}),
    (msg.Connect(EX), {"r": EX}),
    (msg.Disconnect(RP, "role"), {"r": RP, "why": "role"}),
    (msg.Request(role=LL, epoch=5, at=40, kind="extend", goal=[1.0, 2.0], goal_k=3),
     {"role": LL, "e": 5, "T": 40, "kind": "extend", "goal": [1.0, 2.0], "gk": 3}),
    (msg.Request(role=LL, epoch=5, at=40, kind="retract", goal=None, goal_k=-1),
     {"role": LL, "e": 5, "T": 40, "kind": "retract", "goal": None, "gk": -1}),
    (msg.Ack(5), {"e": 5}),
    (msg.Nack(5, "stale"), {"e": 5, "why": "stale"}),
    (msg.Target(2, [3.5, 1.0]), {"k": 2, "x": [3.5, 1.0]}),
    (msg.Arrived(2), {"k": 2}),
    (msg.Help(), {}),
    (msg.Where(RP, 6, LL, [0.5, 0.5]), {"r": RP, "c": 6, "cr": LL, "cx": [0.5, 0.5]}),
]


@pytest.mark.parametrize(("typed", "plain"), CASES, ids=[type(t).__name__ for t, _ in CASES])
def test_bytes_are_the_hand_written_dicts_and_survive_a_round_trip(typed, plain):
    assert pack(BODIES.encode(typed)) == pack(plain)
    back = BODIES.decode(Frame(2, typed.KIND, plain, 1, 0))
    assert type(back) is type(typed) and pack(BODIES.encode(back)) == pack(plain)


def test_a_forwarded_flood_copy_keeps_its_bytes_but_the_hop_count():
    plain = {"o": 4, "s": 7, "dl": 12, "h": 1, "e": 3, "x": [1, 2.0], "u": [0.1, 0]}
    fwd = msgspec.structs.replace(BODIES.decode(Frame(4, msg.LL_INFO, plain, 1, 0)), hop=2)
    assert pack(BODIES.encode(fwd)) == pack({**plain, "h": 2})


class Ctx:
    id, tick, now, clock, range, sensing = 1, 3, 3, "lockstep", 2.0, 2.0

    def __init__(self):
        self.out = []

    def send(self, dst, kind, body):
        self.out.append((dst, kind, body))

    def broadcast(self, kind, body, exclude=()):
        self.out.append((None, kind, body))


def robot():
    r = RoleSwitching(base=0, leader=5)
    r.on_start(Ctx())
    return r


@pytest.mark.parametrize(("kind", "body", "cause"), [
    (msg.STATE, [1, 2], "not_a_map"),
    (msg.STATE, {"r": "king", "p": [0, 0], "v": [0, 0], "u": [0, 0], "n": 1, "e": 0}, "bad_field"),
    (msg.STATE, {"r": EX, "p": [0, float("nan")], "v": [0, 0], "u": [0, 0], "n": 1, "e": 0}, "bad_field"),
    (msg.STATE, {"r": EX, "p": [0, 0], "v": [0, 0], "u": [0, 0], "n": True, "e": 0}, "bad_field"),
    (msg.LL_INFO, {"o": 4, "s": 7, "dl": 12, "h": 1, "e": 3, "x": [1.0, 2.0]}, "missing_field"),
    (msg.CONNECT, {"r": 3}, "bad_field"),
    (msg.TARGET, {"k": 1, "x": [1.0]}, "bad_field"),
    (msg.WHERE, {"r": RP, "c": 6, "cr": "nobody", "cx": [0.5, 0.5]}, "bad_field"),
    (msg.HELP, "help", "not_a_map"),
    ("RS_OTHER", {}, "unknown_kind"),
])
def test_each_bad_body_is_counted_in_malformed_under_its_cause(kind, body, cause):
    r, ctx = robot(), Ctx()
    r.on_frame(ctx, Frame(2, kind, body, 1, 0))
    rep = r.report()
    assert rep["malformed"] == {cause: 1} and rep["refused"] == {} and ctx.out == [] and r.nbr == {}


def test_a_request_that_does_not_decode_is_refused_unanswered():
    r, ctx = robot(), Ctx()
    r.on_frame(ctx, Frame(2, msg.REQUEST, [1, 2, 3], 1, 0))
    r.on_frame(ctx, Frame(2, msg.REQUEST, {"role": LL, "e": 9, "T": 4, "kind": "swap"}, 1, 0))
    assert r.report()["refused"] == {"not_a_map": 1, "bad_field": 1} and ctx.out == []
