"""SECS's frame bodies (``SECS_T``, ``SECS_M``), typed; the keys and their order are the wire's.

A robot's ``SECS_T`` holds the keys its role sends, in this order: the master's ``a, T, al, d, p, [rv], [fl],
v``, the scheduled master's ``a, T, al, d, ph, fl | p [r] | rv, v``, a backbone robot's ``a, T, al, d, [ph],
[p], [rv | fl], [r], v`` (``r`` only with the opt-in ``hold_tasks``); a key a robot does not send is ``UNSET``.
The angles' range ([0, 2π), finite) depends on the role, so the behaviour checks them after decoding
(``protocols.secs.behavior.parse_t``), counted as ``angle``.
"""

from __future__ import annotations

import sys
from typing import Annotated, Any, Union

import msgspec
from msgspec import Meta, field

from swarmactors.robot.bodies import UNSET, Bodies, Body, Finite, Index, NonNeg, Num, UnsetType

T_KIND = "SECS_T"
M_KIND = "SECS_M"

Probability = Union[Annotated[int, Meta(ge=0, le=1)], Annotated[float, Meta(ge=0, le=1)]]  # noqa: UP007
Positive = Union[Annotated[int, Meta(gt=0)], Annotated[float, Meta(gt=0, le=sys.float_info.max)]]  # noqa: UP007


class Target(Body, kw_only=True):
    """``SECS_T``: a robot's arm, ∠T (the master: one per arm), alignment, distance, velocity, relayed orders."""

    KIND = T_KIND
    arm: int = field(name="a")  # -1: the master
    target: Num | list[Num] | None | UnsetType = field(default=UNSET, name="T")  # ∠T_i in its own frame;
    # the master's: a list, one per arm
    aligned: bool | UnsetType = field(default=UNSET, name="al")
    dist: NonNeg | None | UnsetType = field(default=UNSET, name="d")  # its distance to the master along the swarm
    phase: Index | UnsetType = field(default=UNSET, name="ph")  # the master's behaviour changes (a schedule)
    probs: list[Probability] | UnsetType = field(default=UNSET, name="p")  # the arms' probabilities
    rv: Positive | UnsetType = field(default=UNSET, name="rv")  # the rendez-vous δ
    flock: Any = field(default=UNSET, name="fl")  # flocking (1)
    reach: list[NonNeg] | UnsetType = field(default=UNSET, name="r")  # opt-in hold_tasks: each task's distance
    v: tuple[Finite, Finite] | UnsetType = UNSET  # its velocity in its own frame (none: at rest)

    @classmethod
    def of(cls, body: dict) -> Target:
        """The typed body of a ``SECS_T`` dict the behaviour builds (its short keys)."""
        return cls(**{_FIELD[k]: v for k, v in body.items()})


_FIELD = {f.encode_name: f.name for f in msgspec.structs.fields(Target)}


class Bearings(Body, kw_only=True):
    """``SECS_M``: [[i, ∠M_ji], ...], the bearing in its own frame at which it sees each neighbour i."""

    KIND = M_KIND
    seen: list[tuple[int, Num]] = field(name="M")


BODIES = Bodies(Target, Bearings)
