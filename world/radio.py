"""The radio medium: who hears a frame, when, and whether.

Rules (DESIGN.md, "Radio medium"), applied once per frame from the positions
at the send tick:

* range - a disk of the *transmitter's* radius, so heterogeneous ranges give
  directed links; a broadcast reaches every alive robot in range except the
  sender, an addressed frame only its destination and only if in range (else
  dropped as ``range``); both by the rule of world/sensing.py (squared
  distance <= range * range);
* exclusion - a broadcast's ``exclude`` list names robots that discard it: as a
  real radio, the world still carries their copies through every rule below
  and records a copy that arrives as *overheard* (trace ``ovh``, counted, never
  handed to the behaviour); ``radio.exclude = "filter"`` is the older rule
  where excluded robots are no candidates at all (neither heard nor dropped);
  addressed frames are point-to-point either way (the MAC filters them);
* cuts and partitions - a frame over a cut link or between partition groups is
  dropped as ``cut``;
* occlusion - with ``radio.occlusion``, a frame to a receiver in range that an
  obstacle hides from the sender (world/space.py) is dropped as ``occluded``;
* bandwidth - an optional cap of bytes per robot per tick; every frame sent
  counts, heard or not; frames past it, in sending order, are dropped as
  ``bandwidth`` for every receiver;
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

``Medium.decide_batch`` applies these rules to all (frame, receiver) pairs of a batch at once, with numpy:
the frames' headers become arrays, the candidate receivers come from the tick's ``Reach`` table
(world/sensing.py), and every rule is a mask over the pairs. The random draws are the counter-based ones
(world/rng.py) keyed on the same fields, so the outcome is the same as deciding frame by frame, in any
order. Frame bodies are never decoded: only their lengths count.
"""

from __future__ import annotations

from dataclasses import dataclass

import msgspec
import numpy as np

from transport.messages import DROP_CAUSES
from transport.scenario import Radio
from transport.severance import Severance
from world import rng
from world.bursts import GilbertElliott
from world.sensing import Reach

