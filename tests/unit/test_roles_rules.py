"""RoleSwitching's rules below Zenoh: the parameters, the motion laws (Eqs. 1-7) and Algorithm 1's request.

Each test states the rule in the paper's terms (Kobayashi, Higuchi & Ueno 2022) and checks the pure function
that ``protocols.roles.behavior.RoleSwitching`` calls.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from protocols.roles.behavior import RoleSwitching
from protocols.roles.messages import BODIES, REQUEST
from protocols.roles.params import RoleParams
from protocols.roles.rules import (
    BS,
    EX,
    EXTEND,
    LL,
    NACK_BACKOFF,
    RETRACT,
    RP,
    Answer,
    Candidate,
    answer_request,
    cap,
    explorer_input,
    head_to,
    hold,
    leader_input,
    repeater_input,
    role_change_request,
)

P = RoleParams(leader=1)
D_C = 1.5
xy = st.floats(-5, 5, allow_nan=False)
vec = st.tuples(xy, xy).map(np.array)


# ---------------------------------------------------------------- parameters
def test_defaults_are_the_documented_values():
    assert (P.eta_a, P.eta_b, P.eta_c, P.vmax, P.d_n) == (0.8, 0.15, 3, 0.03, 0.6)
    assert (P.k1, P.k2, P.k3, P.k4, P.k5, P.k6, P.k7, P.k8) == (0.05, 0.1, 0.02, 0.1, 0.5, 0.05, 0.5, 0.02)


@pytest.mark.parametrize("params,message", [
    ({}, "leader is required"),
    ({"leader": 1, "speed": 2}, "unknown parameter 'speed'"),
    ({"leader": -1}, "leader = -1 must be a robot id"),
    ({"leader": True}, "leader = True must be a robot id"),
    ({"leader": 0}, "base station cannot be the initial local leader"),
    ({"leader": 3, "base": 3}, "base station cannot be"),
    ({"leader": 1, "eta_a": 1.0}, "eta_a = 1.0 must be a number in (0, 1)"),
    ({"leader": 1, "eta_b": 0.0}, "eta_b = 0.0 must be a number in (0, 1)"),
    ({"leader": 1, "eta_a": 0.3, "eta_b": 0.4}, "eta_b = 0.4 must be smaller than eta_a = 0.3"),
    ({"leader": 1, "eta_b": 0.9}, "eta_b = 0.9 must be smaller than eta_a = 0.8"),
    ({"leader": 1, "k6": -0.1}, "k6 = -0.1 must be a non-negative number"),
    ({"leader": 1, "vmax": 0}, "vmax = 0 must be a positive number"),
    ({"leader": 1, "vmax": float("nan")}, "vmax = nan must be a positive number"),
    ({"leader": 1, "lease": 0}, "lease = 0 must be a positive integer"),
    ({"leader": 1, "expiry": 2.5}, "expiry = 2.5 must be a positive integer"),
    ({"leader": 1, "aat": "sometimes"}, "aat = 'sometimes' must be one of"),
    ({"leader": 1, "targets": [[1, 2], [3]]}, "targets = [[1, 2], [3]] must be a list of [x, y] points"),
    ({"leader": 1, "targets": {"count": 3, "side": 2}}, "targets.side: unknown key"),
    ({"leader": 1, "targets": {"count": -3}}, "targets.count = -3 must be a non-negative integer"),
])
def test_a_bad_parameter_is_named_with_its_value(params, message):
    assert message in RoleParams.problem(params)
    assert RoleSwitching.validate(params) == RoleParams.problem(params)
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)").replace("[", r"\[")):
        RoleSwitching(**params)


def test_good_parameters_build_the_behaviour_unchanged():
    params = {"leader": 5, "base": 0, "targets": {"seed": 1, "count": 60, "lo": 0.0, "hi": 5.6921},
              "eta_a": 0.7, "lease": 4, "aat": "baseline", "hold": 0.85}
    assert RoleParams.problem(params) is None
    robot = RoleSwitching(**params)
    assert robot.p == RoleParams(**params) and robot.p.eta_a == 0.7 and robot.p.k1 == 0.05


# ---------------------------------------------------------------- motion laws
def test_cap_saturates_at_vmax_and_keeps_the_direction():
    assert np.allclose(cap(np.array([3.0, 4.0]), 0.5), [0.3, 0.4])
    assert np.array_equal(cap(np.array([0.01, 0.0]), 0.03), [0.01, 0.0])


@settings(max_examples=100, deadline=None)
@given(x=vec, xp=vec, xc=vec)
def test_eq1_repeater_of_the_leader_heads_to_the_midpoint(x, xp, xc):
    u = repeater_input(x, xp, xc, True, P, D_C)
    assert np.allclose(u, 2 * P.k1 * ((xp + xc) / 2 - x))


def test_eq2_repeater_keeps_eta_a_d_c_from_its_parent_on_the_line():
    xp, xc = np.array([0.0, 0.0]), np.array([2 * P.eta_a * D_C, 0.0])
    at = np.array([P.eta_a * D_C, 0.0])  # eta_a d_c from the parent, on the line to the child
    assert np.allclose(repeater_input(at, xp, xc, False, P, D_C), 0.0)
    near = np.array([0.5 * P.eta_a * D_C, 0.0])  # too close to the parent: pushed outwards, towards the child
    assert repeater_input(near, xp, xc, False, P, D_C)[0] > 0


@settings(max_examples=100, deadline=None)
@given(x=vec, goal=vec)
def test_eq3_leader_heads_to_its_goal(x, goal):
    assert np.allclose(leader_input(x, goal.tolist(), P), P.k4 * (goal - x))
    assert np.array_equal(leader_input(x, None, P), [0.0, 0.0])


def test_h6_hold_turns_an_outward_input_inwards_beyond_hold_d_c():
    xp = np.array([0.0, 0.0])
    inside = np.array([0.5, 0.0])
    u = np.array([0.02, 0.01])
    assert np.array_equal(hold(u, inside, xp, P, D_C), u)  # within hold d_c: unchanged
    far = np.array([P.hold * D_C + 0.1, 0.0])
    out = hold(u, far, xp, P, D_C)
    assert out[0] == pytest.approx(-P.vmax) and out[1] == pytest.approx(0.01)  # outward part -> vmax inwards
    assert np.array_equal(hold(np.array([-0.05, 0.0]), far, xp, P, D_C), [-0.05, 0.0])  # already inwards
    assert np.array_equal(hold(u, far, None, P, D_C), u)  # no parent known


def test_h6_hold_never_drives_a_repeater_away_from_a_child_beyond_hold_d_c():
    """The patrol N = 30, seed 2020 (tick 1557): repeater 17, held towards its parent at vmax, left its child 10.

    10 had just handed the lead over and was turning round (0.15 rad per timestep) so could not follow: the
    link 17-10 grew from 1.30 to 1.506 > d_c in 15 ticks. The child side of H6 keeps the parent side's pull
    (and Eqs. 1-2) from moving a repeater away from a child already beyond hold d_c.
    """
    far = P.hold * D_C + 0.05
    xp, x, xc = np.array([-far, 0.0]), np.array([0.0, 0.0]), np.array([far - 0.02, 0.0])  # a straight chain
    u = np.array([0.0, 0.01])
    assert np.array_equal(hold(u, x, xp, P, D_C, None), [-P.vmax, 0.01])  # parent side alone: away from the child
    assert np.allclose(hold(u, x, xp, P, D_C, xc), [0.0, 0.01])  # child side: no move along the chain
    near = np.array([P.hold * D_C - 0.05, 0.0])  # the child within hold d_c: the parent side as before
    assert np.array_equal(hold(u, x, xp, P, D_C, near), [-P.vmax, 0.01])
    towards = np.array([0.02, 0.0])  # towards a far child: kept (Eq. 1's midpoint, the chain's normal motion)
    assert np.array_equal(hold(towards, x, None, P, D_C, xc), towards)
    bent = np.array([0.0, -far])  # parent and child at a right angle: the pull to the parent stays whole
    assert np.allclose(hold(u, x, xp, P, D_C, bent), [-P.vmax, 0.0])
    wide = far * np.array([0.5, -math.sqrt(3) / 2])  # 120 degrees: dropping the child-outward part of a large
    assert np.array_equal(hold(np.array([0.0, 0.2]), x, xp, P, D_C, wide), [0.0, 0.0])  # input leaves a parent-
    # outward one: the robot stands still


@settings(max_examples=200, deadline=None)
@given(vec, vec, vec, vec)
def test_h6_hold_does_not_stretch_a_link_already_beyond_hold_d_c(u, x, xp, xc):
    """First order: u never lengthens the parent link or the child link of a robot beyond hold d_c of either."""
    u = u / 100
    out = hold(u, x, xp, P, D_C, xc)
    for other in (xp, xc):
        r = x - other
        d = float(np.hypot(*r))
        if d > P.hold * D_C:
            assert float(out @ r) / d <= 1e-12


def test_eqs4_to_7_explorer_terms_add_up_and_are_capped():
    p = RoleParams(leader=1, vmax=10.0)
    x = np.array([0.0, 0.0])
    link_u = [[0.02, 0.0], None]  # robot 2 announced u; robot 3's STATE not heard yet
    link_x = [np.array([1.0, 0.0]), np.array([0.0, 0.3])]
    il, xl = [0.01, 0.01], [2.0, 1.0]
    u = explorer_input(x, link_u, link_x, (il, xl), p)
    eq5 = p.k5 / 2 * np.array([0.02, 0.0])  # divided by |A_i| = 2, both links
    eq6 = p.k6 * (np.array([1.0, 0.0]) * (1 - p.d_n) + np.array([0.0, 0.3]) * (1 - p.d_n / 0.3))
    eq7 = p.k7 * np.array(il) + p.k8 * np.array(xl)
    assert np.allclose(u, eq5 + eq6 + eq7)
    capped = explorer_input(x, link_u, link_x, (il, xl), P)
    assert math.hypot(*capped) == pytest.approx(P.vmax) and np.allclose(capped / P.vmax, u / np.hypot(*u))


def test_eq6_explorer_at_distance_d_n_of_its_only_link_stands_still():
    x = np.array([0.0, 0.0])
    assert np.allclose(explorer_input(x, [[0.0, 0.0]], [np.array([0.0, P.d_n])], None, P), 0.0)
    assert np.array_equal(explorer_input(x, [], [], None, P), [0.0, 0.0])


@settings(max_examples=60, deadline=None)
@given(x=vec, goal=vec)
def test_recovery_heads_to_the_goal_or_the_origin_at_vmax(x, goal):
    if np.hypot(*(goal - x)) > 1e-3:
        u = head_to(x, goal, P.vmax)
        assert math.hypot(*u) == pytest.approx(P.vmax)
        assert float(u @ (goal - x)) > 0
    if np.hypot(*x) > 1e-3:
        assert float(head_to(x, None, P.vmax) @ x) < 0


# ---------------------------------------------------------------- Algorithm 1
XP = np.array([0.0, 0.0])


def request(x, cands, tick=100, parent_is_base=False, parent_refused_at=None, goal=None, p=P):
    return role_change_request(tick, np.array(x), XP, 7, parent_is_base, parent_refused_at, cands, goal, p, D_C)


def test_algorithm1_no_request_between_eta_b_and_eta_a():
    assert request([0.5 * D_C, 0.0], [Candidate(2, np.array([1.2, 0.3]), 4, None)]) is None


def test_algorithm1_extends_to_the_linked_explorer_with_most_links():
    x = [0.85 * D_C, 0.0]  # d > eta_a d_c
    cands = [Candidate(2, np.array([1.6, 0.4]), 2, None), Candidate(3, np.array([1.6, -0.4]), 5, None),
             Candidate(4, np.array([1.7, 0.0]), 3, None)]
    assert request(x, cands) == (EXTEND, 3)


def test_algorithm1_ties_go_to_the_closest_to_the_goal_then_the_smallest_id():
    x = [0.85 * D_C, 0.0]
    cands = [Candidate(4, np.array([1.6, 0.4]), 3, None), Candidate(2, np.array([1.6, -0.4]), 3, None)]
    assert request(x, cands, goal=[3.0, 3.0]) == (EXTEND, 4)
    assert request(x, cands, goal=[3.0, -3.0]) == (EXTEND, 2)
    assert request(x, cands) == (EXTEND, 2)


def test_algorithm1_skips_a_recent_refusal_and_candidates_that_would_hand_back():
    x = np.array([0.85 * D_C, 0.0])
    lim = (P.eta_b + P.margin) * D_C
    refused = Candidate(2, np.array([1.6, 0.4]), 9, 100 - NACK_BACKOFF + 1)
    too_close = Candidate(3, x + [lim * 0.9, 0.0], 9, None)
    unknown = Candidate(5, None, 9, None)
    ok = Candidate(4, np.array([1.7, 0.0]), 1, None)
    assert request(x, [refused, too_close, unknown, ok]) == (EXTEND, 4)
    assert request(x, [refused._replace(refused_at=100 - NACK_BACKOFF), ok]) == (EXTEND, 2)  # backoff over
    assert request(x, [refused, too_close]) == (EXTEND, None)  # nobody fits: the leader stalls


def test_algorithm1_retracts_to_the_parent_unless_it_is_the_base_station():
    x = [0.1 * D_C, 0.0]  # d < eta_b d_c
    assert request(x, []) == (RETRACT, 7)
    assert request(x, [], parent_is_base=True) is None
    assert request(x, [], parent_refused_at=95) is None
    assert request(x, [], parent_refused_at=100 - NACK_BACKOFF) == (RETRACT, 7)


@settings(max_examples=200, deadline=None)
@given(d=st.floats(0.0, 2.0), n=st.integers(0, 6))
def test_algorithm1_request_kind_follows_the_thresholds(d, n):
    cands = [Candidate(10 + i, np.array([d + 1.0, 0.5 * i]), i, None) for i in range(n)]
    req = request([d, 0.0], cands)
    if d > P.eta_a * D_C:
        assert req is not None and req.kind == EXTEND
    elif d < P.eta_b * D_C:
        assert req == (RETRACT, 7)
    else:
        assert req is None


# ---------------------------------------------------------------- Algorithm 1: the candidate's answer (H2-H3)
REQ = {"role": LL, "e": 5, "T": 40, "kind": EXTEND, "goal": [1.0, 2.0], "gk": 3}


def answer(body=REQ, src=7, role=EX, epoch=4, linked=True, child=None, pending=None, led_from=None, decided=None):
    req = BODIES.decode_body(REQUEST, body)
    return answer_request(req, src, role, epoch, linked, child, pending, led_from, decided or {})


def test_a_linked_explorer_accepts_an_extension_with_a_newer_epoch():
    assert answer() == Answer("ack", None, True)


def test_the_parent_repeater_accepts_a_retraction_from_its_child():
    assert answer({**REQ, "kind": RETRACT}, role=RP, child=7) == Answer("ack", None, True)
    assert answer({**REQ, "kind": RETRACT}, role=RP, child=8) == Answer("nack", "role_conflict", True)


@pytest.mark.parametrize(("body", "cause"), [
    (None, "not_a_map"), ([], "not_a_map"), ({**REQ, "e": "5"}, "bad_field"), ({**REQ, "T": True}, "bad_field"),
    ({**REQ, "kind": "swap"}, "bad_field"), ({**REQ, "goal": [1.0]}, "bad_field"),
    ({k: v for k, v in REQ.items() if k != "role"}, "missing_field")])
def test_a_malformed_request_is_refused_by_its_decoding_and_gets_no_reply(body, cause):
    """It never reaches answer_request: the robot counts it in ``refused`` under the decoder's cause."""
    counts: dict = {}
    assert BODIES.decode_body(REQUEST, body, counts) is None and counts == {cause: 1}


