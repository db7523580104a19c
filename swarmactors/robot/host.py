"""The robot host under its earlier names: ``RobotHost`` is ``swarmactors.robot.HostSession``.

The robot side lives in ``swarmactors.robot``: ``Robot`` (``actor``), ``RobotRuntime`` (``runtime``, the robots
stepped from inputs to outputs) and ``HostSession`` (``session``, the Zenoh side). This module keeps the names
other code imports, and the realtime benchmark stamps (``RT_STAMPS``, ``RT_BATCH``: the same objects).
"""

from swarmactors.robot.actor import Robot, run_calls
from swarmactors.robot.inputs import FrameTable, SensedView, decode_body
from swarmactors.robot.runtime import RT_BATCH, RT_STAMPS, RobotRuntime
from swarmactors.robot.session import HostSession, WorldLost

RobotHost = HostSession

__all__ = ["RT_BATCH", "RT_STAMPS", "FrameTable", "HostSession", "Robot", "RobotHost", "RobotRuntime", "SensedView",
           "WorldLost", "decode_body", "run_calls"]
