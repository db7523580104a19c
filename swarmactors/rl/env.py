"""The swarm as a PettingZoo ``ParallelEnv``: each robot running ``RLBehavior`` is an agent (docs/rl.md).

The environment steps a lockstep run in this process (``swarmactors.runs.inprocess.InProcessRun``): the world's
``Simulation`` and the robots' runtimes, with nothing in between. One environment step is one tick, split where
the policy decides:

1. (``reset``, or the end of the previous step) the world begins the tick and every robot runs its hooks: an
   agent's ``RLBehavior`` builds its observation from what its robot sensed and received (robot side);
2. ``step(actions)``: each agent's behaviour acts (``ctx.move``, ``ctx.broadcast``) and its outputs join the rows
   of its robot's step; the world takes every row, its radio decides who hears each frame (range, latency,
   loss, cuts, bandwidth), motion is integrated; the next tick begins (1) and gives the next observations;
3. the task's reward is computed from the world's true state (``Truth``: oracle side).

Same scenario, same seed and the same actions give the same observations, rewards and trace.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from swarmactors.rl.behavior import CHANNELS, Observe, RLBehavior
from swarmactors.rl.tasks import Reward, Task, Truth, as_task
from swarmactors.runs.inprocess import InProcessRun
from swarmactors.runs.launcher import resolve_run
from transport.messages import RobotOut
from transport.scenario import Scenario

USE = ("rl", "swarmactors.rl.behavior:RLBehavior")  # the behaviour's names in a scenario
DEFAULT_OBSERVE = ("pose", "neighbors", "messages")


def parallel_env(scenario, **kwargs) -> SwarmEnv:
    """The swarm of ``scenario`` (a TOML path, a dict or a ``swarmactors.Scenario``) as a PettingZoo ParallelEnv.

    Keyword arguments: ``SwarmEnv``'s.
    """
    return SwarmEnv(scenario, **kwargs)


class SwarmEnv(ParallelEnv):
    """A lockstep scenario whose ``rl`` robots are agents (module docstring; docs/rl.md).

    Agents are ``"robot_<id>"``: the robots whose behaviours include ``use = "rl"``; when no group names it,
    every robot's behaviours are replaced by it. Other robots run their own behaviours.

    Observation (a ``spaces.Dict``, or one ``Box`` with ``flatten=True``), from ``observe`` (``CHANNELS``):

    * ``pose``: the robot's pose (x, y[, z], heading): world pose under global sensing, odometry under local;
    * ``neighbors``: (``neighbors``, dims + 1): range, bearing[, elevation] and 1 for each sensed robot,
      nearest first, zero rows after; bearings in the frame of the velocity command;
    * ``messages``: (``messages``, ``payload`` + 1): the payloads received since the last step and 1;
    * ``rays``: the obstacle rays' distances, capped at the sensing range (groups with ``obstacle_rays``);
    * ``objects``: (objects, dims + 1): the vector to each of the world's objects and 1, while the robot knows it
      (global sensing only).

    Action: a ``Box`` in [-1, 1] of dims (+ ``payload`` + 1 with messages): the velocity as a share of the
    robot's speed cap (``max_speed`` for groups without one), then the payload, then "send" (> 0 broadcasts).

    ``task``: ``"dispersion"``, ``"relay"``, a ``Task`` or a function ``reward(truth)`` (oracle side);
    ``max_steps``: steps per episode (default the scenario's ``run.ticks``); ``hosts``: robot runtimes (as
    ``--processes``); ``overrides`` and ``settings``: the scenario's, as ``swarmactors.run`` takes them.
    """

    metadata = {"name": "swarmactors_v0", "render_modes": [], "is_parallelizable": True}

    def __init__(self, scenario, *, task: Task | Callable[[Truth], Reward] | str | None = None,
                 observe: Sequence[str] = DEFAULT_OBSERVE, neighbors: int = 6, messages: int = 4,
                 payload: int = 4, max_steps: int | None = None, max_speed: float | None = None,
                 flatten: bool = False, hosts: int = 1, overrides: Sequence[str] = (), **settings):
        self.render_mode = None
        self._scenario = scenario
        self._overrides = list(overrides)
        self._settings = dict(settings)
        self._hosts = hosts
        sc = self._resolve(None)
        spec = Scenario.from_dict(sc)
        if spec.run.clock != "lockstep":
            raise ValueError(f"run.clock = {spec.run.clock!r}: the environment is lockstep only")
        self.seed0 = spec.run.seed
        self.dims = spec.world.dims
        self.bounds = np.array(spec.world.bounds, dtype=float) if spec.world.bounds else None
        self.objects = {o.name: np.array(o.pos, dtype=float) for o in spec.world.objects}
        robots = spec.robot_specs()
        self._ids = [i for i, r in enumerate(robots) if any(b.get("use") in USE for b in r.behaviors)]
        self.possible_agents = [f"robot_{i}" for i in self._ids]
        self.agent_ids = dict(zip(self.possible_agents, self._ids, strict=True))
        self.agents: list[str] = []
        self.max_steps = spec.run.ticks if max_steps is None else _count("max_steps", max_steps, 1)
        self.observer = self._observer(observe, neighbors, messages, payload, robots)
        self.payload = self.observer.payload if "messages" in self.observer.channels else 0
        self.flatten = bool(flatten)
        self._speed = {a: _speed(robots[i], max_speed, a) for a, i in self.agent_ids.items()}
        self._dict_spaces = {a: self._obs_space(robots[i]) for a, i in self.agent_ids.items()}
        self._obs_spaces = {a: spaces.flatten_space(s) if self.flatten else s for a, s in self._dict_spaces.items()}
        width = self.dims + (self.payload + 1 if self.payload else 0)
        self._act_spaces = {a: spaces.Box(-1.0, 1.0, (width,), np.float32) for a in self.possible_agents}
        self.task = as_task(task)
        self.task.check(self)
        self.run: InProcessRun | None = None
        self.truth: Truth | None = None
        self.episode_seed: int | None = None
        self._next_seed = self.seed0
        self._behaviors: dict[str, RLBehavior] = {}
        self._robots: dict[str, Any] = {}
        self._outs: dict[str, list[RobotOut]] = {}
        self._loop: asyncio.AbstractEventLoop | None = None
        self._pool: concurrent.futures.ThreadPoolExecutor | None = None
        lo = np.full(self.dims + 1, -np.inf)
        hi = np.full(self.dims + 1, np.inf)
        if self.bounds is not None:  # robots that move are kept inside the bounds
            lo[: self.dims], hi[: self.dims] = self.bounds[0][: self.dims], self.bounds[1][: self.dims]
        lo[-1], hi[-1] = -math.pi, math.pi
        self.state_space = spaces.Box(np.tile(lo, len(self._ids)).astype(np.float32),
                                      np.tile(hi, len(self._ids)).astype(np.float32), dtype=np.float32)

    # ------------------------------------------------------------ set-up
    def _resolve(self, seed: int | None) -> dict:
        settings = dict(self._settings)
        if seed is not None:
            settings["run__seed"] = seed
        sc = resolve_run(self._scenario, overrides=self._overrides, settings=settings)
        groups = sc.get("robots", [])
        if not any(b.get("use") in USE for g in groups for b in g.get("behaviors", [])):
            for g in groups:  # no group names the rl behaviour: every robot becomes an agent
                g["behaviors"] = [{"use": "rl"}]
        return sc

    def _observer(self, observe, neighbors, messages, payload, robots) -> Observe:
        if isinstance(observe, str):
            observe = (observe,)
        bad = [c for c in observe if c not in CHANNELS]
        if bad or not observe:
            raise ValueError(f"observe = {list(observe)!r}: give one or more of {', '.join(CHANNELS)}")
        agents = [robots[i] for i in self._ids]
        if not agents:
            raise ValueError("no robot runs the rl behaviour, so the environment has no agent")
        rays = 0
        if "rays" in observe:
            counts = {r.obstacle_rays for r in agents}
            if len(counts) != 1 or 0 in counts:
                raise ValueError(f"observe 'rays' needs every agent's group to have the same obstacle_rays > 0 "
                                 f"(they have {sorted(counts)})")
            rays = counts.pop()
        if "objects" in observe:
            if any(r.sensing_frame == "local" for r in agents):
                raise ValueError("observe 'objects' needs sensing_frame = \"global\" (objects are world positions)")
            if not self.objects:
                raise ValueError("observe 'objects' needs world.objects")
        return Observe(tuple(dict.fromkeys(observe)), _count("neighbors", neighbors, 0),
                       _count("messages", messages, 0), _count("payload", payload, 1 if "messages" in observe else 0),
                       rays, tuple(self.objects), self.dims)

    def _obs_space(self, robot) -> spaces.Dict:
        o, d = self.observer, self.dims
        sensing = float(robot.sensing)
        parts: dict[str, spaces.Space] = {}
        for name in o.channels:
            if name == "pose":
                parts[name] = spaces.Box(-np.inf, np.inf, (d + 1,), np.float32)
            elif name == "neighbors":
                lo = [0.0, -math.pi] + ([-math.pi / 2] if d == 3 else []) + [0.0]
                hi = [sensing, math.pi] + ([math.pi / 2] if d == 3 else []) + [1.0]
                parts[name] = spaces.Box(np.tile(np.array(lo, np.float32), (o.neighbors, 1)),
                                         np.tile(np.array(hi, np.float32), (o.neighbors, 1)), dtype=np.float32)
            elif name == "messages":
                parts[name] = spaces.Box(np.tile(np.array([-1.0] * o.payload + [0.0], np.float32), (o.messages, 1)),
                                         np.ones((o.messages, o.payload + 1), np.float32), dtype=np.float32)
            elif name == "rays":
                parts[name] = spaces.Box(0.0, sensing, (o.rays,), np.float32)
            else:
                lo = np.tile(np.array([-np.inf] * d + [0.0], np.float32), (len(o.objects), 1))
                hi = np.tile(np.array([np.inf] * d + [1.0], np.float32), (len(o.objects), 1))
                parts[name] = spaces.Box(lo, hi, dtype=np.float32)
        return spaces.Dict(parts)

    # ------------------------------------------------------------ the PettingZoo API
    def observation_space(self, agent: str) -> spaces.Space:
        return self._obs_spaces[self._known(agent)]

    def action_space(self, agent: str) -> spaces.Space:
        return self._act_spaces[self._known(agent)]

    def reset(self, seed: int | None = None, options: dict | None = None):
        """A new episode: ``seed`` is the scenario's ``run.seed`` for it (placement, radio, noise, robots' rngs).

        Without a seed, the first episode uses the scenario's own seed and each later one the next integer.
        ``options`` are not used.
        """
        if seed is not None:
            self._next_seed = _count("seed", seed, 0)
        self.episode_seed = self._next_seed
        self._next_seed += 1
        spec = Scenario.from_dict(self._resolve(self.episode_seed))
        self.run = InProcessRun(spec, hosts=self._hosts)
        self._robots, self._behaviors = {}, {}
        for runtime in self.run.runtimes.values():
            for rid, robot in runtime.robots.items():
                agent = f"robot_{rid}"
                if agent not in self.agent_ids:
                    continue
                if robot.error:
                    raise ValueError(f"agent {agent}: its robot could not be built: {robot.error}")
                b = next(b for b in robot.behaviors if isinstance(b, RLBehavior))
                b.observer = self.observer
                self._robots[agent], self._behaviors[agent] = robot, b
        self._outs = self._drive(self.run.robots_step())
        self.agents = [a for a in self.possible_agents if self._alive(a)]
        self.truth = self._truth({})
        self.task.reset(self.truth)
        metrics = self.task.metrics(self.truth)
        return ({a: self._observation(a) for a in self.agents},
                {a: {"tick": self.run.tick, "task": metrics} for a in self.agents})

    def step(self, actions: Mapping[str, Any]):
        """One tick: the agents' actions, the radio, motion; the next observations and the rewards."""
        if self.run is None:
            raise RuntimeError("step before reset")
        for agent in actions:
            self._known(agent)
        rows = {row.id: (host, k) for host, out in self._outs.items() for k, row in enumerate(out)}
        for agent in self.agents:
            robot = self._robots[agent]
            if not robot.alive:
                continue
            velocity, payload = self._decode(agent, actions.get(agent))
            self._behaviors[agent].act(velocity, payload)
            extra = robot.outputs()
            at = rows.get(robot.id)
            if at is None:
                self._outs.setdefault(self.run.sim.robots.host[robot.id], []).append(extra)
            else:
                host, k = at
                self._outs[host][k] = _merge(self._outs[host][k], extra)
        rec = self.run.world_step(self._outs)
        self._outs = self._drive(self.run.robots_step())
        self.truth = truth = self._truth(rec)
        done = self.task.done(truth)
        out_of_time = self.run.tick >= self.max_steps or self.run.sim.stop_request is not None
        agents = self.agents
        rewards = self._rewards(self.task.reward(truth), agents)
        terminated = {a: done or not self._alive(a) for a in agents}
        truncated = {a: out_of_time and not terminated[a] for a in agents}
        metrics = self.task.metrics(truth)
        obs = {a: self._observation(a) for a in agents}
        infos = {a: {"tick": self.run.tick, "task": metrics} for a in agents}
        self.agents = [a for a in agents if not (terminated[a] or truncated[a])]
        return obs, rewards, terminated, truncated, infos

    def state(self) -> np.ndarray:
        """The agents' true positions and headings (oracle side: for centralised critics, never for agents)."""
        if self.truth is None:
            raise RuntimeError("state before reset")
        t = self.truth
        return np.hstack([t.pos[self._ids], t.heading[self._ids][:, None]]).astype(np.float32).ravel()

    def close(self) -> None:
        if self._loop is not None:
            if self._pool is not None:
                self._pool.submit(self._loop.close).result()
                self._pool.shutdown()
            else:
                self._loop.close()
            self._loop, self._pool = None, None

    # ------------------------------------------------------------ inside
    def _known(self, agent: str) -> str:
        if agent not in self.agent_ids:
            raise ValueError(f"unknown agent {agent!r} (agents: robot_<id> of the rl robots, e.g. "
                             f"{', '.join(self.possible_agents[:3])})")
        return agent

    def _alive(self, agent: str) -> bool:
        rid = self.agent_ids[agent]
        return bool(self.run.sim.robots.alive[rid]) and self._robots[agent].alive

    def _decode(self, agent: str, action: Any) -> tuple[list[float], list[float] | None]:
        """An agent's action as (velocity, payload or None); no action: stand still, send nothing."""
        d = self.dims
        if action is None:
            return [0.0] * d, None
        a = np.asarray(action, dtype=np.float64).ravel()
        width = self._act_spaces[agent].shape[0]
        if a.shape != (width,) or not np.isfinite(a).all():
            raise ValueError(f"action of {agent}: {action!r} must be {width} finite numbers in [-1, 1] "
                             f"(velocity{', payload, send' if self.payload else ''})")
        a = np.clip(a, -1.0, 1.0)
        velocity = (a[:d] * self._speed[agent]).tolist()
        if not self.payload or a[-1] <= 0:
            return velocity, None
        return velocity, a[d:d + self.payload].tolist()

    def _observation(self, agent: str) -> Any:
        obs = self._behaviors[agent].observation
        return spaces.flatten(self._dict_spaces[agent], obs) if self.flatten else obs

    def _truth(self, rec: dict) -> Truth:
        sim = self.run.sim
        r = sim.robots
        return Truth(self.run.tick, r.pos.copy(), r.heading.copy(), r.alive.copy(), r.range.copy(), r.sensing.copy(),
                     {k: np.array(v, dtype=float) for k, v in sim.objects.items()},
                     None if sim.bounds is None else sim.bounds.copy(), dict(self.agent_ids), rec, sim)

    def _rewards(self, value: Reward, agents: list[str]) -> dict[str, float]:
        if isinstance(value, Mapping):
            return {a: float(value.get(a, 0.0)) for a in agents}
        arr = np.asarray(value, dtype=float)
        if arr.ndim == 0:
            return dict.fromkeys(agents, float(arr))
        if arr.shape == (len(self._ids),):  # by agent, in possible_agents order
            by_agent = dict(zip(self.possible_agents, arr.tolist(), strict=True))
            return {a: by_agent[a] for a in agents}
        if arr.ndim == 1 and len(arr) == len(self.run.sim.robots):  # by robot id
            return {a: float(arr[self.agent_ids[a]]) for a in agents}
        raise ValueError(f"task {self.task.name or self.task!r} returned a reward of shape {arr.shape}: give a "
                         f"number, a dict by agent, or one value per agent ({len(self._ids)}) or per robot")

    def _drive(self, coro):
        """Run a coroutine of the in-process run on this env's own event loop (in a thread if one already runs)."""
        if self._loop is None:
            self._loop = asyncio.new_event_loop()
        try:
            asyncio.get_running_loop()
        except RuntimeError:
            return self._loop.run_until_complete(coro)
        if self._pool is None:  # a notebook's loop runs in this thread: ours runs in one of its own
            self._pool = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="swarmactors-rl")
        return self._pool.submit(self._loop.run_until_complete, coro).result()


def _merge(a: RobotOut, b: RobotOut) -> RobotOut:
    """One robot's rows of one tick as one: its hooks' outputs, then the action's (velocity, frames)."""
    status = {**(a.status or {}), **(b.status or {})} or None
    return RobotOut(a.id, b.velocity if b.velocity is not None else a.velocity, [*a.frames, *b.frames], status,
                    a.error or b.error)


def _speed(robot, max_speed: float | None, agent: str) -> float:
    cap = robot.speed
    if max_speed is not None:
        if not (isinstance(max_speed, (int, float)) and math.isfinite(max_speed) and max_speed > 0):
            raise ValueError(f"max_speed = {max_speed!r}: give a finite number > 0")
        return float(max_speed) if cap is None else min(float(max_speed), float(cap))
    if cap is None:
        raise ValueError(f"agent {agent}: its group has no speed cap; give the group a speed or pass max_speed")
    return float(cap)


def _count(name: str, value: Any, least: int) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or value < least:
        raise ValueError(f"{name} = {value!r}: give an integer >= {least}")
    return value
