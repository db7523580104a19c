"""The robot side: what a robot host process loads, and nothing more (numpy, msgspec, Zenoh; no oracle).

The lowest layer of the core: it imports neither ``swarmactors.oracle``, ``swarmactors.runs`` nor
``swarmactors.tools`` (a ``lint-imports`` contract checks it).

* ``Behavior``, ``Context``, ``Frame``, ``Sensed`` (``behavior``): what a protocol writes and sees; ``bodies``
  its typed frame bodies, ``knownmap`` the map a robot knows, ``robot_clock`` its own clock.
* ``Robot`` (``actor``): one robot's behaviours, context and hook order.
* ``RobotRuntime`` (``runtime``): a host's robots stepped from the world's inputs to their outputs, with no
  transport; what an in-process driver steps.
* ``HostSession`` (``session``): joins a world over Zenoh and drives a RobotRuntime with what travels on the
  wire (keys, sealing, registration, liveliness, realtime timers; ``precise_timer``, ``tasks``).
* ``hosting``: a robot-host process's entry point; ``host``: the host under its earlier names.
* ``family`` and ``plugins``: the protocol families and the registries of behaviours, checks and subcommands
  built from them, which a host reads to resolve a behaviour by name.

Names are imported on first use (PEP 562), so ``from swarmactors.robot.behavior import Behavior`` loads the
Behavior API without the host session and Zenoh.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from swarmactors._lazy import lazy_exports

if TYPE_CHECKING:
    from swarmactors.robot.actor import Robot, run_calls
    from swarmactors.robot.behavior import Behavior, Context, Frame, Sensed
    from swarmactors.robot.inputs import FrameTable, SensedView
    from swarmactors.robot.runtime import DueTimer, RobotRuntime
    from swarmactors.robot.session import HostSession, WorldLost

_HOME = {
    "Behavior": "swarmactors.robot.behavior",
    "Context": "swarmactors.robot.behavior",
    "Frame": "swarmactors.robot.behavior",
    "Sensed": "swarmactors.robot.behavior",
    "Robot": "swarmactors.robot.actor",
    "run_calls": "swarmactors.robot.actor",
    "FrameTable": "swarmactors.robot.inputs",
    "SensedView": "swarmactors.robot.inputs",
    "DueTimer": "swarmactors.robot.runtime",
    "RobotRuntime": "swarmactors.robot.runtime",
    "HostSession": "swarmactors.robot.session",
    "WorldLost": "swarmactors.robot.session",
}


__getattr__, __dir__ = lazy_exports(__name__, _HOME)


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
