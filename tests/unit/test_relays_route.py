"""Swarm Relays, R5 without WP: where the head's request stops (``route``), and the recruiting records.

``route = "first"`` (the default, Sec. IV) keeps the request at the first robot counted from the head that has
free neighbours; ``route = "base"`` passes it on down to the base. The records (``asked``, ``recruits``) are read
by the Fig. 6 analysis only.
"""

from __future__ import annotations

import pytest
from test_relays_recruit import X, robot

from protocols.relays.behavior import NEED, Relays, keeps_request
from protocols.relays.messages import Need


@pytest.mark.parametrize(("route", "parent_is_root", "can_recruit", "keeps"), [
    ("first", True, False, True), ("first", False, True, True), ("first", False, False, False),
    ("base", True, False, True), ("base", True, True, True), ("base", False, True, False),
    ("base", False, False, False),
])
def test_keeps_request(route, parent_is_root, can_recruit, keeps):
    assert keeps_request(route, parent_is_root, can_recruit) is keeps


def test_route_base_a_robot_with_free_neighbours_passes_the_request_on_down():
    mid, ctx = robot(2, hears_free=True)
    mid.route = "base"
    mid._on_need(ctx, 3, Need(0))
    assert ctx.sent == [(1, NEED, {"c": 0})] and mid.asked == []
    mid._recruit(ctx)
    assert not mid.pending and not ctx.cast  # asked by nobody: it does not recruit


def test_route_base_a_head_with_free_neighbours_sends_its_request_down():
    head, ctx = robot(3, hears_free=True)
    head.route = "base"
    head._recruit(ctx)
    assert ctx.sent == [(2, NEED, {"c": 0})] and not head.pending


def test_route_base_the_base_keeps_the_request_and_recruits_in_front_of_itself_once_stretched():
    base, ctx = robot(1, hears_free=True)
    base.route, base.cnt = "base", 3  # three robots from the base to the head
    ctx.position = [0.9, 0.0]  # not stretched yet
    base._on_need(ctx, 2, Need(0))
    assert ctx.sent == [] and base.asked == [[ctx.tick, 1, 2, False]]
    base._recruit(ctx)
    assert not base.pending
    ctx.tick += 1
    ctx.position = list(X[1])
    base._recruit(ctx)
    assert base.pending[0]["parent"] == 0 and base.pending[0]["child"] == 1
    opened, depth, _up, stretched, asked, closed, winner, joined = base.recruits[-1]
    assert (opened, depth, stretched, asked, closed, winner, joined) == (ctx.tick, 1, True, ctx.tick - 1, None, None,
                                                                          None)


def test_the_recruit_record_holds_the_close_the_winner_and_the_join():
    mid, ctx = robot(2, hears_free=True)
    mid.cnt = 2
    mid._on_need(ctx, 3, Need(0))
    asked = ctx.tick
    mid._recruit(ctx)
    mid.pending[0]["z"], mid.pending[0]["y"] = 5, 0.5
    ctx.tick = mid.pending[0]["close"]
    mid._recruit(ctx)
    close = ctx.tick
    mid.heard[1] = (ctx.tick, mid.heard[1][1])
    mid.parent = 5  # the child (me) took the recruit as parent
    ctx.tick += 1
    mid._recruit(ctx)
    assert mid.recruits == [[asked, 2, 1, True, asked, close, 5, ctx.tick]]
    assert mid.report()["recruits"] is mid.recruits


def test_route_must_be_a_known_value():
    assert Relays.validate({"targets": [[8.0, 0.0]], "route": "base"}) is None
    assert "route = 'root'" in Relays.validate({"targets": [[8.0, 0.0]], "route": "root"})
