"""Biconnectivity R15: a verdict only after ``agree`` agreeing periods (issue 23), driven by hand, no world."""

from __future__ import annotations

import numpy as np

from protocols.biconnectivity.behavior import CHECK_REQUEST, DC_TRUE, Biconnectivity
from swarmactors import Frame


class Ctx:
    """The part of the robot's context the check uses (lockstep: now = tick)."""

    clock, dt, range = "lockstep", 1.0, 1.0

    def __init__(self, rid: int):
        self.id, self.tick, self.now = rid, 0, 0.0
        self.position = [0.0, 0.0]
        self.rng = np.random.default_rng(0)
        self.out: list = []

    def broadcast(self, kind, body, exclude=()):
        self.out.append((kind, body))

    def send(self, dst, kind, body):
        self.out.append((kind, body))

    def set_status(self, **kw):
        pass

    def log(self, text):
        pass

    def at(self, tick: int) -> None:
        self.tick, self.now = tick, float(tick)

    def sent(self, kind: str) -> list:
        return [b for k, b in self.out if k == kind]


def robot(rid: int = 0, **params) -> tuple[Biconnectivity, Ctx]:
    b, ctx = Biconnectivity(N=4, c=1, hello=0, **params), Ctx(rid)
    b.on_start(ctx)
    return b, ctx


def test_validate():
    assert Biconnectivity.validate({"agree": 0})
    assert Biconnectivity.validate({"agree": 3, "max_periods": 2})
    assert Biconnectivity.validate({"agree": 2, "max_periods": 4}) is None


def test_paper_mode_decides_on_the_first_period():
    b, ctx = robot()
    ctx.at(1)
    b._initiate(ctx)
    b._decide(ctx, False, "not doubly connected to all")
    assert b.biconnected is False and b.check["done"] and "rounds" not in b.check
    assert b.report()["bounds"]["check"] == 6 * 4 + 2


def test_two_agreeing_periods_make_the_verdict_and_each_new_period_is_asked_for():
    b, ctx = robot(agree=2)
    ctx.at(1)
    b._initiate(ctx)
    assert ctx.sent(CHECK_REQUEST) == [[1, 1.0, 0]]
    ctx.at(20)
    b._decide(ctx, False, "not doubly connected to all")  # a lost frame, say
    assert b.biconnected is None and not b.check["done"]
    assert b.period == 20 and b.check["period"] == 20 and not b.check["evaluated"]
    assert ctx.sent(CHECK_REQUEST)[-1] == [20, 1.0, 0, 2]  # the same check (initiator, request time), period 2
    ctx.at(40)
    b._decide(ctx, True, "this robot and a neighbour are doubly connected to all")  # disagrees: a third period
    assert b.biconnected is None and b.period == 40
    ctx.at(60)
    b._decide(ctx, True, "this robot and a neighbour are doubly connected to all")
    ck = b.check
    assert b.biconnected is True and ck["done"] and ck["verdict"] is True
    assert [r[:2] for r in ck["rounds"]] == [[1, False], [20, True], [40, True]]
    assert ck["decided"] - ck["requested"] == 59


def test_no_agreement_within_max_periods_gives_null_and_timeouts_never_agree():
    b, ctx = robot(agree=2, max_periods=3)
    ctx.at(1)
    b._initiate(ctx)
    for t, v in ((20, None), (40, None), (60, True)):
        ctx.at(t)
        b._decide(ctx, v, "timeout" if v is None else "x")
    assert b.check["done"] and b.check["verdict"] is None and b.reason == "no agreement"
    assert b.report()["bounds"]["check"] == 3 * (6 * 4 + 2)


def test_budget_ends_the_check_at_once():
    b, ctx = robot(agree=2)
    ctx.at(1)
    b._initiate(ctx)
    b._decide(ctx, None, "budget")
    assert b.check["done"] and b.reason == "budget" and len(b.check["rounds"]) == 1


def test_a_further_periods_request_only_joins_a_robot_outside_the_check_and_a_decided_one_answers():
    outsider, ctx = robot(rid=5, agree=2)
    ctx.at(21)
    outsider.on_frame(ctx, Frame(1, CHECK_REQUEST, [20, 1.0, 0, 2], 0, 20))
    assert outsider.period == 20 and outsider.check is None  # joined the fill (R4), runs no check
    member, ctx = robot(rid=1, agree=2)
    ctx.at(2)
    member.on_frame(ctx, Frame(0, CHECK_REQUEST, [1, 1.0, 0], 0, 1))
    for t in (20, 40):
        ctx.at(t)
        member._decide(ctx, True, "x")
    assert member.biconnected is True
    ctx.at(41)
    member.on_frame(ctx, Frame(0, CHECK_REQUEST, [40, 1.0, 0, 3], 0, 40))  # the initiator needs a third period
    assert member.period == 40 and member.answer_only == 40
    ctx.out.clear()
    ctx.at(41 + 12)  # 3Nc after it joined period 40 (at tick 41)
    member.on_tick(ctx, None)
    assert ctx.sent(DC_TRUE) == [[40]] and member.biconnected is True and len(member.checks) == 1
