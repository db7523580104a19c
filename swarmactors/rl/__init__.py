"""The swarm as a multi-agent reinforcement-learning environment (PettingZoo, Gymnasium spaces): docs/rl.md.

``swarmactors.rl.parallel_env(scenario, ...)`` needs the ``[rl]`` extra (pettingzoo, gymnasium), imported on
first use of the names below (PEP 562). ``swarmactors.rl.behavior`` (the robot side, ``use = "rl"``) imports
neither: a robot host loads it without the extra.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from swarmactors._lazy import lazy_exports

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


__getattr__, __dir__ = lazy_exports(__name__, _HOME)


__all__ = ["Dispersion", "GoalRelay", "Observe", "RLBehavior", "SwarmEnv", "Task", "Truth", "parallel_env"]
