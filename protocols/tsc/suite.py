"""The task scheduler as a family: the ``swarmactors schedule`` subcommand (no behaviour, no check, no suite)."""

from __future__ import annotations

from swarmactors.robot.family import Family

FAMILY = Family(name="tsc", commands={"schedule": "protocols.tsc.schedule_cli"},
                description="Panerati et al.'s Task Scheduling Controller (TCTM/TDSM MILPs): swarmactors schedule")
