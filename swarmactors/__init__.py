"""swarmactors: robot swarms as asynchronous actors over Eclipse Zenoh."""

from swarmactors.behavior import Behavior, Context, Frame, Sensed
from swarmactors.builder import Scenario
from swarmactors.checks import Outcome
from swarmactors.result import Result


def run(scenario, **kwargs) -> Result:
    """Run a scenario and return its Result (see ``swarmactors.launcher.run``)."""
    from swarmactors.launcher import run as _run

    return _run(scenario, **kwargs)


__all__ = ["Behavior", "Context", "Frame", "Outcome", "Result", "Scenario", "Sensed", "run"]
