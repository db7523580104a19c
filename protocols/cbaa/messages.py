"""CBAA's frame body (one kind, ``BID``), typed; the keys and their order are the wire's."""

from __future__ import annotations

from msgspec import field

from protocols.cbaa.rules import KIND
from swarmactors.robot.bodies import UNSET, Bodies, Body, Finite, Index, NonNeg, UnsetType


class Bid(Body, kw_only=True):
    """A robot's bid table: its task, the highest bid it knows per task and who made it, and (T1) its table.

    What the types cannot say (one entry per task, ``t`` a task whose winner is the sender, a bid with its
    winner) the behaviour checks against its own task list.
    """

    KIND = KIND
    task: Index | None = field(name="t")  # x_i: the task the sender holds, or none
    bids: list[NonNeg] = field(name="y")  # y: the highest bid known per task (0: none)
    winners: list[Index | None] = field(name="z")  # z: who made it (None: nobody)
    seen: list[tuple[int, Finite]] | UnsetType = field(default=UNSET, name="s")  # T1: [robot, time] freshness


BODIES = Bodies(Bid)
