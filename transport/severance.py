"""Links severed by cuts and partitions: one rule for the radio, the oracle and the charts.

A link between robots a and b is severed, in both directions, when the pair was cut (the ``cut`` action,
pair in either order, until ``restore`` or ``heal``) or when a and b are in different partition groups
(``partition``: group k + 1 for the k-th listed group, group 0 for every robot listed nowhere; a new
partition replaces the previous one; ``heal`` ends cuts and partition). The world's radio (world/radio.py)
drops frames over a severed link as ``cut``; the charts replay the same actions from the trace's ``ev`` lists
(``apply``) and leave severed links out. The oracle (``Result.graph_at``) keeps its own replay
(``swarmactors.oracle.result.Severed``), compared with this one by tests/unit/test_graph_at.py, so that a bug in one
does not hide in both. Numpy only: no networkx, no scipy.
"""

from __future__ import annotations

import numpy as np


class Severance:
    """The cuts and the partition in force; ``mask(src, dst)`` says which links they sever."""

    def __init__(self) -> None:
        self.cuts: set[tuple[int, int]] = set()
        self.group: dict[int, int] = {}  # robot -> partition group; absent = group 0

    def __bool__(self) -> bool:
        return bool(self.cuts or self.group)

    def __eq__(self, other) -> bool:
        return isinstance(other, Severance) and (self.cuts, self.group) == (other.cuts, other.group)

    __hash__ = None

    def copy(self) -> Severance:
        other = Severance()
        other.cuts, other.group = set(self.cuts), dict(self.group)
        return other

    def cut(self, a: int, b: int) -> None:
        self.cuts.add((min(a, b), max(a, b)))

    def restore(self, a: int, b: int) -> None:
        self.cuts.discard((min(a, b), max(a, b)))

    def partition(self, groups: list[list[int]]) -> None:
        self.group = {r: g + 1 for g, members in enumerate(groups) for r in members}

    def heal(self) -> None:
        self.cuts.clear()
        self.group.clear()

    def apply(self, ev: dict) -> None:
        """Replay one trace event (``cut``, ``restore``, ``partition``, ``heal``; others change nothing)."""
        if "cut" in ev:
            for a, b in ev["cut"]:
                self.cut(a, b)
        elif "restore" in ev:
            for a, b in ev["restore"]:
                self.restore(a, b)
        elif "partition" in ev:
            self.partition(ev["partition"])
        elif "heal" in ev:
            self.heal()

    def severed(self, a: int, b: int) -> bool:
        """Whether the link between robots ``a`` and ``b`` is severed."""
        if self.cuts and (min(a, b), max(a, b)) in self.cuts:
            return True
        return bool(self.group) and self.group.get(a, 0) != self.group.get(b, 0)

    def mask(self, src: np.ndarray, dst: np.ndarray) -> np.ndarray:
        """``severed`` for every pair (src[k], dst[k]) at once."""
        src = np.asarray(src, dtype=np.int64)
        dst = np.asarray(dst, dtype=np.int64)
        out = np.zeros(len(src), dtype=bool)
        if not self or not len(src):
            return out
        if self.group:
            top = max(max(self.group), int(src.max()), int(dst.max())) + 1
            g = np.zeros(top, dtype=np.int64)
            g[np.fromiter(self.group, np.int64, len(self.group))] = np.fromiter(self.group.values(), np.int64,
                                                                                  len(self.group))
            out |= g[src] != g[dst]
        if self.cuts:
            lo, hi = np.minimum(src, dst), np.maximum(src, dst)
            cut = np.array(sorted(self.cuts), dtype=np.int64).reshape(-1, 2)
            top = max(int(hi.max()), int(cut.max())) + 1
            out |= np.isin(lo * top + hi, cut[:, 0] * top + cut[:, 1])
        return out
