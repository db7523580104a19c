"""The robot side: behaviours, the runtime that steps them, and the host session that carries it over Zenoh.

* ``Behavior``, ``Context``, ``Frame``, ``Sensed`` (``swarmactors.behavior``): what a protocol writes and sees.
* ``Robot`` (``actor``): one robot's behaviours, context and hook order.
* ``RobotRuntime`` (``runtime``): a host's robots stepped from the world's inputs to their outputs, with no
  transport; what an in-process driver steps.
* ``HostSession`` (``session``): joins a world over Zenoh and drives a RobotRuntime with what travels on the
  wire (keys, sealing, registration, liveliness, realtime timers).
"""

from swarmactors.behavior import Behavior, Context, Frame, Sensed
from swarmactors.robot.actor import Robot, run_calls
from swarmactors.robot.inputs import FrameTable, SensedView
from swarmactors.robot.runtime import DueTimer, RobotRuntime
from swarmactors.robot.session import HostSession, WorldLost

__all__ = [
    "Behavior",
    "Context",
    "DueTimer",
    "Frame",
    "FrameTable",
    "HostSession",
    "Robot",
    "RobotRuntime",
    "Sensed",
    "SensedView",
    "WorldLost",
    "run_calls",
]
