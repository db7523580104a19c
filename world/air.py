"""The air: every copy of a frame the radio let through, until it falls due; one table for both clocks.

A copy is (frame, receiver) with its due time: ``send tick + latency`` in lockstep (ticks), the sender's radio
call plus a drawn latency in realtime (wall-clock seconds). Copies are kept by due *slot*: a slot is one tick in
lockstep and ``width`` seconds (``BOOKKEEPING_S``) in realtime, so ``pop(until)`` takes every slot that ends
by ``until`` - never a copy before its due time - as arrays in (receiver, src, seq) order.

The fate of a copy is decided when it is popped (``Simulation.deliver``): ``dead`` when its receiver died at
or before the copy's due time, else overheard (the receiver is on the frame's exclude list) or delivered.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from world.radio import Outgoing


class Copies(NamedTuple):
    """Copies as columns: frame ``frames[ref[k]]`` to ``dst[k]``, due at ``due[k]``.

    ``frames`` holds (frame, send tick) pairs, each frame once however many copies it has.
    """

    dst: np.ndarray
    ref: np.ndarray
    src: np.ndarray
    seq: np.ndarray
    sent: np.ndarray  # the tick each copy's frame was sent
    due: np.ndarray
    overheard: np.ndarray
    frames: list[tuple[Outgoing, int]]

    def only(self, mask: np.ndarray) -> Copies:
        return Copies(self.dst[mask], self.ref[mask], self.src[mask], self.seq[mask], self.sent[mask],
                      self.due[mask], self.overheard[mask], self.frames)


class Air:
    """Copies in the air, by due slot (``width``: 1 tick in lockstep, ``BOOKKEEPING_S`` in realtime)."""

    def __init__(self, width: float = 1.0):
        self.width = width
        self._slots: dict[int, list[Copies]] = {}

    def slot(self, due: float) -> int:
        """The slot a due time falls in: the one that ends at or after it."""
        return math.ceil(due / self.width)

    def put(self, copies: Copies) -> list[int]:
        """Put ``copies`` in the air; return the slots that were empty before (a realtime timer each)."""
        if not len(copies.dst):
            return []
        slots = np.ceil(copies.due / self.width).astype(np.int64)
        first = int(slots[0])
        one = len(slots) == 1 or bool((slots == first).all())  # the common case: every copy due in one slot
        new = []
        for s in [first] if one else np.unique(slots).tolist():
            group = self._slots.get(s)
            if group is None:
                group = self._slots[s] = []
                new.append(s)
            group.append(copies if one else copies.only(slots == s))
        return new

    def pop(self, until: float) -> Copies | None:
        """Every copy in a slot that ends by ``until``, in (receiver, src, seq) order; None when there is none."""
        last = math.floor(until / self.width + 1e-9)
        ready = sorted(s for s in self._slots if s <= last)
        batches = [c for s in ready for c in self._slots.pop(s)]
        if not batches:
            return None
        frames: list[tuple[Outgoing, int]] = []
        parts = []
        for c in batches:  # one frames list for all, each batch's refs shifted into it
            parts.append((c.dst, c.ref + len(frames), c.src, c.seq, c.sent, c.due, c.overheard))
            frames.extend(c.frames)
        dst, ref, src, seq, sent, due, heard = (np.concatenate(col) for col in zip(*parts, strict=True))
        order = np.lexsort((seq, src, dst))
        return Copies(dst[order], ref[order], src[order], seq[order], sent[order], due[order], heard[order], frames)

    def __len__(self) -> int:
        return sum(len(c.dst) for group in self._slots.values() for c in group)
