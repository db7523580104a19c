"""The world: a simulation core without I/O (world/sim.py) and the session that serves it over Zenoh."""

from transport.messages import DROP_CAUSES
from world.radio import Medium, Outgoing
from world.registry import Robots
from world.session import WorldSession
from world.sim import Simulation
from world.tables import POS_DIGITS

__all__ = ["DROP_CAUSES", "POS_DIGITS", "Medium", "Outgoing", "Robots", "Simulation", "WorldSession"]
