"""Rewards, on the oracle side: what an episode is for, judged from the world's true state.

A reward is computed by the environment, never by a robot: it may read every robot's true position, the radio
graph and the trace record (``Truth``), which no observation holds. A task is either a plain function
``reward(truth)`` or a ``Task`` (reward, plus an optional end and metrics). Two are built in:

* ``Dispersion`` (``task="dispersion"``): cover the world's bounds while staying connected;
* ``GoalRelay`` (``task="relay"``): gather at a goal that only robots near it can sense, so that the others
  learn where it is only through messages relayed by their neighbours.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from swarmactors.runs.scenario import mutual_links


@dataclass(frozen=True)
class Truth:
    """The world's true state after a step: for rewards, metrics and centralised critics, never for agents.

    ``tick``: the tick the robots observe now; ``pos`` (N, dims), ``heading``, ``alive``, ``range`` (radio),
    ``sensing``: every robot's, by robot id (copies); ``objects``: name -> position; ``bounds``: the world's box
    or None; ``agents``: agent name -> robot id; ``record``: the trace record of the tick just ended (frames
    sent, deliveries, drops by cause: docs/trace.md); ``sim``: the simulation itself, for anything else.
    """

    tick: int
    pos: np.ndarray
    heading: np.ndarray
    alive: np.ndarray
    range: np.ndarray
    sensing: np.ndarray
    objects: dict[str, np.ndarray]
    bounds: np.ndarray | None
    agents: dict[str, int]
    record: dict
    sim: Any

    def agent_pos(self) -> np.ndarray:
        """The agents' true positions, in the order of ``agents``."""
        return self.pos[list(self.agents.values())]

    def links(self, ids: list[int] | None = None) -> list[tuple[int, int]]:
        """Mutual radio links (a, b), a < b, between the alive robots of ``ids`` (default: the agents), by robot id.

        The world's own rule (each within the other's range; ``swarmactors.runs.scenario.mutual_links``), without
        occlusion, cuts or loss.
        """
        ids = [i for i in (list(self.agents.values()) if ids is None else ids) if self.alive[i]]
        pairs = mutual_links(self.pos[ids], self.range[ids])
        return [(ids[a], ids[b]) for a, b in pairs]

    def largest_component(self, ids: list[int] | None = None) -> float:
        """The share of ``ids`` (default: the agents) in the largest component of their alive mutual links."""
        ids = list(self.agents.values()) if ids is None else ids
        live = [i for i in ids if self.alive[i]]
        if not ids or not live:
            return 0.0
        index = {rid: k for k, rid in enumerate(live)}
        pairs = self.links(live)
        a = [index[x] for x, _ in pairs]
        b = [index[y] for _, y in pairs]
        graph = coo_matrix((np.ones(len(a)), (a, b)), shape=(len(live), len(live)))
        _, labels = connected_components(graph, directed=False)
        return float(np.bincount(labels).max()) / len(ids)


Reward = float | Mapping[str, float] | np.ndarray  # one for all agents, by agent name, or by robot id


class Task:
    """What an episode is for (oracle side). Subclass and override ``reward``; the rest is optional."""

    name = ""

    def check(self, env: Any) -> None:
        """Refuse an environment this task cannot judge (``ValueError`` naming what is missing)."""

    def reset(self, truth: Truth) -> None:
        """A new episode starts (``truth`` at its first tick)."""

    def reward(self, truth: Truth) -> Reward:
        return 0.0

    def done(self, truth: Truth) -> bool:
        """Whether the task is over (every agent terminates)."""
        return False

    def metrics(self, truth: Truth) -> dict[str, float]:
        """Numbers for each agent's ``info["task"]``."""
        return {}


class FunctionTask(Task):
    """A plain ``reward(truth)`` function as a task."""

    def __init__(self, fn: Callable[[Truth], Reward]):
        self.fn = fn
        self.name = getattr(fn, "__name__", "reward")

    def reward(self, truth: Truth) -> Reward:
        return self.fn(truth)


