"""The SECS oracle's own rules: frame offsets from odometry, connectivity at every tick."""

from __future__ import annotations

import math

import numpy as np

from protocols.secs import oracle


def test_heading_offset_is_recovered_from_odometry():
    rng = np.random.default_rng(7)
    for _ in range(100):
        off = rng.uniform(-math.pi, math.pi)
        start, now = rng.uniform(-5, 5, 2), rng.uniform(-5, 5, 2)
        d = now - start
        c, s = math.cos(-off), math.sin(-off)
        odo = [c * d[0] - s * d[1], s * d[0] + c * d[1]]  # the displacement in the robot's own frame
        got = oracle.heading_offset(odo, start, now)
        assert abs((got - off + math.pi) % (2 * math.pi) - math.pi) < 1e-9
    assert oracle.heading_offset([0.0, 0.0], np.zeros(2), np.zeros(2)) is None


class _Trace:
    def __init__(self, recs):
        self.trace = recs

    def records(self):  # the checks stream the records, as Result.records() does
        return iter(self.trace)

    def ranges(self):
        return {0: 3.0, 1: 3.0, 2: 3.0}


def test_connected_ticks_counts_the_split_ticks():
    recs = [{"t": 0, "pos": [[0, 0.0, 0.0], [1, 2.9, 0.0], [2, 5.8, 0.0]]},
            {"t": 1, "pos": [[0, 0.0, 0.0], [1, 3.1, 0.0], [2, 5.8, 0.0]]},
            {"t": 2, "pos": [[0, 0.0, 0.0], [1, 2.0, 0.0], [2, 4.0, 0.0]]},
            {"t": 3, "pos": [[0, 0.0, 0.0], [2, 4.0, 0.0]]}]
    assert oracle.connected_ticks(_Trace(recs)) == (4, 1, 2)
