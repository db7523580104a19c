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

import msgspec
import numpy as np

# An integer's class, by where it falls among these bounds (side "right"): its type byte and payload size.
_BOUNDS = np.array([-(1 << 31), -(1 << 15), -(1 << 7), -32, 128, 256, 1 << 16, 1 << 32], dtype=np.int64)
_TYPE = np.array([0xD3, 0xD2, 0xD1, 0xD0, 0, 0xCC, 0xCD, 0xCE, 0xCF], dtype=np.uint8)  # 0: a fixint, no type byte
_PAYLOAD = np.array([8, 4, 2, 1, 0, 1, 2, 4, 8], dtype=np.int64)
_FIXINT = 4


def _list_header(n: int) -> bytes:
    if n < 16:
        return bytes([0x90 | n])
    if n < 1 << 16:
        return b"\xdc" + n.to_bytes(2, "big")
    return b"\xdd" + n.to_bytes(4, "big")


# The common case, every value in [0, 2**32): each value (and each row's header) becomes one big-endian word of
# 4 bytes (values below 65536) or 8, its encoding left-aligned; the bytes kept of each word are then taken out
# with one ``np.compress``. By class (fixint, uint8, uint16, uint32): the type byte, shifted into the word's top
# byte, the value's shift, and the bytes kept.
_WORD = {4: np.uint32, 8: np.uint64}
_TOP = {s: np.array([0, 0xCC, 0xCD, 0xCE][: s - 1], dtype=_WORD[s]) << _WORD[s](8 * s - 8) for s in (4, 8)}
_SHIFT = {4: np.array([24, 16, 8], dtype=np.uint32), 8: np.array([56, 48, 40, 24], dtype=np.uint64)}
_LEN = np.array([1, 2, 3, 5], dtype=np.intp)
# _KEEP[s][L]: a mask of a word's first L of s bytes, as one integer of the word's size (read back as s bools)
_KEEP = {s: (np.arange(s) < np.arange(s + 1)[:, None]).view(_WORD[s]).ravel() for s in (4, 8)}


SMALL_ROWS = 4096  # up to this many rows, msgspec packs ``rows.tolist()`` faster than the numpy path below
_encode = msgspec.msgpack.Encoder().encode  # an integer in the fewest bytes, as msgpack-python: the same bytes


def packb(rows: np.ndarray) -> bytes:
    """The msgpack bytes of ``rows.tolist()`` for an (n, w) integer array, w < 16."""
    rows = np.asarray(rows, dtype=np.int64)
    n, w = rows.shape
    if n == 0:
        return _list_header(0)
    if n <= SMALL_ROWS:
        return _encode(rows.tolist())
    return packb_numpy(rows)


def packb_numpy(rows: np.ndarray) -> bytes:
    """``packb`` with numpy (n >= 1 rows of int64): what pays for many rows."""
    n, w = rows.shape
    hi = rows.max()
    if rows.min() < 0 or hi >= 1 << 32:
        return _packb_any(rows)
    cls = (rows >= 128).astype(np.intp)
    cls += rows >= 256
    size = 4
    if hi >= 1 << 16:
        cls += rows >= 1 << 16
        size = 8
    word = _WORD[size]
    words = np.empty((n, w + 1), dtype=word)
    words[:, 0] = word(0x90 | w) << word(8 * size - 8)
    words[:, 1:] = _TOP[size][cls] | (rows.astype(word) << _SHIFT[size][cls])
    kept = np.empty((n, w + 1), dtype=np.intp)
    kept[:, 0] = 1
    kept[:, 1:] = _LEN[cls]
    mask = _KEEP[size][kept].view(bool).ravel()
    data = words.astype(f">u{size}").view(np.uint8).ravel()
    return _list_header(n) + np.compress(mask, data).tobytes()


def _packb_any(rows: np.ndarray) -> bytes:
    """``packb`` for any int64 values (negative ones, or 2**32 and above)."""
    n, w = rows.shape
    v = rows.ravel()
    cls = np.searchsorted(_BOUNDS, v, side="right")
    k = _PAYLOAD[cls]
    items = np.empty((n, w + 1), dtype=np.int64)  # each row: its header, then its values
    items[:, 0] = 1
    items[:, 1:] = (1 + k).reshape(n, w)
    flat = items.ravel()
    offsets = (np.cumsum(flat) - flat).reshape(n, w + 1)
    out = np.empty(int(offsets[-1, -1] + flat[-1]), dtype=np.uint8)
    out[offsets[:, 0]] = 0x90 | w
    at = offsets[:, 1:].ravel()  # where each value's first byte goes
    first = _TYPE[cls]
    small = cls == _FIXINT
    first[small] = v[small] & 0xFF
    out[at] = first
    big = np.flatnonzero(~small)
    if big.size:
        kb, where = k[big], at[big]
        be = v[big].astype(">i8").view(np.uint8).reshape(-1, 8)
        for j in range(1, 9):  # the j-th payload byte is big-endian byte 8 - k + j - 1
            m = np.flatnonzero(kb >= j)
            if not m.size:
                break
            out[where[m] + j] = be[m, 8 - kb[m] + j - 1]
    return _list_header(n) + out.tobytes()


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
