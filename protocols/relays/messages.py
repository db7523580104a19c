"""Swarm Relays' frame bodies, typed: the maps they always were (keys and their order are the wire's).

The virtual stigmergy's frames (VS_PUT, VS_QUERY, VS_DIGEST) are typed in ``protocols.stigmergy.messages``;
what relays write into the stigmergy (targets, plans) is an entry's value, not a frame body.
"""

from __future__ import annotations

from typing import Annotated, Literal

from msgspec import Meta, field

from swarmactors.robot.bodies import Bodies, Body, Finite, Index

CHAIN, TASK, BID, JOIN, NEED = "REL_CHAIN", "REL_TASK", "REL_BID", "REL_JOIN", "REL_NEED"
ROOT, WORKER, NETWORKER, FREE = "root", "worker", "networker", "free"

Role = Literal["root", "worker", "networker", "free"]
Ids = list[int]


class Chain(Body):
    """The status broadcast, every tick (Sec. IV-B): role, chain, parent, child, depth and C_local's halves.

    ``up`` runs from the sender towards the root, ``dn`` from the sender towards the worker (k ids each beyond
    the sender); ``ok``: the chain's worker is at its target; ``n``: the robots from the sender to the worker.
    A role of None is never sent: it marks a link a robot was just given and has not heard yet.
    """

    KIND = CHAIN
    role: Role | None = field(name="r")
    chain: int | None = field(default=None, name="c")
    parent: int | None = field(default=None, name="p")
    child: int | None = field(default=None, name="ch")
    depth: int | None = field(default=None, name="d")
    up: Ids = []
    dn: Ids = []
    ok: bool = False
    n: Index = 0


class Task(Body):
    """A CBAA slot (recruiting, R5): a free robot to sit at ``pos`` (the recruiter's parent's position)."""

    KIND = TASK
    key: str
    pos: Annotated[list[Finite], Meta(min_length=2, max_length=3)]
    close: int  # the tick the auction closes
    chain: int = field(name="c")
    fly: bool = False  # a flying slot takes flying robots only


class Bid(Body):
    """CBAA consensus: per slot key, the best bid heard and its bidder, ``[y, z]`` (max-consensus on (y, -z))."""

    KIND = BID
    bids: dict[str, tuple[Finite, int]]


class Join(Body):
    """The recruiter's call to the slot's winner: sit between ``parent`` and ``child`` in chain ``c`` (Prop. 1)."""

    KIND = JOIN
    chain: int = field(name="c")
    parent: int
    child: int
    key: str


class Need(Body):
    """Without WP prediction: the head asks for a robot; passed parent by parent towards the root (Sec. IV)."""

    KIND = NEED
    chain: int = field(name="c")


BODIES = Bodies(Chain, Task, Bid, Join, Need)
KINDS = BODIES.kinds
