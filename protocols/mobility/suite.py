"""Mobility models as a family: random waypoint and a reflecting random walk (behaviours only, no oracle)."""

from __future__ import annotations

from swarmactors.robot.family import Family

FAMILY = Family(name="mobility", behaviors={"random_waypoint": "protocols.mobility.behavior:RandomWaypoint",
                                            "random_walk": "protocols.mobility.behavior:RandomWalk"})
