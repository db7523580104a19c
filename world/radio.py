"""The radio medium: who hears a frame, when, and whether (DESIGN.md, "Radio medium").

Decided once per frame from the positions at the send tick, for all (frame, receiver) pairs of a decision at
once (a lockstep tick's every frame; a realtime delivery window's), with numpy:

* candidates - a broadcast's are its sender's reach (a disk of the *transmitter's* radius, the rule of
  world/sensing.py: squared distance <= range * range, so heterogeneous ranges give directed links), except
  the sender; an addressed frame's is its destination only. A broadcast's ``exclude`` list names robots that
  discard it: as a real radio, the world still carries their copies through every rule and records a copy
  that arrives as *overheard* (trace ``ovh``, never handed to the behaviour); ``radio.exclude = "filter"`` is
  the older rule where excluded robots are no candidates at all;
* rules - world/linkrules.py: each drops pairs under its cause, in order: ``dead`` and ``range`` (addressed
  frames), ``occlusion``, ``bandwidth``, ``cut`` (cuts and partitions), with ``[radio.channel]`` the shared
  channel's ``mac``, ``pathloss`` and ``sinr`` (world/channel.py), ``loss`` (Bernoulli, the distance model of
  Swarm Relays Sec. III-A, Gilbert-Elliott bursts), then any a scenario adds (``[[radio.rules]]``);
* latency - lockstep: exactly ``latency`` ticks; realtime: drawn uniformly in [latency_min_s, latency_s]
  seconds per (frame, receiver).

A frame still in the air when its receiver dies is dropped as ``dead`` at delivery time (by the simulation,
not here). The random draws are counter-based (world/rng.py) keyed on (seed, tick, src, seq, dst), so the
outcome is the same as deciding frame by frame, in any order. Frame bodies are never decoded: only their
lengths count.
"""

from __future__ import annotations

from dataclasses import dataclass

import msgspec
import numpy as np

from transport.scenario import Radio
from transport.severance import Severance
from world import rng
from world.channel import ChannelModel
from world.linkrules import LinkRule, Transmissions, cause_id, cause_name, pipeline
from world.sensing import Reach


class Outgoing(msgspec.Struct):
    """One frame as the world sees it: header plus opaque body bytes (a Struct: made once per frame sent)."""

    src: int
    dst: int | None
    kind: str
    seq: int
    body: bytes
    exclude: tuple[int, ...] = ()
    at: float | None = None  # realtime: the sender's wall time when it radioed the frame (FrameOut.at)


@dataclass
class Decision:
    """The outcome of a batch: for pair k, frame ``frames[frame[k]]`` and receiver ``dst[k]``.

    ``cause[k]`` is -1 for a copy that arrives, else a cause's number (``world.linkrules.cause_name``);
    ``overheard[k]`` marks a copy to a robot on the frame's ``exclude`` list (one that arrives is overheard, not
    delivered); ``src`` and ``seq`` are the frames' headers (one entry per frame of the batch).
    """

    frame: np.ndarray
    dst: np.ndarray
    cause: np.ndarray
    src: np.ndarray
    seq: np.ndarray
    overheard: np.ndarray

    def only(self, mask: np.ndarray) -> Decision:
        """The pairs where ``mask`` holds."""
        return Decision(self.frame[mask], self.dst[mask], self.cause[mask], self.src, self.seq,
                        self.overheard[mask])

    @property
    def delivered(self) -> np.ndarray:
        """Pairs handed to their receiver: arrived and not excluded."""
        return (self.cause < 0) & ~self.overheard


