"""Biconnectivity's frame bodies, typed: the lists they always were (positional, today's order).

Two wire shapes need more than ``swarmactors.robot.bodies``: a HELLO or POS-REPLY body is the bare list of table rows
(not a list holding it), and a CHECK-REQUEST carries its fourth item (the period's index in the check, R15)
only after a check's first period. ``BODIES`` keeps both: a ``Table`` is decoded from and encoded to the bare
list, and a ``Request`` without an index is sent as three items.
"""

from __future__ import annotations

from collections.abc import MutableMapping
from typing import Annotated, Any, Union

from msgspec import Meta

from swarmactors.robot.bodies import Bodies, Body, Index, NonNeg, Num

CR, DCR = "CR", "DCR"
CHECK_REQUEST, DC_TRUE, DC_FALSE = "CHECK-REQUEST", "DC-TRUE", "DC-FALSE"
BUDGET, VERDICT = "BUDGET", "VERDICT"
HELLO, LEAVE, POS_REQUEST, POS_REPLY, MOVE = "HELLO", "LEAVE", "POS-REQUEST", "POS-REPLY", "MOVE"

Point = tuple[Num, Num]
Positive = Union[Annotated[int, Meta(gt=0)], Annotated[float, Meta(gt=0)]]  # noqa: UP007 - read by msgspec


class Stamped(Body, array_like=True, forbid_unknown_fields=True):
    """A stamped message ``(T, S)`` of period ``p``: ``[p, S]``, S the stamps in order (Algorithm 1)."""

    period: Index
    stamps: Annotated[list[int], Meta(min_length=1)]

    def __post_init__(self):
        if len(set(self.stamps)) != len(self.stamps):
            raise ValueError("repeated_stamp")


class Cr(Stamped):
    """CR-FILL (R2): the stamps collect the sender's connected component."""

    KIND = CR


class Dcr(Stamped):
    """DCR-FILL (Algorithm 2): a robot finding its id in S adds the ids after it (S2) to DCR if |S2| > 1."""

    KIND = DCR


class Request(Body, array_like=True, forbid_unknown_fields=True):
    """Algorithm 3's request (R5): ``[p, t_request, initiator]``, plus R15's index of the period in the check."""

    KIND = CHECK_REQUEST
    period: Index
    requested: Num  # the initiator's clock at the request: it names the check with the initiator
    by: int
    index: int | None = None  # R15: sent as a fourth item only from the check's second period on


class DcTrue(Body, array_like=True, forbid_unknown_fields=True):
    """Algorithm 3, line 3: the sender is doubly connected to all of its component in period ``p``."""

    KIND = DC_TRUE
    period: int


class DcFalse(Body, array_like=True, forbid_unknown_fields=True):
    """Algorithm 3, line 3: the sender is not doubly connected to all in period ``p``."""

    KIND = DC_FALSE
    period: int


class Budget(Body, array_like=True, forbid_unknown_fields=True):
    """R7: period ``p`` went over the relay budget; it is not relayed any more."""

    KIND = BUDGET
    period: Index


class Verdict(Body, array_like=True, forbid_unknown_fields=True):
    """R8: the initiator's verdict on period ``p``, flooded once: ``[p, initiator, value, reason]``."""

    KIND = VERDICT
    period: int
    by: int
    value: bool
    reason: str


class Row(Body, array_like=True, forbid_unknown_fields=True):
    """A table row (R10): ``[id, x, y, stamp tick, neighbour ids]``, a region centre and when it was known."""

    rid: int
    x: Num
    y: Num
    stamp: Num
    neighbours: list[int]


class Table(Body, array_like=True, forbid_unknown_fields=True):
    """A table of rows, sent as the bare list of its rows (see the module's docstring)."""

    rows: list[Row]


class Hello(Table):
    """R10: the sender's table, its own row fresh."""

    KIND = HELLO


class PosReply(Table):
    """R11: a settled robot's table, to a joiner that asked."""

    KIND = POS_REPLY


class Leave(Body, array_like=True, forbid_unknown_fields=True):
    """R12: the sender leaves the structure: ``[id]``."""

    KIND = LEAVE
    rid: int


class PosRequest(Body, array_like=True, forbid_unknown_fields=True):
    """R11: a joiner asks for the settled robots' tables: ``[id]``."""

    KIND = POS_REQUEST
    rid: int


class Move(Body, array_like=True, forbid_unknown_fields=True):
    """R12 (Theorem 4): move up to ``d`` towards the removed robot's centre from tick ``start``, at ``speed``."""

    KIND = MOVE
    leader: int
    round: int
    removed: int
    pos: Point  # the removed robot's region centre
    d: NonNeg
    start: int
    speed: Positive


class _Bodies(Bodies):
    """``Bodies`` with the two shapes of the module's docstring: a bare table, a three-item request."""

    def decode_body(self, kind: str, body: Any, counts: MutableMapping[str, int] | None = None) -> Body | None:
        t = self.types.get(kind)
        if t is not None and issubclass(t, Table):
            if not isinstance(body, list):
                if counts is not None:
                    counts["not_an_array"] = counts.get("not_an_array", 0) + 1
                return None
            body = [body]
        return super().decode_body(kind, body, counts)

    @staticmethod
    def encode(body: Body) -> Any:
        value = Bodies.encode(body)
        if isinstance(body, Table):
            return value[0]
        if isinstance(body, Request) and body.index is None:
            return value[:3]
        return value


BODIES = _Bodies(Cr, Dcr, Request, DcTrue, DcFalse, Budget, Verdict, Hello, Leave, PosRequest, PosReply, Move)
KINDS = BODIES.kinds
