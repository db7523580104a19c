"""Counter-based random numbers for the radio.

A radio decision about (frame, receiver) is a pure function of
``(seed, stream, tick, src, seq, dst)``: it never depends on the order in which
the world happens to process frames, so lockstep runs are reproducible whatever
the number of host processes. The mixer is SplitMix64's finaliser applied to
the fields in turn, vectorised over numpy ``uint64`` arrays.
"""

from __future__ import annotations

import numpy as np

LOSS = 1  # stream ids keep independent decisions independent
LATENCY = 2
BURST = 3
PLACEMENT = 4
NOISE = 5
SITUATED = 6  # per-robot draws: heading offset, clock offset and drift (world/situated.py)
BEARING = 7  # range and bearing noise of situated sensing
RAB = 8  # range and bearing noise of received frames
SHADOW = 9  # the shared channel (world/channel.py): log-normal shadowing per link
START = 10  # a frame's send time within its tick
BACKOFF = 11  # CSMA backoff slots
RECEPTION = 12  # a copy's reception draw against its packet reception ratio

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31 = np.uint64(30), np.uint64(27), np.uint64(31)


def _mix(z: np.ndarray) -> np.ndarray:
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


def hash64(seed: int, *fields) -> np.ndarray:
    """64-bit hash of ``seed`` and ``fields`` (ints or int arrays, broadcast together)."""
    with np.errstate(over="ignore"):
        state = _mix(np.asarray(seed & 0xFFFFFFFFFFFFFFFF, dtype=np.uint64) + _GOLDEN)
        for value in fields:
            v = np.asarray(value, dtype=np.int64).astype(np.uint64)
            state = _mix(state ^ (v + _GOLDEN + (state << np.uint64(6)) + (state >> np.uint64(2))))
    return state


def uniform(seed: int, *fields) -> np.ndarray:
    """Uniform floats in [0, 1) keyed on ``(seed, *fields)``."""
    return (hash64(seed, *fields) >> np.uint64(11)).astype(np.float64) * (1.0 / (1 << 53))

