"""swarmactors: robot swarms as asynchronous actors over Eclipse Zenoh.

Names are imported on first use (PEP 562), so ``from swarmactors import Behavior`` in a robot host loads the
Behavior API only: neither the oracle (``Result``, networkx) nor scipy.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from swarmactors.behavior import Behavior, Context, Frame, Sensed
    from swarmactors.builder import Scenario
    from swarmactors.checks import Outcome
    from swarmactors.result import Result

_HOME = {
    "Behavior": "swarmactors.behavior",
    "Context": "swarmactors.behavior",
    "Frame": "swarmactors.behavior",
    "Sensed": "swarmactors.behavior",
    "Scenario": "swarmactors.builder",
    "Outcome": "swarmactors.checks",
    "Result": "swarmactors.result",
}


def __getattr__(name: str):
    home = _HOME.get(name)
    if home is None:
        raise AttributeError(f"module 'swarmactors' has no attribute {name!r}")
    value = getattr(importlib.import_module(home), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_HOME])


def run(scenario, **kwargs) -> Result:
    """Run a scenario and return its Result (see ``swarmactors.launcher.run``)."""
    from swarmactors.launcher import run as _run

    return _run(scenario, **kwargs)


async def arun(scenario, **kwargs) -> Result:
    """Run a scenario from inside a running event loop (a notebook); see ``swarmactors.notebook.arun``."""
    from swarmactors.notebook import arun as _arun

    return await _arun(scenario, **kwargs)


__all__ = ["Behavior", "Context", "Frame", "Outcome", "Result", "Scenario", "Sensed", "arun", "run"]
