"""Beacons as a family: the behaviour only (the workload of the benchmarks and the radio tests; no oracle)."""

from __future__ import annotations

from swarmactors.robot.family import Family

FAMILY = Family(name="beacon", behaviors={"beacon": "protocols.beacon.behavior:Beacon"})
