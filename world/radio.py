"""The radio medium: who hears a frame, when, and whether.

Rules (DESIGN.md, "Radio medium"), applied once per frame from the positions
at the send tick:

* range - a disk of the *transmitter's* radius, so heterogeneous ranges give
  directed links; a broadcast reaches every alive robot in range except the
  sender and the frame's ``exclude`` list, an addressed frame only its
  destination and only if in range (else dropped as ``range``);
* cuts and partitions - a frame over a cut link or between partition groups is
  dropped as ``cut``;
* occlusion - with ``radio.occlusion``, a frame to a receiver in range that an
  obstacle hides from the sender (world/space.py) is dropped as ``occluded``;
* bandwidth - an optional cap of bytes per robot per tick; frames past it, in
  sending order, are dropped as ``bandwidth`` for every receiver;
* loss - per (frame, receiver), from the counter-based generator:
  ``bernoulli`` loses with probability ``loss``; ``distance`` is Swarm Relays
  Sec. III-A: the receiver decodes with e = 1 when d < delta, exp(-delta*d/Z)
  otherwise (Z the transmitter's range), then ``loss`` applies on top;
  ``loss_model = "gilbert"`` (world/bursts.py) replaces ``loss`` by the
  Gilbert-Elliott state of the (src, dst) pair, multiplied with the
  distance model's probability where both are on;
* latency - lockstep: exactly ``latency`` ticks; realtime: drawn uniformly in
  [latency_min_s, latency_s] seconds per (frame, receiver).

A frame still in the air when its receiver dies is dropped as ``dead`` at
delivery time (by the world, not here).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import repeat

import numpy as np

from world import rng
from world.bursts import GilbertElliott


@dataclass
class RadioConfig:
    """The ``[radio]`` section, resolved."""

    range: float = 1.0
    latency: int = 1
    latency_s: float = 0.01
    latency_min_s: float | None = None
    loss: float = 0.0
    model: str = "bernoulli"
    delta: float = 0.1
    bandwidth: int = 0  # bytes per robot per tick; 0 = unlimited
    occlusion: bool = False  # obstacles block links (world/space.py)
    loss_model: str = "bernoulli"  # or "gilbert" (world/bursts.py): bursts replace the Bernoulli ``loss``
    p_gb: float | None = None
    p_bg: float | None = None
    loss_good: float = 0.0
    loss_bad: float = 1.0
    rab: bool = False  # frames carry the receiver's range and bearing (world/situated.py)

    @classmethod
    def from_dict(cls, data: dict) -> RadioConfig:
        fields = {k: v for k, v in data.items() if k in cls.__dataclass_fields__}
        return cls(**fields)

    @property
    def c_min_s(self) -> float:
        return self.latency_s if self.latency_min_s is None else self.latency_min_s


@dataclass(slots=True)
class Outgoing:
    """One frame as the world sees it: header plus opaque body bytes."""

    src: int
    dst: int | None
    kind: str
    seq: int
    body: bytes
    exclude: tuple[int, ...] = ()
    at: float | None = None  # realtime: the sender's wall time when it radioed the frame (FrameOut.at)


class Medium:
    """Decides receivers and drops for the frames of one tick."""

    def __init__(self, config: RadioConfig, seed: int):
        self.config = config
        self.seed = seed
        self.cuts: set[tuple[int, int]] = set()
        self.group: dict[int, int] = {}  # robot -> partition group; absent = group 0
        self._budget: dict[int, int] = {}  # bytes sent this tick, per robot (bandwidth cap)
        self._budget_tick = -1
        self.bursts = (GilbertElliott(seed, config.p_gb, config.p_bg, config.loss_good, config.loss_bad)
                       if config.loss_model == "gilbert" else None)

    def set_loss(self, loss: float) -> None:
        if self.bursts is not None:
            raise ValueError("loss: the radio's loss_model is \"gilbert\" (its bursts replace the Bernoulli loss)")
        self.config.loss = loss

    def cut(self, a: int, b: int) -> None:
        self.cuts.add((min(a, b), max(a, b)))

    def restore(self, a: int, b: int) -> None:
        self.cuts.discard((min(a, b), max(a, b)))

    def partition(self, groups: list[list[int]]) -> None:
        self.group = {r: g + 1 for g, members in enumerate(groups) for r in members}

    def heal(self) -> None:
        self.cuts.clear()
        self.group.clear()

    def _severed(self, src: int, dst: int) -> bool:
        if self.cuts and (min(src, dst), max(src, dst)) in self.cuts:
            return True
        return bool(self.group) and self.group.get(src, 0) != self.group.get(dst, 0)

    def decide(
        self,
        tick: int,
        frames: list[Outgoing],
        in_range: dict[int, np.ndarray],
        alive: np.ndarray,
        positions: np.ndarray,
        ranges: np.ndarray,
        occluded: dict[int, np.ndarray] | None = None,
    ) -> tuple[list[tuple], list[tuple[int, int, int, str, str]]]:
        """Return ``(deliveries, drops)`` for frames sent at ``tick``.

        ``in_range[src]`` lists the alive robots within ``src``'s range (sorted); ``occluded[src]``, for a sender
        an obstacle cuts off from some of them, is ``(heard, hidden)``: that list split by occlusion.
        A delivery is ``(receiver, src, seq, frame, tick)``; a drop is
        ``(src, seq, dst, kind, cause)``.
        """
        cfg = self.config
        deliveries: list[tuple] = []
        drops: list[tuple[int, int, int, str, str]] = []
        if tick != self._budget_tick:  # the cap is per tick, however many uplinks carry the tick's frames
            self._budget_tick, self._budget = tick, {}
        budget = self._budget
        n = len(alive)
        for f in frames:
            split = occluded.get(f.src) if occluded else None
            if f.dst is None:
                receivers = in_range[f.src] if split is None else split[0]
                if f.exclude:
                    receivers = receivers[~np.isin(receivers, f.exclude)]
                if split is not None:
                    hidden = split[1][~np.isin(split[1], f.exclude)] if f.exclude else split[1]
                    drops.extend((f.src, f.seq, r, f.kind, "occluded") for r in hidden.tolist())
            else:
                d = f.dst
                if not (0 <= d < n) or not alive[d]:
                    drops.append((f.src, f.seq, d, f.kind, "dead"))
                    continue
                if np.linalg.norm(positions[d] - positions[f.src]) > ranges[f.src]:
                    drops.append((f.src, f.seq, d, f.kind, "range"))
                    continue
                if split is not None and (split[1] == d).any():
                    drops.append((f.src, f.seq, d, f.kind, "occluded"))
                    continue
                receivers = np.array([d], dtype=np.int64)
            if receivers.size == 0:
                continue
            if cfg.bandwidth:
                used = budget.get(f.src, 0) + len(f.body)
                budget[f.src] = used
                if used > cfg.bandwidth:
                    drops.extend((f.src, f.seq, int(r), f.kind, "bandwidth") for r in receivers)
                    continue
            if self.cuts or self.group:
                severed = np.array([self._severed(f.src, int(r)) for r in receivers])
                drops.extend((f.src, f.seq, int(r), f.kind, "cut") for r in receivers[severed])
                receivers = receivers[~severed]
            p_ok = self._success_probability(tick, f.src, receivers, positions, ranges)
            if p_ok is not None:
                if ((p_ok == 0.0) | (p_ok == 1.0)).all():  # certain outcomes need no draw (u is in [0, 1))
                    lost = p_ok == 0.0
                else:
                    lost = rng.uniform(self.seed, rng.LOSS, tick, f.src, f.seq, receivers) >= p_ok
                if lost.any():
                    drops.extend((f.src, f.seq, int(r), f.kind, "loss") for r in receivers[lost])
                    receivers = receivers[~lost]
            deliveries.extend(zip(receivers.tolist(), repeat(f.src), repeat(f.seq), repeat(f), repeat(tick)))
        return deliveries, drops

    def _success_probability(self, tick, src, receivers, positions, ranges):
        """Per-receiver decoding probability, or None when every frame gets through."""
        cfg = self.config
        keep = (1.0 - cfg.loss) if self.bursts is None else self.bursts.success(tick, src, receivers)
        if cfg.model == "distance":
            d = np.linalg.norm(positions[receivers] - positions[src], axis=1)
            e = np.where(d < cfg.delta, 1.0, np.exp(-cfg.delta * d / ranges[src]))
            return e * keep
        if self.bursts is not None:
            return keep
        if cfg.loss > 0.0:
            return np.full(len(receivers), 1.0 - cfg.loss)
        return None

    def latencies_s(self, tick: int, src: int, seq: int, receivers: np.ndarray) -> np.ndarray:
        """Realtime latency per receiver, uniform in [latency_min_s, latency_s]."""
        lo, hi = self.config.c_min_s, self.config.latency_s
        if hi <= lo:
            return np.full(len(receivers), hi)
        return lo + (hi - lo) * rng.uniform(self.seed, rng.LATENCY, tick, src, seq, receivers)
