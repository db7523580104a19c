"""The world: a simulation core without I/O (world/sim.py) and the session that serves it over Zenoh."""

from world.linkrules import DROP_CAUSES, LinkRule, Transmissions
from world.radio import Medium, Outgoing
from world.registry import Robots
from world.session import WorldSession
from world.sim import Simulation
from world.tables import POS_DIGITS

__all__ = ["DROP_CAUSES", "POS_DIGITS", "LinkRule", "Medium", "Outgoing", "Robots", "Simulation", "Transmissions",
           "WorldSession"]
