"""Biconnectivity's typed bodies: the bytes of the hand-written lists, a round trip, bad bodies by cause."""

from __future__ import annotations

import numpy as np
import pytest

from protocols.biconnectivity.behavior import Biconnectivity
from protocols.biconnectivity.messages import (
    BODIES,
    BUDGET,
    CHECK_REQUEST,
    CR,
    DC_TRUE,
    DCR,
    HELLO,
    LEAVE,
    MOVE,
    POS_REPLY,
    POS_REQUEST,
    VERDICT,
    Budget,
    Cr,
    DcFalse,
    Dcr,
    DcTrue,
    Hello,
    Leave,
    Move,
    PosReply,
    PosRequest,
    Request,
    Row,
    Verdict,
)
from swarmactors import Frame
from transport.codec import pack


class Ctx:
    """The part of the robot's context the behaviour uses (lockstep: now = tick)."""

    clock, dt, range = "lockstep", 1.0, 1.0

    def __init__(self, rid: int = 1):
        self.id, self.tick, self.now = rid, 0, 0.0
        self.position = [0.0, 0.0]
        self.rng = np.random.default_rng(0)
        self.out: list = []

    def broadcast(self, kind, body, exclude=()):
        self.out.append((None, kind, body))

    def send(self, dst, kind, body):
        self.out.append((dst, kind, body))

    def set_status(self, **kw):
        pass

    def log(self, text):
        pass


ROWS = [[0, 0.5, -1.25, 7, [1, 2]], [3, 1.0, 2.0, 6, []]]


@pytest.mark.parametrize(("typed", "plain"), [
    (Cr(4, [2]), [4, [2]]),
    (Dcr(4, [0, 3, 2]), [4, [0, 3, 2]]),
    (Request(4, 4.0, 2), [4, 4.0, 2]),
    (Request(4, 3, 2), [4, 3, 2]),
    (Request(20, 1.0, 0, 2), [20, 1.0, 0, 2]),
    (DcTrue(4), [4]),
    (DcFalse(4), [4]),
    (Budget(4), [4]),
    (Verdict(4, 2, True, "this robot and a neighbour are doubly connected to all"),
     [4, 2, True, "this robot and a neighbour are doubly connected to all"]),
    (Hello([Row(*r) for r in ROWS]), ROWS),
    (Hello([]), []),
    (PosReply([Row(*ROWS[0])]), ROWS[:1]),
    (Leave(3), [3]),
    (PosRequest(5), [5]),
    (Move(1, 2, 3, [0.5, 1.5], 0.125, 40, 0.05), [1, 2, 3, [0.5, 1.5], 0.125, 40, 0.05]),
    (Move(1, 1, 3, [0.5, 1.5], 1, 40, 0.05), [1, 1, 3, [0.5, 1.5], 1, 40, 0.05]),  # an integer d stays one
])
def test_bytes_are_the_hand_written_lists_and_survive_a_round_trip(typed, plain):
    assert pack(BODIES.encode(typed)) == pack(plain)
    back = BODIES.decode(Frame(2, typed.KIND, plain, 1, 0))
    assert type(back) is type(typed) and pack(BODIES.encode(back)) == pack(plain)


def test_every_kind_is_typed():
    assert set(BODIES.kinds) == {CR, DCR, CHECK_REQUEST, DC_TRUE, "DC-FALSE", BUDGET, VERDICT, HELLO, LEAVE,
                                 POS_REQUEST, POS_REPLY, MOVE}
    assert Biconnectivity.kinds == BODIES.kinds


def test_a_robot_sends_the_hand_written_lists():
    b, ctx = Biconnectivity(N=4, c=1, hello=1, flood_verdict=True), Ctx(1)
    b.on_start(ctx)
    ctx.tick, ctx.now = 3, 3.0
    b._initiate(ctx)
    b.on_tick(ctx, None)
    assert [(k, pack(v)) for _, k, v in ctx.out] == [
        (CR, pack([3, [1]])), (DCR, pack([3, [1]])), (CHECK_REQUEST, pack([3, 3.0, 1])),
        (HELLO, pack([[1, 0.0, 0.0, 3, []]]))]
    ctx.out.clear()
    b.on_frame(ctx, Frame(2, CR, [3, [0, 2]], 1, 3))
    b.on_frame(ctx, Frame(2, POS_REQUEST, [2], 1, 3))
    assert [(d, k, pack(v)) for d, k, v in ctx.out] == [
        (None, CR, pack([3, [0, 2, 1]])), (2, POS_REPLY, pack([[1, 0.0, 0.0, 3, []]]))]