CAUSE = {name: k for k, name in enumerate(DROP_CAUSES)}  # drop causes as small integers in ``Decision.cause``


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

    ``cause[k]`` is -1 for a copy that arrives, else an index into ``DROP_CAUSES``; ``overheard[k]`` marks a
    copy to a robot on the frame's ``exclude`` list (one that arrives is overheard, not delivered); ``src`` and
    ``seq`` are the frames' headers (one entry per frame of the batch).
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

    def __init__(self, config: Radio, seed: int):
        self.config = config  # the scenario's [radio] (transport.scenario.Radio); set_loss replaces it
        self.seed = seed
        self.links = Severance()  # cuts and partitions (transport/severance.py)
        self._budget = np.zeros(0, dtype=np.int64)  # bytes sent this tick, per robot (bandwidth cap)
        self._budget_tick = -1
        self.bursts = (GilbertElliott(seed, config.p_gb, config.p_bg, config.loss_good, config.loss_bad)
                       if config.loss_model == "gilbert" else None)

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
                drops.append((f.src, f.seq, d, f.kind, DROP_CAUSES[c]))
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
    ) -> Decision:
        """Receivers and drops of ``frames``, sent at ``tick``, for all (frame, receiver) pairs at once.

        ``table`` holds each alive robot's reach at ``tick`` (world/sensing.py); ``hidden``, aligned with
        ``table.nbrs``, marks the links an obstacle blocks (None: none). In order: a broadcast's candidates
        are its sender's reach (its ``exclude`` list's copies marked ``overheard``, or left out with
        ``exclude = "filter"``), the hidden ones dropped as ``occluded``; an
        addressed frame's only candidate is its destination, dropped as ``dead`` (no such robot, or dead),
        ``range`` (not in the sender's reach: the broadcast's rule) or ``occluded``; every frame is charged
        to its sender's bandwidth budget for the tick, in sending order, and the candidates of a frame past
        the cap are dropped as ``bandwidth``; then severed links (``cut``), then loss.
        """
        cfg = self.config
        n = len(alive)
        nf = len(frames)
        if tick != self._budget_tick:  # the cap is per tick, however many uplinks carry the tick's frames
            self._budget_tick = tick
            self._budget = np.zeros(n, dtype=np.int64)
        src = np.fromiter((f.src for f in frames), np.int64, nf)
        seq = np.fromiter((f.seq for f in frames), np.int64, nf)
        bcast = np.fromiter((f.dst is None for f in frames), bool, nf)
        out_f: list[np.ndarray] = []  # early drops: (frame, dst, cause, overheard)
        out_d: list[np.ndarray] = []
        out_c: list[np.ndarray] = []
        out_o: list[np.ndarray] = []

        def drop(mask, cause):
            out_f.append(pf[mask])
            out_d.append(pd[mask])
            out_c.append(np.full(len(out_f[-1]), CAUSE[cause], dtype=np.int64))
            out_o.append(po[mask])

        # broadcasts: the sender's reach; copies to the exclude list are overheard (or, "filter", not sent)
        b_ids = np.flatnonzero(bcast)
        pf, idx = _pairs(table.indptr, src[b_ids], b_ids) if b_ids.size else (np.zeros(0, np.int64),) * 2
        pd = table.nbrs[idx]
        po = np.zeros(len(pf), dtype=bool)
        ex = [(k, x) for k in b_ids.tolist() for x in frames[k].exclude]
        if ex and pf.size:
            ef, ed = np.array(ex, dtype=np.int64).T
            po = np.isin(pf * (n + 1) + pd, ef * (n + 1) + np.where((ed >= 0) & (ed < n), ed, n))
            if cfg.exclude == "filter":
                pf, pd, idx, po = pf[~po], pd[~po], idx[~po], po[~po]
        if hidden is not None and pf.size:
            h = hidden[idx]
            drop(h, "occluded")
            pf, pd, po = pf[~h], pd[~h], po[~h]
        # addressed frames: one candidate each, in range when it is in the sender's reach (the same rule)
        u_ids = np.flatnonzero(~bcast)
        if u_ids.size:
            b_f, b_d, b_o = pf, pd, po
            pf = u_ids
            pd = np.fromiter((frames[k].dst for k in u_ids.tolist()), np.int64, len(u_ids))
            po = np.zeros(len(pf), dtype=bool)
            dead = (pd < 0) | (pd >= n)
            dead[~dead] = ~alive[pd[~dead]]
            drop(dead, "dead")
            pf, pd, po = pf[~dead], pd[~dead], po[~dead]
            where = table.find(src[pf], pd)
            far = where < 0
            drop(far, "range")
            pf, pd, po, where = pf[~far], pd[~far], po[~far], where[~far]
            if hidden is not None:
                h = hidden[where]
                drop(h, "occluded")
                pf, pd, po = pf[~h], pd[~h], po[~h]
            pf = np.concatenate([b_f, pf])
            pd = np.concatenate([b_d, pd])
            po = np.concatenate([b_o, po])
        # bandwidth: every frame sent charges its sender, in sending order
        if cfg.bandwidth and nf:
            everyone = np.arange(nf, dtype=np.int64)
            over = self._charge(src, frames, everyone)
            if over.size and pf.size:
                lost = np.isin(pf, over)
                drop(lost, "bandwidth")
                pf, pd, po = pf[~lost], pd[~lost], po[~lost]
        ps = src[pf]
        if self.links and pf.size:
            sev = self.links.mask(ps, pd)
            drop(sev, "cut")
            pf, pd, ps, po = pf[~sev], pd[~sev], ps[~sev], po[~sev]
        p_ok = self._success_probability(tick, ps, pd, positions, ranges) if pf.size else None
        if p_ok is not None:
            lost = rng.uniform(self.seed, rng.LOSS, tick, ps, seq[pf], pd) >= p_ok  # p_ok = 0 or 1: certain
            drop(lost, "loss")
            pf, pd, po = pf[~lost], pd[~lost], po[~lost]
        out_f.append(pf)
        out_d.append(pd)
        out_c.append(np.full(len(pf), -1, dtype=np.int64))
        out_o.append(po)
        return Decision(np.concatenate(out_f), np.concatenate(out_d), np.concatenate(out_c), src, seq,
                        np.concatenate(out_o))

    def _charge(self, senders: np.ndarray, frames: list[Outgoing], which: np.ndarray) -> np.ndarray:
        """Add the bodies of frames ``which`` (sent by ``senders``, in order) to the budget; those past the cap."""
        top = int(senders.max()) + 1
        if top > len(self._budget):
            self._budget = np.concatenate([self._budget, np.zeros(top - len(self._budget), dtype=np.int64)])
        size = np.fromiter((len(frames[k].body) for k in which.tolist()), np.int64, len(which))
        order = np.argsort(senders, kind="stable")
        s, z = senders[order], size[order]
        total = np.cumsum(z)
        first = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
        before = np.repeat(total[first] - z[first], np.diff(np.r_[first, len(s)]))
        used = self._budget[s] + total - before
        last = np.r_[first[1:], len(s)] - 1
        self._budget[s[last]] = used[last]
        return np.sort(order[used > self.config.bandwidth])

    def _success_probability(self, tick, src, receivers, positions, ranges):
        """Per-pair decoding probability, or None when every frame gets through."""
        cfg = self.config
        keep = (1.0 - cfg.loss) if self.bursts is None else self.bursts.success_pairs(tick, src, receivers)
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
