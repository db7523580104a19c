"""Beacon's frame body (one kind, ``BEACON``), typed: the list ``[sent, payload]`` it always was."""

from __future__ import annotations

from swarmactors.robot.bodies import Bodies, Body, Num

KIND = "BEACON"


class BeaconBody(Body, array_like=True):
    """A beacon: the sender's clock when it sent it and ``size`` padding bytes."""

    KIND = KIND
    sent: Num  # the sender's ctx.now
    payload: bytes


BODIES = Bodies(BeaconBody)