def test_a_table_and_a_move_are_taken_and_the_move_forwarded_once():
    b, ctx = Biconnectivity(N=4, c=1, hello=1), Ctx(1)
    b.on_start(ctx)
    b.on_frame(ctx, Frame(2, HELLO, ROWS, 1, 0))
    assert b.table[0] == [0.5, -1.25, 7, [1, 2]] and b.table[3] == [1.0, 2.0, 6, []] and b.heard == {2: 0}
    move = [0, 1, 3, [1.0, 2.0], 0.25, 5, 0.05]
    b.on_frame(ctx, Frame(2, MOVE, move, 1, 0))
    b.on_frame(ctx, Frame(2, MOVE, move, 1, 0))
    assert [(k, pack(v)) for _, k, v in ctx.out] == [(MOVE, pack(move))]
    assert 3 in b.removed and 3 not in b.table and b.move_queue[0]["d"] == 0.25


@pytest.mark.parametrize(("kind", "body", "cause"), [
    (CR, "garbage", "not_an_array"),
    (CR, [1, ["x", 2]], "bad_field"),
    (CR, [-1, [2]], "bad_field"),
    (CR, [1, []], "bad_field"),
    (CR, [1], "bad_length"),
    (CR, [1, [2], 3], "bad_length"),
    (DCR, [1, [0, 0, 2]], "repeated_stamp"),
    (DCR, [1, [0, 3, 4, 5, 2]], "more_than_n_stamps"),
    (DCR, [1, [0, 3]], "last_stamp_not_sender"),
    (CHECK_REQUEST, [1, 1.0], "bad_length"),
    (CHECK_REQUEST, [1, 1.0, 0, 2, 5], "bad_length"),
    (CHECK_REQUEST, [1, "now", 0], "bad_field"),
    (CHECK_REQUEST, [True, 1.0, 0], "bad_field"),
    (CHECK_REQUEST, [1, 1.0, 0, 1.5], "bad_field"),
    (DC_TRUE, [True], "bad_field"),
    (DC_TRUE, {"p": 1}, "not_an_array"),
    (BUDGET, [-1], "bad_field"),
    (VERDICT, [1, 0, "yes", "x"], "bad_field"),
    (VERDICT, [1, 0, True], "bad_length"),
    (HELLO, {"rows": []}, "not_an_array"),
    (HELLO, [[0, 0.5, 1.0, 7]], "bad_field"),
    (HELLO, [[0, 0.5, "y", 7, []]], "bad_field"),
    (POS_REPLY, [[0, 0.5, 1.0, 7, ["a"]]], "bad_field"),
    (LEAVE, [], "bad_length"),
    (POS_REQUEST, "me", "not_an_array"),
    (MOVE, [0, 1, 3, [1.0], 0.25, 5, 0.05], "bad_field"),
    (MOVE, [0, 1, 3, [1.0, 2.0], -0.25, 5, 0.05], "bad_field"),
    (MOVE, [0, 1, 3, [1.0, 2.0], 0.25, 5, 0.0], "bad_field"),
    ("OTHER", [1], "unknown_kind"),
])
def test_each_bad_body_is_counted_under_its_cause_and_changes_nothing(kind, body, cause):
    b, ctx = Biconnectivity(N=4, c=1, hello=1), Ctx(1)
    b.on_start(ctx)
    b.on_frame(ctx, Frame(2, kind, body, 1, 0))
    rep = b.report()
    assert rep["malformed_reasons"] == {cause: 1} and rep["malformed"] == 1
    assert ctx.out == [] and b.period == -1 and b.table == {} and b.heard == {} and not b.removed