@pytest.mark.parametrize("kw,why", [
    ({"body": {**REQ, "role": "king"}}, "unknown_role"),
    ({"body": {**REQ, "role": RP}}, "not_requestable"),
    ({"linked": False}, "not_neighbour"),
    ({"role": BS}, "base_station"),
    ({"role": RP}, "role_conflict"),  # an extension asks an explorer
    ({"role": LL}, "role_conflict"),
    ({"pending": (9, 6)}, "role_conflict"),  # already accepted another request
    ({"epoch": 5}, "stale"),
    ({"epoch": 8}, "stale"),
])
def test_refusals_name_their_reason(kw, why):
    assert answer(**kw) == Answer("nack", why, True)


def test_retries_get_the_same_answer_whatever_changed_h2():
    assert answer(pending=(7, 5), linked=False) == Answer("ack", None, False)  # accepted, waiting for T
    assert answer(role=LL, epoch=5, led_from=7, linked=False) == Answer("ack", None, False)  # switched already
    assert answer(decided={(7, 5): "stale"}) == Answer("nack", "stale", False)  # now it would fit: same answer
    assert answer(decided={(7, 4): "stale"}) == Answer("ack", None, True)  # another epoch: a new request
    assert answer(role=LL, epoch=5, led_from=8) == Answer("nack", "role_conflict", True)
