"""Trace files and the trace hash.

A trace is a msgpack stream (``trace.msgpack``): a header map, one map per
tick, and a footer map. Schema (docs/trace.md):

* header: ``{"trace": "swarmactors", "version": 1, "run_id", "clock", "seed",
  "pos_digits", "scenario"}``
* tick: ``{"t": tick, "pos": [[id, x, y(, z)], ...] (alive robots, rounded),
  "sent": [[src, seq, kind, dst, size], ...], "del": [[src, seq, dst,
  sent_tick], ...], "drop": [[src, seq, dst, cause], ...], "status": {id:
  {field: value}} (changes only), "ev": [event, ...], "mal": [reason, ...]}``
  (empty lists are left out);
* footer: ``{"end": true, "ticks", "trace_hash"}``.

``trace_hash`` is a BLAKE2b-128 digest over the canonical msgpack encoding of
every tick record, in tick order. Records are canonical by construction (lists
sorted, maps keyed in id order) and hold no wall-clock value, so the hash is a
function of what happened only.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterator
from operator import itemgetter
from pathlib import Path

import msgpack

from transport import pack

VERSION = 1


class TraceError(ValueError):
    """A trace file that cannot be read; names the file and the byte offset."""


# Unique sort keys of each list: pos is built in id order and lockstep
# deliveries in (dst, src, seq) order by the world; the others arrive in host order.
_KEYS = {"sent": itemgetter(0, 1), "drop": itemgetter(0, 1, 2)}


def canonical(rec: dict) -> dict:
    """Sort a tick record's lists and maps so that it does not depend on processing order."""
    out = {"t": rec["t"]}
    for key in ("pos", "sent", "del", "drop"):
        if rec.get(key):
            out[key] = sorted(rec[key], key=_KEYS[key]) if key in _KEYS else rec[key]
    if rec.get("status"):
        out["status"] = {rid: dict(sorted(rec["status"][rid].items())) for rid in sorted(rec["status"])}
    for key in ("ev", "mal"):
        if rec.get(key):
            out[key] = sorted(rec[key], key=pack)
    return out


class TraceHasher:
    """Running digest of canonical tick records."""

    def __init__(self) -> None:
        self._h = hashlib.blake2b(digest_size=16)

    def update(self, rec: dict) -> None:
        self._h.update(pack(rec))

    def hexdigest(self) -> str:
        return self._h.hexdigest()


class TraceWriter:
    """A world sink: writes the trace file (if ``path``) and computes the hash.

    A write failure (full disk, removed directory) does not stop the run: the
    hash goes on, the file is closed, and ``error`` says what happened.
    """

    def __init__(self, path: Path | None, header: dict):
        self.path = path
        self.hasher = TraceHasher()
        self.ticks = 0
        self.error: str | None = None
        self._file = None
        if path is not None:
            try:
                self._file = open(path, "wb", buffering=1 << 20)
                self._file.write(pack({"trace": "swarmactors", "version": VERSION, **header}))
            except OSError as exc:
                self._fail(exc)

    def record(self, rec: dict) -> None:
        rec = canonical(rec)
        self.hasher.update(rec)
        self.ticks += 1
        if self._file is not None:
            try:
                self._file.write(pack(rec))
            except OSError as exc:
                self._fail(exc)

    def _fail(self, exc: OSError) -> None:
        self.error = f"trace {self.path}: {exc.strerror or exc}"
        if self._file is not None:
            try:
                self._file.close()
            except OSError:
                pass
        self._file = None

    @property
    def trace_hash(self) -> str:
        return self.hasher.hexdigest()

    def close(self) -> None:
        if self._file is not None:
            try:
                self._file.write(pack({"end": True, "ticks": self.ticks, "trace_hash": self.trace_hash}))
                self._file.close()
            except OSError as exc:
                self._fail(exc)
            self._file = None


def read_trace(path: str | Path) -> tuple[dict, list[dict], dict | None]:
    """Read a whole trace: ``(header, tick records, footer or None if truncated cleanly)``."""
    header = None
    records: list[dict] = []
    footer = None
    for obj in iter_trace(path):
        if header is None:
            header = obj
        elif obj.get("end"):
            footer = obj
        else:
            records.append(obj)
    return header, records, footer


def iter_trace(path: str | Path) -> Iterator[dict]:
    """Yield the header, tick records and footer of a trace, checking each."""
    path = Path(path)
    try:
        f = open(path, "rb")
    except OSError as exc:
        raise TraceError(f"{path}: cannot open: {exc.strerror}") from None
    with f:
        unpacker = msgpack.Unpacker(f, raw=False, strict_map_key=False, max_buffer_size=1 << 30)
        first = True
        offset = 0
        if path.stat().st_size == 0:
            raise TraceError(f"{path}: empty file at byte offset 0 (the run wrote no trace data)")
        while True:
            try:
                obj = unpacker.unpack()
            except msgpack.OutOfData:
                if offset < path.stat().st_size:
                    raise TraceError(f"{path}: truncated record at byte offset {offset}") from None
                return
            except Exception as exc:
                raise TraceError(f"{path}: corrupt data at byte offset {offset}: {exc}") from None
            if not isinstance(obj, dict):
                raise TraceError(f"{path}: byte offset {offset}: expected a map, found {type(obj).__name__}")
            if first:
                if obj.get("trace") != "swarmactors":
                    raise TraceError(f"{path}: byte offset 0: not a swarmactors trace (no header)")
                if obj.get("version") != VERSION:
                    raise TraceError(f"{path}: trace version {obj.get('version')!r}, this reader knows {VERSION}")
                first = False
            elif not obj.get("end") and not isinstance(obj.get("t"), int):
                raise TraceError(f"{path}: byte offset {offset}: tick record without an integer 't'")
            offset = unpacker.tell()
            yield obj


def verify(path: str | Path) -> str:
    """Recompute the hash of a trace file and compare it with its footer's."""
    header, records, footer = read_trace(path)
    h = TraceHasher()
    for rec in records:
        h.update(rec)
    if footer is None:
        raise TraceError(f"{path}: no footer (the run did not finish writing the trace)")
    if footer["trace_hash"] != h.hexdigest():
        raise TraceError(f"{path}: hash mismatch: footer {footer['trace_hash']}, records {h.hexdigest()}")
    return h.hexdigest()
