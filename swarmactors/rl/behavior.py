"""The robot side of the reinforcement-learning environment: a behaviour that observes and acts for a policy.

``RLBehavior`` (registered as ``use = "rl"``) is an ordinary behaviour: it runs in a robot's context like any
other, sees only what its robot senses and receives, and acts through ``ctx.move`` and ``ctx.broadcast``. Each
tick its ``on_tick`` turns what the robot knows into an observation (``Observe.observe``): its pose (odometry
under local sensing), the range and bearing of the neighbours it senses, the payloads of the ``"rl"`` frames it
received since its last observation, its obstacle rays and the objects it knows. Never the world's true state:
that stays with the environment's reward (swarmactors/rl/tasks.py).

The environment (swarmactors/rl/env.py) attaches an ``Observe`` to each agent's behaviour and, once the policy
has chosen, calls ``act``: a velocity command and, optionally, a payload to broadcast. Without an environment
(a scenario run by ``swarmactors run``), the behaviour observes nothing and its robot stands still.

This module imports numpy and the Behavior API only: a robot host loads it without the ``[rl]`` extra.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from swarmactors.robot.behavior import Behavior, Context, Frame

KIND = "rl"  # the message kind of payloads broadcast by ``act``
CHANNELS = ("pose", "neighbors", "messages", "rays", "objects")  # what an observation may hold


@dataclass(frozen=True)
class Observe:
    """What an agent's observation holds, and its fixed sizes (the same for every agent of an environment).

    ``channels``: a subset of ``CHANNELS``; ``neighbors``: how many sensed robots (nearest first); ``messages``:
    how many received payloads; ``payload``: floats per payload; ``rays``: obstacle rays; ``objects``: the names
    of the world's objects, in order; ``dims``: the world's dimensions.
    """

    channels: tuple[str, ...]
    neighbors: int
    messages: int
    payload: int
    rays: int
    objects: tuple[str, ...]
    dims: int

    def observe(self, ctx: Context, sensed: Any, inbox: list[Frame]) -> dict[str, np.ndarray]:
        """One observation, from the robot's context, what it sensed this tick and the payloads it received.

        Vectors and bearings are in the frame of the robot's velocity commands: the world's under global
        sensing, the robot's odometry frame under local sensing.
        """
        out: dict[str, np.ndarray] = {}
        for name in self.channels:
            if name == "pose":
                out[name] = np.asarray(ctx.pose, dtype=np.float32)
            elif name == "neighbors":
                out[name] = self._neighbors(ctx, sensed)
            elif name == "messages":
                out[name] = self._messages(ctx, inbox)
            elif name == "rays":
                rays = np.full(self.rays, ctx.sensing, dtype=np.float32)
                if ctx.rays:
                    rays[:] = np.minimum(np.asarray(ctx.rays[: self.rays], dtype=np.float64), ctx.sensing)
                out[name] = rays
            else:
                out[name] = self._objects(ctx)
        return out

    def _neighbors(self, ctx: Context, sensed: Any) -> np.ndarray:
        """Rows (range, bearing[, elevation], 1) of the nearest sensed robots, nearest first; zero rows after."""
        d = self.dims
        rows = np.zeros((self.neighbors, d + 1), dtype=np.float32)
        if not len(sensed) or not self.neighbors:
            return rows
        vec = sensed.positions() if hasattr(sensed, "positions") else np.array([s.pos for s in sensed])
        if ctx.sensing_frame == "local":  # body frame -> odometry frame (the frame of ctx.move)
            h = float(ctx.pose[-1])
            c, s = math.cos(h), math.sin(h)
            x, y = vec[:, 0].copy(), vec[:, 1].copy()
            vec = vec.copy()
            vec[:, 0], vec[:, 1] = c * x - s * y, s * x + c * y
        else:
            vec = vec - np.asarray(ctx.position, dtype=float)
        rng = np.linalg.norm(vec, axis=1)
        order = np.argsort(rng, kind="stable")[: self.neighbors]
        k = len(order)
        rows[:k, 0] = np.minimum(rng[order], ctx.sensing)
        rows[:k, 1] = np.arctan2(vec[order, 1], vec[order, 0])
        if d == 3:
            rows[:k, 2] = np.arctan2(vec[order, 2], np.hypot(vec[order, 0], vec[order, 1]))
        rows[:k, d] = 1.0
        return rows

    def _messages(self, ctx: Context, inbox: list[Frame]) -> np.ndarray:
        """Rows (payload..., 1) of the payloads received, in (sender, seq) order; a random subset if too many."""
        p = self.payload
        rows = np.zeros((self.messages, p + 1), dtype=np.float32)
        bodies = [f.body for f in inbox if type(f.body) is list and len(f.body) == p]
        if not bodies or not self.messages:
            return rows
        try:
            got = np.array(bodies, dtype=np.float64)
        except (TypeError, ValueError):  # another robot may send anything: keep the payloads of numbers
            got = np.array([b for b in bodies if _payload_ok(b, p)], dtype=np.float64).reshape(-1, p)
        got = got[np.isfinite(got).all(axis=1)]
        if len(got) > self.messages:  # the robot's own generator: deterministic for a seed
            got = got[np.sort(ctx.rng.choice(len(got), self.messages, replace=False))]
        rows[: len(got), :p] = np.clip(got, -1.0, 1.0)
        rows[: len(got), p] = 1.0
        return rows

    def _objects(self, ctx: Context) -> np.ndarray:
        """Rows (vector to the object..., known) for each of the world's objects; zeros for the unknown ones."""
        d = self.dims
        rows = np.zeros((len(self.objects), d + 1), dtype=np.float32)
        pos = np.asarray(ctx.position, dtype=float)
        for i, name in enumerate(self.objects):
            at = ctx.objects.get(name)
            if at is not None:
                obj = np.zeros(d)
                obj[: min(d, len(at))] = at[:d]
                rows[i, :d] = obj - pos
                rows[i, d] = 1.0
        return rows


def _payload_ok(body: Any, size: int) -> bool:
    """Whether a received body is a payload of ``size`` finite numbers (another robot may send anything)."""
    return (isinstance(body, list) and len(body) == size
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in body))


class RLBehavior(Behavior):
    """A robot driven by a policy through ``swarmactors.rl.parallel_env`` (module docstring).

    Parameters: none (the environment configures it). Report: ticks observed, payloads sent and heard.
    """

    name = "rl"
    kinds = (KIND,)
    frames = ("global", "local")

    def __init__(self):
        self.observer: Observe | None = None  # set by the environment
        self.observation: dict[str, np.ndarray] | None = None
        self._ctx: Context | None = None
        self._inbox: list[Frame] = []
        self.observed = 0
        self.sent = 0
        self.heard = 0

    def on_frame(self, ctx: Context, frame: Frame) -> None:
        self._inbox.append(frame)
        self.heard += 1

    def on_tick(self, ctx: Context, sensed) -> None:
        self._ctx = ctx
        if self.observer is not None:
            self.observation = self.observer.observe(ctx, sensed, self._inbox)
            self.observed += 1
        self._inbox = []

    def act(self, velocity: list[float], payload: list[float] | None = None) -> None:
        """This tick's command: move at ``velocity``; broadcast ``payload`` (a list of floats) unless None."""
        ctx = self._ctx
        if ctx is None:
            raise RuntimeError("RLBehavior.act before the robot's first tick")
        ctx.move(velocity)
        if payload is not None:
            ctx.broadcast(KIND, payload)
            self.sent += 1

    def report(self) -> dict:
        return {"observed": self.observed, "sent": self.sent, "heard": self.heard}
