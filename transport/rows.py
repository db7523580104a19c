"""Rows of integers kept as one numpy array, packed to exactly the msgpack bytes of the list of lists.

A lockstep tick delivers thousands of frames, and each delivery is one trace row ``[src, seq, dst, sent_tick]``.
Building a Python list per row only to msgpack it costs more than the radio's whole decision, so the world keeps
the rows as an ``(n, w)`` int64 array (``IntRows``) and ``packb`` encodes them with numpy. msgpack encodes a
list of n items as a header (``0x90 | n`` below 16, ``0xdc`` + 2 bytes below 65536, else ``0xdd`` + 4 bytes)
followed by its items, and an integer in the fewest bytes its value allows: a fixint (-32 … 127) in one byte,
else a type byte (``0xcc``/``0xcd``/``0xce``/``0xcf`` unsigned, ``0xd0``/``0xd1``/``0xd2``/``0xd3`` signed) and
1, 2, 4 or 8 big-endian bytes (the msgpack specification, "int format family"). Packing ``rows.tolist()`` with
msgpack gives the same bytes (tests/unit/test_array_radio.py checks it).
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

_PAYLOAD = np.arange(1, 9)  # byte positions after an integer's type byte


def _list_header(n: int) -> bytes:
    if n < 16:
        return bytes([0x90 | n])
    if n < 1 << 16:
        return b"\xdc" + n.to_bytes(2, "big")
    return b"\xdd" + n.to_bytes(4, "big")


def _ints(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each value's encoding as 9 byte slots (type byte, 8 big-endian bytes) and which slots it uses."""
    n = len(v)
    be = v.astype(">i8").view(np.uint8).reshape(n, 8)
    neg = v < 0
    k = np.select(
        [(v >= -32) & (v < 128),
         np.where(neg, v >= -(1 << 7), v < 1 << 8),
         np.where(neg, v >= -(1 << 15), v < 1 << 16),
         np.where(neg, v >= -(1 << 31), v < 1 << 32)],
        [0, 1, 2, 4], 8)
    tag = np.select([k == 1, k == 2, k == 4], [0xCC, 0xCD, 0xCE], 0xCF) + np.where(neg, 4, 0)
    out = np.empty((n, 9), dtype=np.uint8)
    out[:, 0] = np.where(k == 0, be[:, 7], tag)
    out[:, 1:] = be
    used = np.empty((n, 9), dtype=bool)
    used[:, 0] = True
    used[:, 1:] = _PAYLOAD[None, :] >= (9 - k)[:, None]
    return out, used


def packb(rows: np.ndarray) -> bytes:
    """The msgpack bytes of ``rows.tolist()`` for an (n, w) integer array, w < 16."""
    rows = np.asarray(rows, dtype=np.int64)
    n, w = rows.shape
    if n == 0:
        return _list_header(0)
    buf = np.empty((n, 1 + 9 * w), dtype=np.uint8)
    used = np.empty((n, 1 + 9 * w), dtype=bool)
    buf[:, 0] = 0x90 | w
    used[:, 0] = True
    for c in range(w):
        b, u = _ints(rows[:, c])
        buf[:, 1 + 9 * c: 10 + 9 * c] = b
        used[:, 1 + 9 * c: 10 + 9 * c] = u
    return _list_header(n) + buf[used].tobytes()


class IntRows:
    """An (n, w) int64 array that reads like the list of its rows and packs like it (``packb``)."""

    __slots__ = ("array",)

    def __init__(self, array: np.ndarray):
        self.array = np.asarray(array, dtype=np.int64)

    def __len__(self) -> int:
        return len(self.array)

    def __iter__(self) -> Iterator[list[int]]:
        return iter(self.array.tolist())

    def __getitem__(self, k):
        return self.array.tolist()[k]

    def __eq__(self, other) -> bool:
        return self.tolist() == (other.tolist() if isinstance(other, IntRows) else other)

    __hash__ = None

    def tolist(self) -> list[list[int]]:
        return self.array.tolist()

    def extend(self, rows) -> IntRows:
        """A new IntRows with ``rows`` (an IntRows or a list of rows) after these."""
        more = rows.array if isinstance(rows, IntRows) else np.asarray(rows, dtype=np.int64).reshape(-1, self.width)
        return IntRows(np.concatenate([self.array, more]))

    @property
    def width(self) -> int:
        return self.array.shape[1]

    def packb(self) -> bytes:
        return packb(self.array)