def _pairs(indptr: np.ndarray, rows: np.ndarray, frame_ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Expand CSR rows ``rows`` (one per frame in ``frame_ids``): (frame id, index into the CSR data) per pair.

    A row past the table (a robot added after the tick's reach was computed) is empty.
    """
    last = len(indptr) - 1
    starts = indptr[np.minimum(rows, last)]
    counts = indptr[np.minimum(rows + 1, last)] - starts
    total = int(counts.sum())
    if total == 0:
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty
    first = np.cumsum(counts) - counts
    idx = np.arange(total, dtype=np.int64) + np.repeat(starts - first, counts)
    return np.repeat(frame_ids, counts), idx


class Medium:
    """Decides receivers and drops for the frames of one tick."""

    def __init__(self, config: Radio, seed: int, dt: float = 1.0, realtime: bool = False):
        """``dt`` and ``realtime``: the run's tick length (seconds) and clock, for the shared channel."""
        self.config = config  # the scenario's [radio] (transport.scenario.Radio); set_loss replaces it
        self.seed = seed
        self.rules = pipeline(config, seed, Severance(), dt, realtime)  # world/linkrules.py, in order
        self._cut = self.rule("cut")  # world.linkrules.Cut

    def use_space(self, space) -> None:
        """The run's walls (a ``transport.space.Space``), for the channel's ``walls = "crossing"``."""
        for rule in self.rules:
            if isinstance(getattr(rule, "model", None), ChannelModel):
                rule.model.space = space

    def rule(self, name: str) -> LinkRule:
        """The rule called ``name`` in the pipeline (the first, if a scenario added two of one kind)."""
        return next(r for r in self.rules if r.name == name)

    @property
    def links(self) -> Severance:
        """Cuts and partitions (transport/severance.py): the ``cut`` rule's."""
        return self._cut.links

    @links.setter
    def links(self, links: Severance) -> None:
        self._cut.links = links

    @property
    def cuts(self) -> set[tuple[int, int]]:
        return self.links.cuts

    @property
    def group(self) -> dict[int, int]:
        return self.links.group

    def set_loss(self, loss: float) -> None:
        problem = self.config.loss_problem(loss)
        if problem:
            raise ValueError(f"loss: {problem}")
        self.config = msgspec.structs.replace(self.config, loss=loss)

    def cut(self, a: int, b: int) -> None:
        self.links.cut(a, b)

    def restore(self, a: int, b: int) -> None:
        self.links.restore(a, b)

    def partition(self, groups: list[list[int]]) -> None:
        self.links.partition(groups)

    def heal(self) -> None:
        self.links.heal()

    def decide(
        self,
        tick: int,
        frames: list[Outgoing],
        in_range: dict[int, np.ndarray],
        alive: np.ndarray,
        positions: np.ndarray,
        ranges: np.ndarray,
        occluded: dict[int, np.ndarray] | None = None,
    ) -> tuple[list[tuple], list[tuple[int, int, int, str, str]], list[tuple]]:
        """``decide_batch`` with reach as ``{src: sorted ids}`` and results as tuples.

        ``occluded[src]``, for a sender an obstacle cuts off from some of its reach, is ``(heard, hidden)``.
        A delivery is ``(receiver, src, seq, frame, tick)``; a drop is ``(src, seq, dst, kind, cause)``; an
        overheard copy is shaped like a delivery. Returns ``(deliveries, drops, overheard)``.
        """
        n = len(alive)
        rows = dict(in_range)
        hidden_sets = {}
        for src, (heard, hidden) in (occluded or {}).items():
            rows[src] = np.union1d(heard, hidden).astype(np.int64)
            hidden_sets[src] = set(np.asarray(hidden).tolist())
        table = Reach.from_dict(max([n, *(k + 1 for k in rows)]), rows)
        hidden = None
        if hidden_sets:
            owners = table.owners().tolist()
            hidden = np.array([j in hidden_sets.get(i, ()) for i, j in zip(owners, table.nbrs.tolist(), strict=True)],
                              dtype=bool)
        out = self.decide_batch(tick, frames, table, alive, positions, ranges, hidden)
        deliveries, drops, overheard = [], [], []
        for k, d, c, o in zip(out.frame.tolist(), out.dst.tolist(), out.cause.tolist(), out.overheard.tolist(),
                              strict=True):
            f = frames[k]
            if c >= 0:
                drops.append((f.src, f.seq, d, f.kind, cause_name(c)))
            else:
                (overheard if o else deliveries).append((d, f.src, f.seq, f, tick))
        return deliveries, drops, overheard

    def decide_batch(
        self,
        tick: int,
        frames: list[Outgoing],
        table: Reach,
        alive: np.ndarray,
        positions: np.ndarray,
        ranges: np.ndarray,
        hidden: np.ndarray | None = None,
        tx_power: np.ndarray | None = None,
    ) -> Decision:
        """Receivers and drops of ``frames``, sent at ``tick``, for all (frame, receiver) pairs at once.

        ``table`` holds each alive robot's reach at ``tick`` (world/sensing.py); ``hidden``, aligned with
        ``table.nbrs``, marks the links an obstacle blocks (None: none). The candidates: a broadcast's are its
        sender's reach (its ``exclude`` list's copies marked ``overheard``, or left out with
        ``exclude = "filter"``), an addressed frame's is its destination; then the rules (world/linkrules.py)
        drop pairs in order, and a rule's drops are recorded in the order of its pairs (broadcasts first).
        ``tx_power``: per robot, its transmit power on the shared channel (nan or None: the channel's).
        """
        tx = Transmissions(tick, self.seed, self.config, frames, table, alive, positions, ranges, hidden, tx_power)
        self._candidates(tx)
        out_f, out_d, out_c, out_o = [], [], [], []
        for rule in self.rules:
            lost = rule.apply(tx)
            if lost is None or not lost.any():
                continue
            out_f.append(tx.frame[lost])
            out_d.append(tx.dst[lost])
            out_c.append(np.full(len(out_f[-1]), cause_id(rule.cause), dtype=np.int64))
            out_o.append(tx.overheard[lost])
            tx.keep(~lost)
        out_f.append(tx.frame)
        out_d.append(tx.dst)
        out_c.append(np.full(len(tx), -1, dtype=np.int64))
        out_o.append(tx.overheard)
        return Decision(np.concatenate(out_f), np.concatenate(out_d), np.concatenate(out_c), tx.src, tx.seq,
                        np.concatenate(out_o))

    def _candidates(self, tx: Transmissions) -> None:
        """Every (frame, receiver) pair under decision: the broadcasts' reach, then the addressed frames."""
        n = len(tx.alive)
        frames = tx.frames
        bcast = ~tx.addressed
        b_ids = np.flatnonzero(bcast)
        pf, idx = _pairs(tx.table.indptr, tx.src[b_ids], b_ids) if b_ids.size else (np.zeros(0, np.int64),) * 2
        pd = tx.table.nbrs[idx]
        po = np.zeros(len(pf), dtype=bool)
        ex = [(k, x) for k in b_ids.tolist() for x in frames[k].exclude]
        if ex and pf.size:
            ef, ed = np.array(ex, dtype=np.int64).T
            po = np.isin(pf * (n + 1) + pd, ef * (n + 1) + np.where((ed >= 0) & (ed < n), ed, n))
            if self.config.exclude == "filter":
                pf, pd, idx, po = pf[~po], pd[~po], idx[~po], po[~po]
        u_ids = np.flatnonzero(~bcast)
        if u_ids.size:  # in range when the destination is in the sender's reach (the broadcast's rule)
            ud = np.fromiter((frames[k].dst for k in u_ids.tolist()), np.int64, len(u_ids))
            pf = np.concatenate([pf, u_ids])
            pd = np.concatenate([pd, ud])
            idx = np.concatenate([idx, tx.table.find(tx.src[u_ids], ud)])
            po = np.concatenate([po, np.zeros(len(u_ids), dtype=bool)])
        tx.set_pairs(pf, pd, idx, po)

    def latencies_s(self, tick: int, src: int, seq: int, receivers: np.ndarray) -> np.ndarray:
        """Realtime latency per receiver, uniform in [latency_min_s, latency_s]."""
        lo, hi = self.config.c_min_s, self.config.latency_s
        if hi <= lo:
            return np.full(len(receivers), hi)
        return lo + (hi - lo) * rng.uniform(self.seed, rng.LATENCY, tick, src, seq, receivers)
