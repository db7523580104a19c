"""The world process: clock, kinematics, radio medium, sensing, faults, registry."""

from transport.messages import DROP_CAUSES
from world.radio import Medium, Outgoing
from world.registry import Robots
from world.world import POS_DIGITS, World

__all__ = ["DROP_CAUSES", "POS_DIGITS", "Medium", "Outgoing", "Robots", "World"]
