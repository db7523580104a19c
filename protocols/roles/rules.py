"""RoleSwitching's rules as pure functions: the motion laws (Eqs. 1-7) and Algorithm 1's request and answer.

Kobayashi, Higuchi & Ueno (2022). Every function takes what the robot knows (its position, its parent's and
child's, its links' last states, the flooded u_LL and x_LL) and its parameters, and returns a control input
or a decision; none sends, senses or keeps state. ``behavior.RoleSwitching`` calls them; tests/unit/
test_roles_rules.py checks them. Vectors are numpy arrays of 2 floats; u is per timestep.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np

from protocols.roles.params import RoleParams

BS, RP, LL, EX = "base_station", "repeater", "local_leader", "explorer"
ROLES = (BS, RP, LL, EX)
EXTEND, RETRACT = "extend", "retract"
NACK_BACKOFF = 20  # ticks a robot that refused a request is not asked again (ours)


def cap(u: np.ndarray, vmax: float) -> np.ndarray:
    """Eq. 4's saturation: u scaled down to |u| = vmax when longer."""
    n = math.hypot(u[0], u[1])
    return u * (vmax / n) if n > vmax else u


# ------------------------------------------------------------------ motion laws
def repeater_input(x: np.ndarray, xp: np.ndarray, xc: np.ndarray, child_leads: bool, p: RoleParams,
                   d_c: float) -> np.ndarray:
    """A repeater's input before H6 and the cap.

    Eq. 1 (its child is the local leader): u = k1 ((x_p - x) + (x_c - x)), towards the midpoint.
    Eq. 2 (its child is a repeater): u = k2 (x_p - x - eta_a d_c (x_p - x)/|x_p - x|) + k3 ((x_p - x) + (x_c - x)),
    eta_a d_c from the parent, on the line to the child.
    """
    if child_leads:
        return p.k1 * ((xp - x) + (xc - x))
    dp = xp - x
    n = float(np.hypot(*dp))
    return p.k2 * (dp - p.eta_a * d_c * dp / n if n > 1e-9 else dp) + p.k3 * ((xp - x) + (xc - x))


def leader_input(x: np.ndarray, goal: Sequence[float] | None, p: RoleParams) -> np.ndarray:
    """Eq. 3: the local leader heads to its goal, u = k4 (x_goal - x); zero without a goal."""
    return p.k4 * (np.array(goal) - x) if goal is not None else np.zeros(2)


def hold(u: np.ndarray, x: np.ndarray, xp: np.ndarray | None, p: RoleParams, d_c: float,
         xc: np.ndarray | None = None) -> np.ndarray:
    """H6 (ours): a chain robot's input kept from stretching its chain links past hold d_c.

    Parent side: beyond hold d_c from its parent (``xp``), the outward part of u is replaced by vmax inwards.
    Child side (a repeater; ``xc``, its child's position): beyond hold d_c from its child, the part of u that
    points away from the child is dropped, after the parent side, so that the parent side's pull never drags
    the robot away from a child that cannot follow at once (a new repeater turning round at 0.15 rad per
    timestep). When that leaves u pointing away from a parent beyond hold d_c as well, the robot stands still:
    neither link grows.
    """
    rp = None
    if xp is not None:
        r = x - xp
        d = float(np.hypot(*r))
        if d > p.hold * d_c:
            rp = r / d
            out = float(u @ rp)
            if out > -p.vmax:
                u = u - (out + p.vmax) * rp
    if xc is not None:
        r = x - xc
        d = float(np.hypot(*r))
        if d > p.hold * d_c:
            rc = r / d
            out = float(u @ rc)
            if out > 0.0:
                u = u - out * rc
                if rp is not None and float(u @ rp) > 0.0:
                    u = np.zeros(2)
    return u


def explorer_input(x: np.ndarray, link_u: Sequence[Sequence[float] | None],
                   link_x: Sequence[np.ndarray | None], leader: tuple[Sequence[float], Sequence[float]] | None,
                   p: RoleParams) -> np.ndarray:
    """Eqs. 4-7: an explorer's input, capped at vmax.

    ``link_u`` and ``link_x`` hold, for each linked robot (sorted by id), its last announced input and its
    position (None when unknown); ``leader`` is the flooded (u_LL, x_LL), or None. With the links A_i:
    Eq. 5, velocity matching: k5 / |A_i| * sum of u_j;
    Eq. 6, distance keeping: k6 * sum of (x_j - x - d_n (x_j - x)/|x_j - x|);
    Eq. 7, following the local leader: k7 u_LL + k8 (x_LL - x);
    Eq. 4: u = cap(Eq. 5 + Eq. 6 + Eq. 7, vmax).
    """
    x0, x1 = float(x[0]), float(x[1])
    ux = uy = 0.0
    if link_u:
        mx = my = 0.0
        for uj in link_u:  # Eq. 5
            if uj is not None:
                mx += uj[0]
                my += uj[1]
        ux += p.k5 / len(link_u) * mx
        uy += p.k5 / len(link_u) * my
        for xj in link_x:  # Eq. 6
            if xj is None:
                continue
            dx, dy = float(xj[0]) - x0, float(xj[1]) - x1
            n = math.hypot(dx, dy)
            if n > 1e-9:
                ux += p.k6 * (dx - p.d_n * dx / n)
                uy += p.k6 * (dy - p.d_n * dy / n)
    if leader is not None:  # Eq. 7
        il, xl = leader
        ux += p.k7 * il[0] + p.k8 * (xl[0] - x0)
        uy += p.k7 * il[1] + p.k8 * (xl[1] - x1)
    return cap(np.array([ux, uy]), p.vmax)


