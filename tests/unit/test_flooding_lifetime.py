"""Flooding F1r (issue 23): the remaining lifetime instead of an absolute deadline, driven by hand, no world."""

from __future__ import annotations

from protocols.flooding.behavior import KIND, Flooding
from swarmactors import Frame


class Ctx:
    """The part of the robot's context flooding uses; ``now`` is this robot's own clock."""

    def __init__(self, rid: int, tick: int, now: float, clock: str = "lockstep", dt: float = 1.0):
        self.id, self.tick, self.now, self.clock, self.dt = rid, tick, now, clock, dt
        self.out: list = []

    def broadcast(self, kind, body, exclude=()):
        self.out.append((kind, body, tuple(exclude)))

    def set_status(self, **kw):
        pass


def test_validate():
    assert Flooding.validate({"expiry": 3, "lifetime": "absolute"})
    assert Flooding.validate({"expiry": 3, "lifetime": "remaining", "hop_cost": 0})
    assert Flooding.validate({"expiry": 3, "lifetime": "remaining", "hop_cost": 0.05}) is None


def test_origin_sends_the_whole_lifetime_and_each_hop_consumes_one_step():
    origin = Flooding(origin=0, at=1, expiry=2, lifetime="remaining")
    ctx = Ctx(0, 1, now=1000.25)  # a clock far from the world's: it does not matter
    origin.on_tick(ctx, None)
    (kind, body, _), = ctx.out
    assert kind == KIND and body["rl"] == 2 and "dl" not in body
    hop1 = Flooding(origin=0, at=1, expiry=2, lifetime="remaining")
    c1 = Ctx(1, 2, now=-7.5)
    hop1.on_frame(c1, Frame(0, KIND, body, 0, 1))
    (_, fwd, excl), = c1.out
    assert fwd["rl"] == 1 and fwd["h"] == 2 and excl == (0,) and hop1.received["0/0"]["hop"] == 1
    hop2 = Flooding(origin=0, at=1, expiry=2, lifetime="remaining")
    c2 = Ctx(2, 3, now=3.1)
    hop2.on_frame(c2, Frame(1, KIND, fwd, 0, 2))
    assert "0/0" in hop2.received and c2.out[0][1]["rl"] == 0  # arrives with nothing left: delivered, forwarded
    hop3 = Flooding(origin=0, at=1, expiry=2, lifetime="remaining")
    c3 = Ctx(3, 4, now=4.0)
    hop3.on_frame(c3, Frame(2, KIND, c2.out[0][1], 0, 3))
    assert hop3.received == {} and hop3.expired == 1 and c3.out == []  # F1r: 0 - 1 < 0


def test_the_deadline_rule_depends_on_the_receivers_clock_and_the_remaining_one_does_not():
    body = {"m": "0/0", "dl": 3.0, "h": 2, "p": None}  # sent at 1 with expiry 2, arriving at true time 3
    late_clock = Flooding(origin=0, at=1, expiry=2)
    late_clock.on_frame(Ctx(2, 3, now=3.1), Frame(1, KIND, body, 0, 2))
    assert late_clock.expired == 1  # F1: a clock 0.1 ahead of the origin's drops it
    skewed = Flooding(origin=0, at=1, expiry=2, lifetime="remaining")
    skewed.on_frame(Ctx(2, 3, now=3.1), Frame(1, KIND, {"m": "0/0", "rl": 1.0, "h": 2, "p": None}, 0, 2))
    assert skewed.expired == 0 and "0/0" in skewed.received


def test_hop_cost_defaults_to_one_tick_of_the_clock():
    f = Flooding(origin=0, expiry=0.1, lifetime="remaining")
    ctx = Ctx(1, 2, now=0.0, clock="realtime", dt=0.05)
    f.on_frame(ctx, Frame(0, KIND, {"m": "0/0", "rl": 0.1, "h": 1, "p": None}, 0, 0.0))
    assert ctx.out[0][1]["rl"] == 0.05
    g = Flooding(origin=0, expiry=3, lifetime="remaining", hop_cost=2)
    c = Ctx(1, 2, now=0.0)
    g.on_frame(c, Frame(0, KIND, {"m": "0/0", "rl": 3, "h": 1, "p": None}, 0, 0))
    assert c.out[0][1]["rl"] == 1
