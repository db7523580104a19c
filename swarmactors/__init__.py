"""swarmactors: robot swarms as asynchronous actors over Eclipse Zenoh."""

from swarmactors.behavior import Behavior, Context, Frame, Sensed
from swarmactors.checks import Outcome
from swarmactors.result import Result

__all__ = ["Behavior", "Context", "Frame", "Outcome", "Result", "Sensed"]
