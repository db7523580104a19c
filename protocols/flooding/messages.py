"""Flooding's frame bodies (one kind, ``FLOOD``), typed; the keys and their order are the wire's."""

from __future__ import annotations

from typing import Any

from msgspec import field

from swarmactors.robot.bodies import UNSET, Bodies, Body, Num, UnsetType

KIND = "FLOOD"


class Flood(Body, kw_only=True):
    """A copy of message ``msg``: its deadline (F1) or remaining lifetime (F1r), its hop count and payload."""

    KIND = KIND
    msg: str = field(name="m")
    deadline: Num | None | UnsetType = field(default=UNSET, name="dl")  # F1: origin's clock + expiry
    remaining: Num | None | UnsetType = field(default=UNSET, name="rl")  # F1r: the lifetime left
    hop: int = field(name="h")
    payload: Any = field(default=None, name="p")


BODIES = Bodies(Flood)
