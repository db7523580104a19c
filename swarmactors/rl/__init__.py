"""The swarm as a multi-agent reinforcement-learning environment (PettingZoo, Gymnasium spaces): docs/rl.md.

``swarmactors.rl.parallel_env(scenario, ...)`` needs the ``[rl]`` extra (pettingzoo, gymnasium), imported on
first use of the names below (PEP 562). ``swarmactors.rl.behavior`` (the robot side, ``use = "rl"``) imports
neither: a robot host loads it without the extra.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from swarmactors.rl.behavior import Observe, RLBehavior
    from swarmactors.rl.env import SwarmEnv, parallel_env
    from swarmactors.rl.tasks import Dispersion, GoalRelay, Task, Truth

_HOME = {
    "parallel_env": "swarmactors.rl.env",
    "SwarmEnv": "swarmactors.rl.env",
    "RLBehavior": "swarmactors.rl.behavior",
    "Observe": "swarmactors.rl.behavior",
    "Task": "swarmactors.rl.tasks",
    "Truth": "swarmactors.rl.tasks",
    "Dispersion": "swarmactors.rl.tasks",
    "GoalRelay": "swarmactors.rl.tasks",
}


def __getattr__(name: str):
    home = _HOME.get(name)
    if home is None:
        raise AttributeError(f"module 'swarmactors.rl' has no attribute {name!r}")
    value = getattr(importlib.import_module(home), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_HOME])


__all__ = ["Dispersion", "GoalRelay", "Observe", "RLBehavior", "SwarmEnv", "Task", "Truth", "parallel_env"]
