"""Bursty loss: the Gilbert-Elliott channel, one per directed pair of robots.

Each directed pair (src, dst) is a two-state Markov chain, Good or Bad, that advances once per tick:
Good -> Bad with probability ``p_gb``, Bad -> Good with ``p_bg``. A frame heard in state s is lost with
probability ``loss_good`` or ``loss_bad``; frames of the same tick share the pair's state, so losses come in
bursts whose length in ticks is geometric with mean 1 / p_bg.

A pair is evaluated only at the ticks it carries a frame. Over the k ticks since its last evaluation the
state advances in closed form: with lambda = 1 - p_gb - p_bg and pi_B = p_gb / (p_gb + p_bg),

    P(Bad at t + k | s at t) = pi_B + (s - pi_B) * lambda**k        (s = 1 for Bad, 0 for Good),

and a pair's first state is drawn from the stationary distribution (Bad with pi_B). Each draw is keyed on
(seed, BURST, tick, src, dst) of the counter-based generator, so the states do not depend on the order in
which the world handles frames or on how robots are spread over host processes.
"""

from __future__ import annotations

import numpy as np

from world import rng


class GilbertElliott:
    """The per-pair channel states of one run; ``success(tick, src, receivers)`` gives decoding probabilities."""

    def __init__(self, seed: int, p_gb: float, p_bg: float, loss_good: float = 0.0, loss_bad: float = 1.0):
        self.seed = seed
        self.p_gb, self.p_bg = float(p_gb), float(p_bg)
        self.loss = (float(loss_good), float(loss_bad))
        total = self.p_gb + self.p_bg
        self.pi_bad = self.p_gb / total if total > 0 else 0.0
        self.lam = 1.0 - total
        self._state: dict[tuple[int, int], tuple[int, int]] = {}  # (src, dst) -> (tick evaluated, 1 if Bad)

    def stationary_loss(self) -> float:
        """The long-run fraction of frames lost: pi_G * loss_good + pi_B * loss_bad."""
        return (1.0 - self.pi_bad) * self.loss[0] + self.pi_bad * self.loss[1]

    def states(self, tick: int, src: int, receivers: np.ndarray) -> np.ndarray:
        """The state (1 = Bad) of each pair (src, r) at ``tick``, advancing each from its last evaluation."""
        receivers = np.asarray(receivers, dtype=np.int64)
        table = self._state
        rl = receivers.tolist()
        seen = [table.get((src, r)) for r in rl]
        out = np.array([-1 if x is None or x[0] != tick else x[1] for x in seen], dtype=np.int64)
        todo = np.flatnonzero(out < 0)  # frames of the same tick share the state: drawn once per tick
        if todo.size:
            u = rng.uniform(self.seed, rng.BURST, tick, src, receivers[todo]).tolist()
            pi, lam = self.pi_bad, self.lam
            for k, uk in zip(todo.tolist(), u, strict=True):
                x = seen[k]
                p_bad = pi if x is None else pi + (x[1] - pi) * lam ** (tick - x[0])
                s = int(uk < p_bad)
                table[(src, rl[k])] = (tick, s)
                out[k] = s
        return out

    def success_pairs(self, tick: int, src: np.ndarray, dst: np.ndarray) -> np.ndarray:
        """``success`` for pairs (src[k], dst[k]); a pair repeated in the batch (several frames) has one state."""
        src = np.asarray(src, dtype=np.int64)
        dst = np.asarray(dst, dtype=np.int64)
        s = np.zeros(len(src), dtype=np.int64)
        if len(src):
            pairs, back = np.unique(np.column_stack([src, dst]), axis=0, return_inverse=True)
            state = np.zeros(len(pairs), dtype=np.int64)
            cuts = np.flatnonzero(pairs[1:, 0] != pairs[:-1, 0]) + 1
            for rows in np.split(np.arange(len(pairs)), cuts):  # pairs are sorted by sender
                state[rows] = self.states(tick, int(pairs[rows[0], 0]), pairs[rows, 1])
            s = state[back.ravel()]
        return np.where(s == 1, 1.0 - self.loss[1], 1.0 - self.loss[0])

    def success(self, tick: int, src: int, receivers: np.ndarray) -> np.ndarray:
        """Per-receiver probability that a frame sent at ``tick`` is decoded: 1 - loss of the pair's state."""
        s = self.states(tick, src, receivers)
        return np.where(s == 1, 1.0 - self.loss[1], 1.0 - self.loss[0])
