"""SECS's typed bodies: the bytes of the hand-written dicts of every role, a round trip, bad bodies by cause."""

from __future__ import annotations

import math

import pytest

from protocols.secs.behavior import SECS
from protocols.secs.messages import BODIES, M_KIND, T_KIND, Bearings, Target
from swarmactors import Frame
from transport.codec import pack

PLAIN_T = [
    # the master: a, T, al, d, p, [rv], [fl], v
    {"a": -1, "T": [0.5, 3.0], "al": True, "d": 0.0, "p": [0.25, 0.75], "v": [0.0, 0.0]},
    {"a": -1, "T": [0.5], "al": True, "d": 0.0, "p": [1.0], "rv": 0.4, "v": [0.0, 0.0]},
    {"a": -1, "T": [0.5], "al": True, "d": 0.0, "p": [1.0], "fl": 1, "v": [0.1, -0.2]},
    # the scheduled master: a, T, al, d, ph, fl | p | rv, v
    {"a": -1, "T": [], "al": True, "d": 0.0, "ph": 0, "fl": 1, "v": [0.3, 0.0]},
    {"a": -1, "T": [1.0, 2.0], "al": True, "d": 0.0, "ph": 1, "p": [0.5, 0.5], "v": [0.0, 0.0]},
    {"a": -1, "T": [], "al": True, "d": 0.0, "ph": 2, "rv": 0.3, "v": [0.0, 0.0]},
    # a backbone robot: a, T, al, d, [ph], [p], [rv | fl], v
    {"a": 0, "T": None, "al": False, "d": None, "v": [0.0, 0.0]},
    {"a": 1, "T": 4.25, "al": True, "d": 1.5, "ph": 1, "p": [0.5, 0.5], "v": [0.01, 0.02]},
    {"a": 1, "T": None, "al": False, "d": 2.0, "p": [0.5, 0.5], "rv": 0.3, "v": [0.0, 0.0]},
    {"a": 1, "T": None, "al": False, "d": 2, "ph": 0, "fl": 1, "v": [0.0, 0.0]},
]


@pytest.mark.parametrize("plain", PLAIN_T)
def test_target_bytes_are_the_hand_written_dicts_and_survive_a_round_trip(plain):
    typed = Target.of(plain)
    assert pack(BODIES.encode(typed)) == pack(plain)
    back = BODIES.decode(Frame(2, T_KIND, plain, 1, 0))
    assert back == Target.of(dict(plain, v=tuple(plain["v"]))) and pack(BODIES.encode(back)) == pack(plain)


def test_bearings_bytes_and_round_trip():
    plain = {"M": [[1, 0.5], [4, 6.0]]}
    assert pack(BODIES.encode(Bearings(seen=[[1, 0.5], [4, 6.0]]))) == pack(plain)
    assert pack(BODIES.encode(BODIES.decode(Frame(2, M_KIND, plain, 1, 0)))) == pack(plain)


class Ctx:
    id = 7
    clock = "lockstep"
    dt = 0.1
    pose = [0.0, 0.0, 0.0]


@pytest.mark.parametrize(("kind", "body", "cause"), [
    (T_KIND, [0, 1.0], "not_a_map"),
    (T_KIND, {"T": 1.0, "d": 1.0}, "missing_field"),
    (T_KIND, {"a": "0", "T": 1.0}, "bad_field"),
    (T_KIND, {"a": 0, "T": 1.0, "d": -1.0}, "bad_field"),
    (T_KIND, {"a": 0, "T": 1.0, "d": math.inf}, "bad_field"),
    (T_KIND, {"a": 0, "T": 1.0, "p": [1.5]}, "bad_field"),
    (T_KIND, {"a": 0, "T": 1.0, "rv": 0}, "bad_field"),
    (T_KIND, {"a": 0, "T": 1.0, "ph": -1}, "bad_field"),
    (T_KIND, {"a": 0, "T": 1.0, "v": [0.0]}, "bad_field"),
    (T_KIND, {"a": 0, "T": 1.0, "v": [0.0, math.nan]}, "bad_field"),
    (T_KIND, {"a": 0, "T": 7.0}, "angle"),
    (T_KIND, {"a": -1, "T": 1.0}, "bad_field"),  # the master's ∠T is a list
    (T_KIND, {"a": -1, "T": [1.0, -1.0]}, "angle"),
    (M_KIND, None, "not_a_map"),
    (M_KIND, {"M": [[7]]}, "bad_field"),
    (M_KIND, {"M": [[7, 6.5]]}, "angle"),
])
def test_each_bad_body_is_refused_under_its_cause(kind, body, cause):
    b = SECS()
    b.on_frame(Ctx(), Frame(2, kind, body, 1, 3, rab=(1.0, 0.2)))
    assert b.refused == {cause: 1} and b.info == {} and b.seen_by == {}
