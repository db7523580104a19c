"""Virtual stigmergy's typed bodies: the bytes of the hand-written lists, a round trip, bad bodies by cause."""

from __future__ import annotations

import pytest

from protocols.stigmergy.messages import BODIES, DIGEST, PUT, QUERY, Digest, Put, Query
from protocols.stigmergy.table import Stigmergy
from swarmactors import Frame
from transport.codec import pack


class Ctx:
    def __init__(self, rid=1):
        self.id, self.tick, self.now, self.clock = rid, 0, 0, "lockstep"
        self.out = []

    def broadcast(self, kind, body, exclude=()):
        self.out.append((None, kind, body))

    def send(self, dst, kind, body):
        self.out.append((dst, kind, body))


@pytest.mark.parametrize(("typed", "plain"), [
    (Put(0, "k", {"a": [1, 2.5]}, 3, 4), [0, "k", {"a": [1, 2.5]}, 3, 4]),
    (Put("relay", 7, None, 2, 0), ["relay", 7, None, 2, 0]),
    (Query(0, "k", None, 0, 4, 9), [0, "k", None, 0, 4, 9]),
    (Query(0, "k", b"\x01", 5, 4, 0), [0, "k", b"\x01", 5, 4, 0]),
    (Digest(0, [["a", 1, 2], [3, 4, 5]]), [0, [["a", 1, 2], [3, 4, 5]]]),
])
def test_bytes_are_the_hand_written_lists_and_survive_a_round_trip(typed, plain):
    assert pack(BODIES.encode(typed)) == pack(plain)
    back = BODIES.decode(Frame(2, typed.KIND, plain, 1, 0))
    assert pack(BODIES.encode(back)) == pack(plain) and type(back) is type(typed)


def test_a_flush_sends_the_hand_written_lists():
    node, ctx = Stigmergy(anti_entropy=1), Ctx()
    node.attach(ctx)
    t = node.create("s")
    t.put("a", 1.5)
    t.get("b")
    node.flush(ctx)
    assert [pack(b) for _, _, b in ctx.out] == [pack(["s", [["a", 1, 1]]]), pack(["s", "a", 1.5, 1, 1]),
                                                pack(["s", "b", None, 0, 1, 1])]


@pytest.mark.parametrize(("kind", "body", "cause"), [
    (PUT, {"sid": 0}, "not_an_array"),
    (PUT, [0, "k", 1], "bad_length"),
    (PUT, [0, "k", 1, -1, 3], "timestamp"),
    (PUT, [0, "k", 1, 0, 3], "timestamp"),
    (PUT, [0, "k", 1, 1.5, 3], "bad_field"),
    (PUT, [0, "k", 1, True, 3], "bad_field"),
    (PUT, [0, ["k"], 1, 2, 3], "bad_field"),
    (PUT, [1.5, "k", 1, 2, 3], "bad_field"),
    (PUT, [0, "k", 1, 2, -4], "bad_field"),
    (QUERY, [0, "k", 5, 0, 3, 0], "timestamp"),
    (QUERY, [0, "k", None, 0, 3, -1], "bad_field"),
    (QUERY, [0, "k", None, 0, 3], "bad_length"),
    (DIGEST, [0, [["k", -1, 2]]], "bad_field"),
    (DIGEST, [0, [["k", 1]]], "bad_field"),
    (DIGEST, [0, "k"], "bad_field"),
    ("VS_OTHER", [0], "unknown_kind"),
])
def test_each_bad_body_is_counted_under_its_cause_and_changes_nothing(kind, body, cause):
    node, ctx = Stigmergy(), Ctx()
    node.attach(ctx)
    t = node.create(0)
    if kind != "VS_OTHER":
        assert node.on_frame(ctx, Frame(2, kind, body, 1, 0))
    else:
        assert BODIES.decode(Frame(2, kind, body, 1, 0), node.malformed) is None
    node.flush(ctx)
    assert node.counters()["malformed"] == {cause: 1} and t.entries == {} and ctx.out == []
