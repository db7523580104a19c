"""Role switching's frame bodies, one typed Struct per kind; the keys and their order are the wire's.

A position or a control input is ``[x, y]`` of finite numbers; a role is one of the four role names, but a
``ROLE_REQUEST`` may name any string (a role that does not exist is refused with a reason, rules H2-H3).
"""

from __future__ import annotations

from typing import Any, Literal

from msgspec import field

from swarmactors.robot.bodies import UNSET, Bodies, Body, Finite, UnsetType

STATE = "RS_STATE"  # every tick, to the robots in A_i: role, position, velocity, control input, |A_i|, epoch
LL_INFO = "RS_LL"  # the local leader's u_LL and x_LL, by message-expiration flooding (Sec. III-C)
CONNECT = "RS_CONNECT"  # Algorithm 2: i asks j to add the link (j complies if its role allows)
DISCONNECT = "RS_DISCONNECT"  # Algorithm 2 (or a role refusal): j drops the link
REQUEST = "ROLE_REQUEST"  # Algorithm 1: become the local leader (epoch, switch tick, goal)
ACK = "ROLE_ACK"
NACK = "ROLE_NACK"
TARGET = "RS_TARGET"  # base station -> chain -> local leader: the current target
ARRIVED = "RS_ARRIVED"  # local leader -> chain -> base station
HELP = "RS_HELP"  # a disconnected explorer asks a repeater / the base station for its child's location
WHERE = "RS_WHERE"  # the answer: the child's id, role and position

Role = Literal["base_station", "repeater", "local_leader", "explorer"]
Point = tuple[Finite, Finite]


class State(Body):
    """A robot's state for its links: role, position, velocity, control input, |A_i|, epoch, parent."""

    KIND = STATE
    role: Role = field(name="r")
    pos: Point = field(name="p")
    vel: Point = field(name="v")
    u: Point = field(name="u")
    links: int = field(name="n")
    epoch: int = field(name="e")
    parent: int | None = field(default=None, name="pa")  # a repeater's or local leader's parent


class LeaderInfo(Body):
    """F1-F3: the local leader's flooded (u_LL, x_LL): origin, sequence, deadline, hops, epoch."""

    KIND = LL_INFO
    origin: int = field(name="o")
    seq: int = field(name="s")
    deadline: Finite = field(name="dl")
    hop: int = field(name="h")
    epoch: int = field(name="e")
    x: Point
    u: Point


class Connect(Body):
    """Algorithm 2: add the link (the sender's role)."""

    KIND = CONNECT
    role: Role = field(name="r")


class Disconnect(Body):
    """Algorithm 2 or a role refusal: drop the link (the sender's role, and why)."""

    KIND = DISCONNECT
    role: Role = field(name="r")
    why: Any = None


class Request(Body, kw_only=True):
    """Algorithm 1: become ``role`` (the local leader) at tick ``T`` of epoch ``e``, an extension or a retraction."""

    KIND = REQUEST
    role: str
    epoch: int = field(name="e")
    at: int = field(name="T")
    kind: Literal["extend", "retract"]
    goal: Point | None | UnsetType = UNSET  # the leader's goal and its index, handed over with the lead
    goal_k: int | UnsetType = field(default=UNSET, name="gk")


class Ack(Body):
    KIND = ACK
    epoch: int = field(name="e")


class Nack(Body):
    KIND = NACK
    epoch: int = field(name="e")
    why: Any = None


class Target(Body):
    """The mission's target ``k`` at ``x``, relayed down the chain."""

    KIND = TARGET
    k: int
    x: Point


class Arrived(Body):
    """The local leader reached target ``k``, relayed up the chain."""

    KIND = ARRIVED
    k: int


class Help(Body):
    """A lost explorer asks for the chain's next robot (an empty map)."""

    KIND = HELP


class Where(Body):
    """The answer to HELP: the sender's role and its child's id, role and position."""

    KIND = WHERE
    role: Role = field(name="r")
    child: int = field(name="c")
    child_role: Role = field(name="cr")
    child_pos: Point = field(name="cx")


BODIES = Bodies(State, LeaderInfo, Connect, Disconnect, Request, Ack, Nack, Target, Arrived, Help, Where)
KINDS = BODIES.kinds