def head_to(x: np.ndarray, goal: np.ndarray | None, vmax: float) -> np.ndarray:
    """Sec. III-D: a disconnected explorer goes at full speed to ``goal``, or to the origin without one."""
    return cap((goal - x) * 1e3 if goal is not None else -x * 1e3, vmax)


# ------------------------------------------------------------------ Algorithm 1
class Candidate(NamedTuple):
    """A robot the local leader links (Algorithm 2), as the leader knows it."""

    id: int
    x: np.ndarray | None  # its position (None: unknown)
    links: int  # |A_c| from its last STATE (0 when unknown)
    refused_at: int | None  # the tick it last refused a request of ours


class Request(NamedTuple):
    """Algorithm 1's decision: ask ``to`` to become the local leader (``to`` None: extend, nobody fits)."""

    kind: str
    to: int | None


def role_change_request(tick: int, x: np.ndarray, xp: np.ndarray, parent: int, parent_is_base: bool,
                        parent_refused_at: int | None, candidates: Sequence[Candidate],
                        goal: Sequence[float] | None, p: RoleParams, d_c: float) -> Request | None:
    """Algorithm 1, lines 1-6, for the local leader at ``x`` whose parent is at ``xp`` (d = |x - x_p|).

    Line 1-3, d > eta_a d_c: EXTEND to the linked explorer with the most links |A_c| (ties: the closest to
    the goal, then the smallest id). Skipped (ours): a robot that refused us within NACK_BACKOFF ticks, and
    one within (eta_b + margin) d_c of us or within twice that of our parent (it would hand the lead
    straight back, now or once we stand at Eq. 1's midpoint). ``Request(EXTEND, None)`` when none fits.
    Line 4-6, d < eta_b d_c and the parent is not the base station: RETRACT to the parent (unless it refused
    us within NACK_BACKOFF ticks). None otherwise.
    """
    d = float(np.hypot(*(x - xp)))
    if d > p.eta_a * d_c:
        best = None
        lim = (p.eta_b + p.margin) * d_c
        for c in candidates:
            if c.refused_at is not None and tick - c.refused_at < NACK_BACKOFF:
                continue
            if c.x is None or float(np.hypot(*(c.x - x))) <= lim or float(np.hypot(*(c.x - xp))) <= 2 * lim:
                continue
            dist_goal = float(np.hypot(*(c.x - np.array(goal)))) if goal else 0.0
            key = (-c.links, dist_goal, c.id)
            if best is None or key < best[0]:
                best = (key, c.id)
        return Request(EXTEND, best[1] if best is not None else None)
    if d < p.eta_b * d_c and not parent_is_base and (
            parent_refused_at is None or tick - parent_refused_at >= NACK_BACKOFF):
        return Request(RETRACT, parent)
    return None


class Answer(NamedTuple):
    """A candidate's answer to a ROLE_REQUEST (rules H2-H3)."""

    reply: str | None  # "ack", "nack", or None (a malformed request gets no reply)
    why: str | None  # the reason of a refusal
    new: bool  # a decision taken now (counted in ``refused``), not the repeat of an earlier one


REMEMBERED = ("not_neighbour", "base_station", "role_conflict", "stale")  # refusals repeated to every retry


def answer_request(body: Any, src: int, role: str, epoch: int, linked: bool, child: int | None,
                   pending: tuple[int, int] | None, led_from: int | None,
                   decided: Mapping[tuple[int, int], str]) -> Answer:
    """How the robot answers ``src``'s request ``body`` to become local leader (Algorithm 1, made safe).

    ``body`` is the decoded request (``messages.Request``: one that does not decode is refused, without a
    reply, before it gets here). In order: a request for a role that does not exist
    (unknown_role) or is not the local leader (not_requestable) is refused. H2: a retry of a request we
    accepted is acknowledged again (``pending`` = (requester, epoch) accepted and waiting for the switch tick,
    or ``led_from`` = the requester we took the lead from at this ``epoch``), and a retry of one we refused
    gets the same answer (``decided``: (requester, epoch) -> reason), whatever changed since. Otherwise it is
    refused when the requester is not linked (not_neighbour), we are the base station (base_station), the
    request does not fit our role (role_conflict: EXTEND asks an explorer, RETRACT the parent repeater of the
    requester) or we already accepted another one, or its epoch is not above ours (stale); H3: accepted.
    """
    if body.role not in ROLES:
        return Answer("nack", "unknown_role", True)
    if body.role != LL:
        return Answer("nack", "not_requestable", True)
    e = body.epoch
    if pending == (src, e) or (role == LL and epoch == e and led_from == src):
        return Answer("ack", None, False)
    why = decided.get((src, e))
    if why is not None:
        return Answer("nack", why, False)
    if not linked:
        return Answer("nack", "not_neighbour", True)
    if role == BS:
        return Answer("nack", "base_station", True)
    fits = (body.kind == EXTEND and role == EX) or (body.kind == RETRACT and role == RP and child == src)
    if not fits or pending is not None:
        return Answer("nack", "role_conflict", True)
    if e <= epoch:
        return Answer("nack", "stale", True)
    return Answer("ack", None, True)
