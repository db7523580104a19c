"""A tick's inputs as a robot sees them: what it sensed and the frames it received, shared with no other robot."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import msgspec
import numpy as np

from swarmactors.robot.behavior import Frame, Sensed
from transport.messages import FrameIn


class SensedView(Sequence):
    """What a robot sensed this tick, as ``Sensed`` items built only when read.

    Under local sensing each neighbour's numbers are (range, bearing[, elevation]), turned into a body-frame
    vector for ``pos``.
    """

    __slots__ = ("_ids", "_flat", "_dims", "_local")

    def __init__(self, ids: list[int], flat: list[float], dims: int, local: bool = False):
        self._ids, self._flat, self._dims, self._local = ids, flat, dims, local

    def __len__(self) -> int:
        return len(self._ids)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(len(self)))]
        d = self._dims
        row = self._flat[i * d : (i + 1) * d]
        if self._local:
            return Sensed(self._ids[i], _cartesian(np.array([row]), d)[0], row[0], row[1])
        return Sensed(self._ids[i], np.array(row))

    @property
    def ids(self) -> list[int]:
        return self._ids

    def positions(self) -> np.ndarray:
        """All sensed positions (body-frame vectors under local sensing) as an (n, dims) array."""
        rows = np.array(self._flat, dtype=float).reshape(len(self._ids), self._dims)
        return _cartesian(rows, self._dims) if self._local else rows


def _cartesian(rows: np.ndarray, dims: int) -> np.ndarray:
    """(range, bearing[, elevation]) rows as body-frame vectors (x ahead, y left[, z up])."""
    r, b = rows[:, 0], rows[:, 1]
    e = rows[:, 2] if dims > 2 else np.zeros(len(rows))
    out = [r * np.cos(e) * np.cos(b), r * np.cos(e) * np.sin(b)] + ([r * np.sin(e)] if dims > 2 else [])
    return np.column_stack(out)


_body_decoder = msgspec.msgpack.Decoder()
_UNSEEN = object()
_replace = msgspec.structs.replace


def decode_body(f: FrameIn, rab: list[float] | None = None) -> Frame | None:
    """A received frame with its body decoded (and its range and bearing); None for an undecodable body."""
    try:
        return Frame(f.src, f.kind, _body_decoder.decode(f.body), f.seq, f.sent, None if rab is None else tuple(rab))
    except msgspec.DecodeError:
        return None


def with_rab(frame: Frame, rab: tuple[float, float]) -> Frame:
    """``frame`` as heard at (range, bearing) ``rab`` by its receiver."""
    return _replace(frame, rab=rab)


class FrameTable:
    """A downlink's frames, decoded once per host and handed out so that robots share nothing.

    A body is decoded once; an immutable one (a number, string, bytes, None) is shared by every receiver,
    a list or map is decoded again for each further receiver, so no robot sees another's changes.
    """

    __slots__ = ("_frames", "_given", "_again")

    def __init__(self, frames: list[FrameIn]):
        self._frames = frames
        self._given: list[Any] = [_UNSEEN] * len(frames)  # the first receiver's Frame (None: undecodable)
        self._again: list[bytes | None] = [None] * len(frames)  # the body to decode for further receivers

    def _first(self, k: int) -> Frame | None:
        f = self._frames[k]
        frame = self._given[k] = decode_body(f)
        if frame is not None and isinstance(frame.body, (list, dict)):
            self._again[k] = f.body
        return frame

    def frame(self, k: int) -> Frame | None:
        frame = self._given[k]
        if frame is _UNSEEN:
            return self._first(k)
        again = self._again[k]
        return frame if again is None else _replace(frame, body=_body_decoder.decode(again))

    def inbox(self, refs: list[int]) -> tuple[list[Frame], int]:
        """One robot's frames (its slice of the table, in order) and how many had a body that does not decode."""
        given, again = self._given, self._again
        out: list[Frame] = []
        bad = 0
        for k in refs:
            frame = given[k]
            if frame is _UNSEEN:
                frame = self._first(k)
            elif again[k] is not None:
                frame = _replace(frame, body=_body_decoder.decode(again[k]))
            if frame is None:
                bad += 1
            else:
                out.append(frame)
        return out, bad
