"""RoleSwitching's parameters: one dataclass, validated in one place.

A scenario's ``[[robots]] behaviors = [{ use = "roles", leader = 5, eta_a = 0.8, ... }]`` keys are the fields
below, unchanged. ``RoleParams.problem(params)`` says what is wrong with a parameter table (naming the key and
the value), ``RoleParams.of(params)`` builds the parameters or raises ``ValueError`` with that message. The
values the paper gives and the ones we chose are in docs/protocols/roles.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any

from protocols.roles.aat import MODES, PROPOSED
from swarmactors.robot.behavior import is_int, is_num

# kinds of value (a field's ``metadata["kind"]``) and what each accepts
ROBOT_ID, FRACTION, POSITIVE, GAIN, COUNT, MODE, TARGETS, WITNESSES, FLAG = (
    "robot id", "fraction", "positive", "gain", "count", "mode", "targets", "witnesses", "flag")
WITNESS_SETS = ("linkable", "all")
RULES = {
    ROBOT_ID: (lambda v: is_int(v) and v >= 0, "must be a robot id (non-negative integer)"),
    FRACTION: (lambda v: is_num(v) and 0 < v < 1, "must be a number in (0, 1) (a fraction of d_c)"),
    POSITIVE: (lambda v: is_num(v) and v > 0, "must be a positive number"),
    GAIN: (lambda v: is_num(v) and v >= 0, "must be a non-negative number"),
    COUNT: (lambda v: is_int(v) and v >= 1, "must be a positive integer"),
    MODE: (lambda v: v in MODES, f"must be one of {MODES}"),
    WITNESSES: (lambda v: v in WITNESS_SETS, f"must be one of {WITNESS_SETS}"),
    FLAG: (lambda v: isinstance(v, bool), "must be true or false"),
}


def _p(default: Any, kind: str, doc: str) -> Any:
    return field(default=default, metadata={"kind": kind, "doc": doc})


def is_point(v: Any) -> bool:
    """Whether ``v`` is an [x, y] of finite numbers (a list or tuple of two ints or floats, no bool)."""
    return (type(v) in (list, tuple) and len(v) == 2 and all(type(c) in (int, float) for c in v)
            and all(math.isfinite(c) for c in v))


@dataclass(frozen=True)
class RoleParams:
    """The parameters of one ``roles`` robot (Kobayashi et al. 2022; d_c and d_s come from the robot's context)."""

    leader: int = field(metadata={"kind": ROBOT_ID, "doc": "the initial local leader"})
    base: int = _p(0, ROBOT_ID, "the base station (fixed at its position)")
    targets: list | dict | None = _p(None, TARGETS, "the base station's targets: [[x, y], ...] or "
                                                    "{seed, count, lo, hi}")
    eta_a: float = _p(0.8, FRACTION, "Algorithm 1: extend when the parent is beyond eta_a d_c")
    eta_b: float = _p(0.15, FRACTION, "Algorithm 1: retract when the parent is within eta_b d_c")
    eta_c: int = _p(3, COUNT, "Algorithm 2: test all sensed robots when |A_i| < eta_c")
    aat: str = _p(PROPOSED, MODE, "Algorithm 2 (proposed) or the every-tick baseline")
    witnesses: str = _p("linkable", WITNESSES, "Algorithm 2's witnesses R_k: local leaders and explorers "
                        "(linkable, ours) or every sensed robot, repeaters and the base station included (all, "
                        "the paper as printed)")
    circles: bool = _p(True, FLAG, "Algorithm 2 lines 9-15 (the circle tests); false skips them, for comparison")
    k1: float = _p(0.05, GAIN, "Eq. 1 gain")
    k2: float = _p(0.1, GAIN, "Eq. 2 gain (distance to the parent)")
    k3: float = _p(0.02, GAIN, "Eq. 2 gain (midpoint)")
    k4: float = _p(0.1, GAIN, "Eq. 3 gain")
    k5: float = _p(0.5, GAIN, "Eq. 5 gain (velocity matching)")
    k6: float = _p(0.05, GAIN, "Eq. 6 gain (distance keeping)")
    k7: float = _p(0.5, GAIN, "Eq. 7 gain (the local leader's input)")
    k8: float = _p(0.02, GAIN, "Eq. 7 gain (the local leader's position)")
    d_n: float = _p(0.6, POSITIVE, "Eq. 6: the distance kept to linked robots")
    vmax: float = _p(0.03, POSITIVE, "Eq. 4: the cap on |u| per timestep")
    expiry: int = _p(15, COUNT, "Sec. III-C: a flooded u_LL expires after this many ticks")
    lost_after: int = _p(8, COUNT, "Sec. III-D: disconnected after this many ticks without a fresh u_LL")
    help_every: int = _p(5, COUNT, "Sec. III-D: ticks between two RS_HELP")
    target_every: int = _p(10, COUNT, "ticks between two repeats of RS_TARGET / RS_ARRIVED")
    arrive: float = _p(0.1, POSITIVE, "a target is reached within this distance")
    switch_delay: int = _p(3, COUNT, "H1: the switch tick is the request's tick + switch_delay")
    lease: int = _p(6, COUNT, "H4: a request unanswered by T + lease is taken as lost")
    hold: float = _p(0.9, FRACTION, "H6: a chain robot stays within hold d_c of its parent (and its child)")
    margin: float = _p(0.05, GAIN, "H1': a candidate must stand beyond (eta_b + margin) d_c")

    @classmethod
    def problem(cls, params: dict) -> str | None:
        """What is wrong with a scenario's parameter table (naming the key and value), or None."""
        known = {f.name: f for f in fields(cls)}
        for key in params:
            if key not in known:
                return f"unknown parameter {key!r} (known: {', '.join(known)})"
        if "leader" not in params:
            return "leader is required (the id of the initial local leader)"
        for key, value in params.items():
            kind = known[key].metadata["kind"]
            if kind == TARGETS:
                if (why := _targets_problem(value)) is not None:
                    return why
                continue
            ok, rule = RULES[kind]
            if not ok(value):
                return f"{key} = {value!r} {rule}"
        if params["leader"] == params.get("base", 0):
            return f"leader = {params['leader']!r}: the base station cannot be the initial local leader"
        if params.get("eta_b", cls.eta_b) >= params.get("eta_a", cls.eta_a):
            return (f"eta_b = {params.get('eta_b', cls.eta_b)!r} must be smaller than "
                    f"eta_a = {params.get('eta_a', cls.eta_a)!r}")
        return None

    @classmethod
    def of(cls, params: dict) -> RoleParams:
        """The parameters from a scenario's table; ``ValueError`` naming the key when one is bad."""
        why = cls.problem(params)
        if why is not None:
            raise ValueError(why)
        return cls(**params)


def _targets_problem(t: Any) -> str | None:
    if t is None or (isinstance(t, list) and all(is_point(p) for p in t)):
        return None
    if isinstance(t, dict):
        extra = set(t) - {"seed", "count", "lo", "hi"}
        if extra:
            return f"targets.{sorted(extra)[0]}: unknown key (a targets table takes seed, count, lo, hi)"
        for key in ("seed", "count"):
            if key in t and not (is_int(t[key]) and t[key] >= 0):
                return f"targets.{key} = {t[key]!r} must be a non-negative integer"
        for key in ("lo", "hi"):
            if key in t and not is_num(t[key]):
                return f"targets.{key} = {t[key]!r} must be a number"
        return None
    return f"targets = {t!r} must be a list of [x, y] points or a table {{seed, count, lo, hi}}"
