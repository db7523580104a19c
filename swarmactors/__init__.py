"""swarmactors: robot swarms as asynchronous actors over Eclipse Zenoh.

Names are imported on first use (PEP 562), so ``from swarmactors import Behavior`` in a robot host loads the
Behavior API only: neither the oracle (``Result``, networkx) nor scipy.

The core is in layers, each importing only those below it: ``swarmactors.tools`` (viewer, replay, plots, export,
sweeps) above ``swarmactors.runs`` (scenarios, launcher, conformance kit) above ``swarmactors.oracle`` (trace,
result, checks) above ``swarmactors.robot`` (what a robot host loads). The flat module paths of earlier
releases still import, with a DeprecationWarning, for one more release (``swarmactors._moved``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from swarmactors import _moved
from swarmactors._lazy import lazy_exports

_moved.install()

if TYPE_CHECKING:
    from swarmactors.oracle.checks import Outcome
    from swarmactors.oracle.result import Result
    from swarmactors.robot.behavior import Behavior, Context, Frame, Sensed
    from swarmactors.runs.builder import Scenario

_HOME = {
    "Behavior": "swarmactors.robot.behavior",
    "Context": "swarmactors.robot.behavior",
    "Frame": "swarmactors.robot.behavior",
    "Sensed": "swarmactors.robot.behavior",
    "Scenario": "swarmactors.runs.builder",
    "Outcome": "swarmactors.oracle.checks",
    "Result": "swarmactors.oracle.result",
}


__getattr__, __dir__ = lazy_exports(__name__, _HOME)


def run(scenario, **kwargs) -> Result:
    """Run a scenario and return its Result (see ``swarmactors.runs.launcher.run``)."""
    from swarmactors.runs.launcher import run as _run

    return _run(scenario, **kwargs)


async def arun(scenario, **kwargs) -> Result:
    """Run a scenario from inside a running event loop (a notebook); see ``swarmactors.tools.notebook.arun``."""
    from swarmactors.tools.notebook import arun as _arun

    return await _arun(scenario, **kwargs)


__all__ = ["Behavior", "Context", "Frame", "Outcome", "Result", "Scenario", "Sensed", "arun", "run"]