class Dispersion(Task):
    """Cover the world's bounds while staying connected (a shared reward).

    Reward each step: the share of the bounds within ``radius`` of an alive agent (judged on a grid of
    ``cells`` x ``cells`` points), times the share of agents in the largest component of their radio graph when
    ``connected`` (so spreading beyond radio range does not pay). Metrics: ``coverage``, ``component``.
    """

    name = "dispersion"

    def __init__(self, radius: float | None = None, cells: int = 40, connected: bool = True):
        if radius is not None and not (isinstance(radius, (int, float)) and radius > 0):
            raise ValueError(f"Dispersion radius = {radius!r}: give a number > 0 (or None: half the sensing range)")
        if not (isinstance(cells, int) and 2 <= cells <= 1000):
            raise ValueError(f"Dispersion cells = {cells!r}: give an integer in 2..1000")
        self.radius, self.cells, self.connected = radius, cells, connected
        self._grid: np.ndarray | None = None
        self._last: tuple[Truth, dict[str, float]] | None = None

    def check(self, env: Any) -> None:
        if env.bounds is None:
            raise ValueError("task 'dispersion' needs world.bounds (the area to cover)")

    def _points(self, truth: Truth) -> np.ndarray:
        if self._grid is None:
            lo, hi = truth.bounds[0][:2], truth.bounds[1][:2]
            axes = [lo[k] + (np.arange(self.cells) + 0.5) * (hi[k] - lo[k]) / self.cells for k in range(2)]
            gx, gy = np.meshgrid(*axes)
            self._grid = np.column_stack([gx.ravel(), gy.ravel()])
        return self._grid

    def metrics(self, truth: Truth) -> dict[str, float]:
        if self._last is not None and self._last[0] is truth:  # reward and metrics of one step: computed once
            return self._last[1]
        ids = [i for i in truth.agents.values() if truth.alive[i]]
        if not ids:
            return {"coverage": 0.0, "component": 0.0}
        pts = self._points(truth)
        radius = truth.sensing[ids] / 2 if self.radius is None else np.full(len(ids), float(self.radius))
        pos = truth.pos[ids][:, :2]
        if radius.min() == radius.max():  # the nearest agent of each grid point, from a k-d tree
            r = float(radius[0])
            dist, _ = cKDTree(pos).query(pts, distance_upper_bound=r * (1 + 1e-9) + 1e-12)
            covered = float((dist <= r).mean())
        else:
            d2 = ((pts[:, None, :] - pos[None, :, :]) ** 2).sum(axis=2)
            covered = float((d2 <= radius[None, :] ** 2).any(axis=1).mean())
        out = {"coverage": covered, "component": truth.largest_component()}
        self._last = (truth, out)
        return out

    def reward(self, truth: Truth) -> Reward:
        m = self.metrics(truth)
        return m["coverage"] * (m["component"] if self.connected else 1.0)


class GoalRelay(Task):
    """Gather at a goal that only robots near it sense: the others learn where it is only through messages.

    The scenario names an object ``goal`` (default ``"goal"``) with ``known_by = "sensing"``: a robot knows it
    while the goal is within its sensing range. Reward per agent each step: minus its distance to the goal,
    divided by the bounds' diagonal (or 1 without bounds). Done when every alive agent is within ``radius`` of
    it. Metrics: ``at_goal`` (the share of agents within ``radius``), ``mean_distance``.
    """

    name = "relay"

    def __init__(self, goal: str = "goal", radius: float = 1.0):
        if not (isinstance(radius, (int, float)) and radius > 0):
            raise ValueError(f"GoalRelay radius = {radius!r}: give a number > 0")
        self.goal, self.radius = goal, float(radius)

    def check(self, env: Any) -> None:
        if self.goal not in env.objects:
            known = ", ".join(env.objects) or "none"
            raise ValueError(f"task 'relay' needs an object named {self.goal!r} in world.objects (objects: {known})")

    def _dist(self, truth: Truth) -> np.ndarray:
        g = np.zeros(truth.pos.shape[1])
        at = truth.objects[self.goal]
        g[: len(at)] = at[: len(g)]
        return np.linalg.norm(truth.agent_pos() - g, axis=1)

    def reward(self, truth: Truth) -> Reward:
        scale = 1.0 if truth.bounds is None else float(np.linalg.norm(truth.bounds[1] - truth.bounds[0]))
        return -self._dist(truth) / scale

    def done(self, truth: Truth) -> bool:
        alive = truth.alive[list(truth.agents.values())]
        return bool(alive.any() and (self._dist(truth)[alive] <= self.radius).all())

    def metrics(self, truth: Truth) -> dict[str, float]:
        d = self._dist(truth)
        return {"at_goal": float((d <= self.radius).mean()), "mean_distance": float(d.mean())}


TASKS: dict[str, type[Task]] = {"dispersion": Dispersion, "relay": GoalRelay}


def as_task(task: Task | Callable[[Truth], Reward] | str | None) -> Task:
    """A task from a built-in's name, a ``Task``, a reward function, or None (a reward of 0)."""
    if task is None:
        return Task()
    if isinstance(task, Task):
        return task
    if isinstance(task, str):
        cls = TASKS.get(task)
        if cls is None:
            raise ValueError(f"task {task!r} is not one of {', '.join(TASKS)} (or pass a Task or a function)")
        return cls()
    if callable(task):
        return FunctionTask(task)
    raise ValueError(f"task {task!r}: give a built-in's name ({', '.join(TASKS)}), a Task or a function of Truth")
