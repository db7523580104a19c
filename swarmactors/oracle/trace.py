"""Trace files and the trace hash.

A trace is a msgpack stream (``trace.msgpack``): a header map, one map per
tick, and a footer map. Schema (docs/trace.md):

* header: ``{"trace": "swarmactors", "version": 2, "run_id", "clock", "seed",
  "pos_digits", "scenario"}``
* tick: ``{"t": tick, "pos": [[id, x, y(, z)], ...] (alive robots, rounded),
  "sent": [[src, seq, kind, dst, size], ...], "del": [[src, seq, dst,
  sent_tick], ...], "ovh": [[src, seq, dst, sent_tick], ...] (copies a robot
  on a broadcast's exclude list overheard: version 2), "drop": [[src, seq,
  dst, cause], ...], "status": {id:
  {field: value}} (changes only), "ev": [event, ...], "mal": [reason, ...]}``
  (empty lists are left out);
* footer: ``{"end": true, "ticks", "trace_hash", "header_hash"}``.

``trace_hash`` is a BLAKE2b-128 digest over the canonical msgpack encoding of
every tick record, in tick order. Records are canonical by construction (lists
sorted, maps keyed in id order) and hold no wall-clock value, so the hash is a
function of what happened only. ``header_hash`` is the same digest of the
header as written (it holds the run id and the scenario, so it is kept apart from
``trace_hash``, which must not depend on the run id); ``verify`` and the replay
check both, so an edited header or record does not go unnoticed.
"""

from __future__ import annotations

import hashlib
import stat
import time
from collections.abc import Iterable, Iterator
from operator import itemgetter
from pathlib import Path
from typing import Any

import msgpack
import msgspec

from transport import pack
from transport.rows import IntRows

VERSION = 2  # 2: tick records may hold "ovh" (overheard copies); version 1 traces are read as they are
READABLE = (1, 2)
MODES = ("off", "summary", "full")  # run.trace: what the trace file holds (the hash is the same in every mode)
SUMMARISED = ("del", "ovh", "drop")  # the per-(frame, receiver) lists a summary trace replaces by counts
FLUSH_S = 1.0  # the trace file is flushed at least this often (seconds)
ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"  # a Zstandard frame's first bytes
# Bounds on what a reader accepts (docs/trace.md, "Limits"): a trace is input, and may be hostile.
MAX_RECORD_BYTES = 32 << 20  # one header, tick record or footer, as encoded: 25x a record of 10,000 robots
MAX_RECORD_CONTAINERS = 2_000_000  # lists and maps in one record (each costs ~70 bytes once decoded)
MAX_RATIO = 2000  # decompressed bytes per compressed byte of a zstd trace (real traces: up to ~300)
RATIO_FLOOR = 64 << 20  # decompressed bytes always allowed before the ratio applies
_READ_CHUNK = 1 << 20


class TraceError(ValueError):
    """A trace file that cannot be read; names the file and the byte offset."""


# Unique sort keys of each list: pos is built in id order and lockstep
# deliveries in (dst, src, seq) order by the world; the others arrive in host order.
_KEYS = {"sent": itemgetter(0, 1), "drop": itemgetter(0, 1, 2), "cmd": itemgetter(0)}


def canonical(rec: dict) -> dict:
    """Sort a tick record's lists and maps so that it does not depend on processing order."""
    out = {"t": rec["t"]}
    for key in ("pos", "sent", "del", "ovh", "drop", "cmd"):
        if rec.get(key):
            out[key] = sorted(rec[key], key=_KEYS[key]) if key in _KEYS else rec[key]
    if rec.get("status"):
        out["status"] = {rid: dict(sorted(rec["status"][rid].items())) for rid in sorted(rec["status"])}
    for key in ("ev", "mal"):
        if rec.get(key):
            out[key] = sorted(rec[key], key=pack)
    return out


def digest(obj: Any) -> str:
    """BLAKE2b-128 of an object's msgpack encoding (the trace's one hash function)."""
    return hashlib.blake2b(pack(obj), digest_size=16).hexdigest()


_NUMBER = (int, float)


def _rows_fine(value: list, width: int) -> bool:
    """True when every row is a plain list of ``width`` or more fields whose first is a plain int (or a bool).

    The same test as ``record_problem``'s loop, by C-level passes over the rows (a delivery list holds
    thousands of rows a tick); False sends the caller to the loop, which names the first bad row.
    """
    if not set(map(type, value)) <= {list}:
        return False
    if min(map(len, value), default=width) < width:
        return False
    return set(map(type, map(itemgetter(0), value))) <= {int, bool}


def record_problem(rec: dict) -> str | None:
    """What is wrong with the shape of a tick record (None: nothing); docs/trace.md is the schema."""
    rows = {"pos": 3, "sent": 5, "del": 4, "ovh": 4, "drop": 4, "cmd": 3}
    for key, width in rows.items():
        value = rec.get(key, [])
        if not isinstance(value, list):
            return f"'{key}' is a {type(value).__name__}, not a list"
        if _rows_fine(value, width):  # the common case, decided without a Python loop over the rows
            continue
        for row in value:
            if not isinstance(row, list) or len(row) < width or not isinstance(row[0], int):
                return f"'{key}' holds {row!r}, not a row of {width} or more fields starting with a robot id"
    if not all(isinstance(v, _NUMBER) and not isinstance(v, bool) for row in rec.get("pos", []) for v in row[1:]):
        return "'pos' holds a coordinate that is not a number"
    status = rec.get("status", {})
    if not isinstance(status, dict) or not all(isinstance(v, dict) for v in status.values()):
        return "'status' is not a map of robot id to a map of fields"
    for key in ("ev", "mal"):
        if not isinstance(rec.get(key, []), list):
            return f"'{key}' is not a list"
    return None


# The world's own rows (ints, floats, strings, None) are packed by msgspec, which writes the same bytes as msgpack
# for these types (tests/unit/test_trace_codec.py) in a quarter of the time; anything a behaviour put in the
# record (status values, events) goes through ``pack``.
_ROWS = frozenset({"pos", "sent", "del", "ovh", "drop", "cmd"})
_encode_rows = msgspec.msgpack.Encoder().encode


def pack_record(rec: dict) -> bytes:
    """``pack(rec)``, with ``IntRows`` values (the world's delivery rows) packed from their arrays.

    A msgpack map is its header followed by each key and value in order, so the bytes are the same as packing
    the record with every ``IntRows`` turned into its list of rows.
    """
    n = len(rec)
    parts = [bytes([0x80 | n]) if n < 16 else b"\xde" + n.to_bytes(2, "big")]
    for key, value in rec.items():
        parts.append(pack(key))
        parts.append(value.packb() if isinstance(value, IntRows)
                     else _encode_rows(value) if key in _ROWS else pack(value))
    return b"".join(parts)


def summarise(rec: dict) -> dict:
    """A canonical record as a summary trace holds it: ``del``, ``ovh`` and ``drop`` replaced by counts.

    ``ndel`` is the number of deliveries, ``novh`` of overheard copies, ``ndrop`` the drops per cause (sorted by
    cause).
    """
    out = {k: v for k, v in rec.items() if k not in SUMMARISED}
    if rec.get("del"):
        out["ndel"] = len(rec["del"])
    if rec.get("ovh"):
        out["novh"] = len(rec["ovh"])
    if rec.get("drop"):
        causes: dict[str, int] = {}
        for row in rec["drop"]:
            causes[row[3]] = causes.get(row[3], 0) + 1
        out["ndrop"] = dict(sorted(causes.items()))
    return out


class TraceHasher:
    """Running digest of canonical tick records."""

    def __init__(self) -> None:
        self._h = hashlib.blake2b(digest_size=16)

    def update(self, rec: dict) -> None:
        self._h.update(pack_record(rec))

    def update_bytes(self, data: bytes) -> None:
        """``update`` for a record already packed (``pack_record``)."""
        self._h.update(data)

    def hexdigest(self) -> str:
        return self._h.hexdigest()


class TraceWriter:
    """A world sink: writes the trace file (if ``path``) and computes the hash.

    ``mode`` (``run.trace``) is ``full`` (every record as it is hashed), ``summary`` (records without the
    per-(frame, receiver) ``del`` and ``drop`` lists, which become the counts ``ndel`` and ``ndrop``; the header
    says ``"mode": "summary"`` and the footer adds ``summary_hash``, the digest of the records as written) or
    ``off`` (no file). ``trace_hash`` is computed over the full records in every mode, so it is the same.

    A write failure (full disk, removed directory) does not stop the run: the
    hash goes on, the file is closed, and ``error`` says what happened. The file is
    flushed at least once per second (``FLUSH_S``), so a world killed mid-run loses at
    most the last second of its trace. ``compression = "zstd"`` writes the same msgpack
    stream through a Zstandard compressor (``run.trace_compression``); readers detect it
    by its magic number, and the hashes are over the records, not the bytes on disk.
    """

    def __init__(self, path: Path | None, header: dict, compression: str | None = None, mode: str = "full"):
        if mode not in MODES:
            raise ValueError(f"trace mode {mode!r}: must be one of {', '.join(MODES)}")
        self.mode = mode
        path = None if mode == "off" else path
        self.path = path
        self.summary_hasher = TraceHasher() if mode == "summary" else None
        self.hasher = TraceHasher()
        self.ticks = 0
        self.error: str | None = None
        self.header_hash: str | None = None
        self._file = None
        self._raw = None  # the file under a compressor
        self._flushed = time.monotonic()
        if path is not None:
            try:
                self._file = open(path, "wb", buffering=1 << 20)
                if compression == "zstd":
                    import zstandard

                    self._raw = self._file
                    self._file = zstandard.ZstdCompressor(level=3).stream_writer(self._raw, closefd=False)
                head = {"trace": "swarmactors", "version": VERSION, **header}
                if mode == "summary":
                    head["mode"] = "summary"
                self.header_hash = digest(head)
                self._file.write(pack(head))
                self._flush()  # the header is on disk as soon as the world opens
            except OSError as exc:
                self._fail(exc)

    def record(self, rec: dict) -> None:
        rec = canonical(rec)
        data = pack_record(rec)
        self.hasher.update_bytes(data)
        self.ticks += 1
        if self.summary_hasher is not None:
            data = pack_record(summarise(rec))
            self.summary_hasher.update_bytes(data)
        if self._file is not None:
            try:
                self._file.write(data)
                if time.monotonic() - self._flushed >= FLUSH_S:
                    self._flush()
            except OSError as exc:
                self._fail(exc)

    def _flush(self) -> None:
        if self._raw is not None:
            import zstandard

            self._file.flush(zstandard.FLUSH_BLOCK)  # a whole block, readable by itself
            self._raw.flush()
        else:
            self._file.flush()
        self._flushed = time.monotonic()

    def _fail(self, exc: OSError) -> None:
        self.error = f"trace {self.path}: {exc.strerror or exc}"
        for f in (self._file, self._raw):
            if f is not None:
                try:
                    f.close()
                except OSError:
                    pass
        self._file = self._raw = None

    @property
    def trace_hash(self) -> str:
        return self.hasher.hexdigest()

    def close(self) -> None:
        if self._file is not None:
            try:
                footer = {"end": True, "ticks": self.ticks, "trace_hash": self.trace_hash,
                          "header_hash": self.header_hash}
                if self.summary_hasher is not None:
                    footer["summary_hash"] = self.summary_hasher.hexdigest()
                self._file.write(pack(footer))
                self._file.close()
                if self._raw is not None:
                    self._raw.close()
                    self._raw = None
            except OSError as exc:
                self._fail(exc)
            self._file = None


def read_trace(path: str | Path) -> tuple[dict, list[dict], dict | None]:
    """Read a whole trace: ``(header, tick records, footer or None if truncated cleanly)``.

    Every record is held in memory (O(ticks)); what runs after a run streams with ``iter_trace`` instead.
    """
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
    """Yield the header, tick records and footer of a trace, checking each (one record in memory at a time)."""
    for _, obj in iter_offsets(path):
        yield obj


class _Inflated:
    """A zstd trace's decompressed stream, refused once it exceeds ``RATIO_FLOOR + MAX_RATIO`` x the bytes read.

    ``tee``: a file that receives every decompressed byte read (the replay's seekable copy), so the copy
    grows no faster than the checked stream.
    """

    def __init__(self, path: Path, raw, tee=None):
        import zstandard

        self.path, self.raw, self.tee = path, raw, tee
        self.reader = zstandard.ZstdDecompressor().stream_reader(raw, read_across_frames=True, closefd=True)
        self.out = 0

    def read(self, n: int = -1) -> bytes:
        data = self.reader.read(_READ_CHUNK if n < 0 or n > _READ_CHUNK else n)
        self.out += len(data)
        packed = self.raw.tell()
        if self.out > RATIO_FLOOR + MAX_RATIO * packed:
            raise TraceError(f"{self.path}: decompresses to more than {MAX_RATIO} times its size "
                             f"({self.out / 1e6:.0f} MB from the first {packed / 1e3:.0f} kB): "
                             "refused as a decompression bomb")
        if self.tee is not None:
            self.tee.write(data)
        return data

    def close(self) -> None:
        self.reader.close()


def is_compressed(path: str | Path) -> bool:
    """Whether the trace at ``path`` is a zstd stream; TraceError if it is not a non-empty regular file."""
    f, size = _open(Path(path))
    f.close()
    return size is None


def _open(path: Path, tee=None):
    """The trace file opened for reading, and its size (None: a compressed stream, of unknown length)."""
    try:
        st = path.stat()
        if not stat.S_ISREG(st.st_mode):  # /dev/zero, a FIFO: no end, or no data until someone writes
            raise TraceError(f"{path}: not a regular file")
        f = open(path, "rb")
    except OSError as exc:
        raise TraceError(f"{path}: cannot open: {exc.strerror}") from None
    if st.st_size == 0:
        f.close()
        raise TraceError(f"{path}: empty file at byte offset 0 (the run wrote no trace data)")
    if f.read(4) == ZSTD_MAGIC:  # a compressed trace: offsets are in the decompressed stream
        f.seek(0)
        return _Inflated(path, f, tee), None
    f.seek(0)
    return f, st.st_size


class _Budget:
    """Counts the lists and maps msgpack builds for one record (its ``list_hook``/``object_hook``)."""

    def __init__(self) -> None:
        self.left = MAX_RECORD_CONTAINERS

    def take(self, obj):
        self.left -= 1
        if self.left < 0:
            raise _TooManyContainers
        return obj


class _TooManyContainers(Exception):
    pass


def iter_offsets(path: str | Path, stream=None, start: int = 0, tee=None) -> Iterator[tuple[int, dict]]:
    """Yield ``(byte offset, object)`` for the header, tick records and footer of a trace, checking each.

    Offsets are in the msgpack stream (the decompressed one for a zstd trace). ``stream``: read this
    seekable plain msgpack stream (``Replay``'s copy) from byte ``start`` instead of opening ``path``; the
    header is then only checked when ``start`` is 0. ``tee``: a file that receives a zstd trace's
    decompressed bytes as they are read. A record beyond ``MAX_RECORD_BYTES`` or ``MAX_RECORD_CONTAINERS``, and
    a zstd stream beyond ``MAX_RATIO``, are a TraceError naming the file and the bound, before the memory or
    disk it would take is used.
    """
    path = Path(path)
    if stream is None:
        f, size = _open(path, tee)
    else:
        stream.seek(0, 2)
        f, size = None, stream.tell()
        stream.seek(start)
    budget = _Budget()
    try:
        unpacker = msgpack.Unpacker(f if f is not None else stream, raw=False, strict_map_key=False,
                                    max_buffer_size=MAX_RECORD_BYTES, list_hook=budget.take,
                                    object_hook=budget.take)
        first = start == 0
        offset = start
        while True:
            budget.left = MAX_RECORD_CONTAINERS
            try:
                obj = unpacker.unpack()
            except msgpack.OutOfData:
                if (size is not None and offset < size) or (size is None and start + unpacker.tell() > offset):
                    raise TraceError(f"{path}: truncated record at byte offset {offset}") from None
                return
            except TraceError:
                raise
            except msgpack.BufferFull:
                raise TraceError(f"{path}: the record at byte offset {offset} is larger than "
                                 f"{MAX_RECORD_BYTES >> 20} MiB, the bound on one record") from None
            except _TooManyContainers:
                raise TraceError(f"{path}: the record at byte offset {offset} holds more than "
                                 f"{MAX_RECORD_CONTAINERS:,} lists and maps, the bound on one record") from None
            except ValueError as exc:
                if "exceeds max_" in str(exc):  # a string, list or map longer than a record may be
                    raise TraceError(f"{path}: the record at byte offset {offset} is larger than "
                                     f"{MAX_RECORD_BYTES >> 20} MiB, the bound on one record ({exc})") from None
                raise TraceError(f"{path}: corrupt data at byte offset {offset}: {exc}") from None
            except Exception as exc:
                raise TraceError(f"{path}: corrupt data at byte offset {offset}: {exc}") from None
            if not isinstance(obj, dict):
                raise TraceError(f"{path}: byte offset {offset}: expected a map, found {type(obj).__name__}")
            if first:
                if obj.get("trace") != "swarmactors":
                    raise TraceError(f"{path}: byte offset 0: not a swarmactors trace (no header)")
                if obj.get("version") not in READABLE:
                    raise TraceError(f"{path}: trace version {obj.get('version')!r}, this reader knows "
                                     f"{', '.join(map(str, READABLE))}")
                first = False
            elif not obj.get("end"):
                if not isinstance(obj.get("t"), int):
                    raise TraceError(f"{path}: byte offset {offset}: tick record without an integer 't'")
                problem = record_problem(obj)
                if problem:
                    raise TraceError(f"{path}: byte offset {offset}: tick {obj['t']}: {problem}")
            here = offset
            offset = start + unpacker.tell()
            yield here, obj
    finally:
        if f is not None:
            f.close()


def hash_problem(header: dict, records: Iterable[dict], footer: dict | None) -> str | None:
    """Whether a trace's records and header match the hashes in its footer (None: they do, or no footer).

    ``records`` is read once, in order (a generator streams them).
    """
    if footer is None:
        return None
    h = TraceHasher()
    for rec in records:
        h.update(rec)
    return footer_problem(header, h.hexdigest(), footer)


def footer_problem(header: dict, records_hash: str, footer: dict | None) -> str | None:
    """``hash_problem`` for a digest of the records computed by the caller (``TraceHasher``) while streaming."""
    if footer is None:
        return None
    if header.get("mode") == "summary":  # the records as written: their own digest (trace_hash is the full run's)
        if footer.get("summary_hash") != records_hash:
            return (f"hash mismatch: footer summary_hash {footer.get('summary_hash')}, records {records_hash} "
                    "(edited or corrupt)")
    elif footer.get("trace_hash") != records_hash:
        return f"hash mismatch: footer {footer.get('trace_hash')}, records {records_hash} (edited or corrupt)"
    if footer.get("header_hash") is not None and footer["header_hash"] != digest(header):
        return "the header does not match its hash in the footer (edited or corrupt)"
    return None


def verify(path: str | Path) -> str:
    """Recompute the hashes of a trace file and compare them with its footer's; the trace hash (streamed)."""
    header, footer = None, None
    h = TraceHasher()
    for obj in iter_trace(path):
        if header is None:
            header = obj
        elif obj.get("end"):
            footer = obj
        else:
            h.update(obj)
    if footer is None:
        raise TraceError(f"{path}: no footer (the run did not finish writing the trace)")
    problem = footer_problem(header, h.hexdigest(), footer)
    if problem:
        raise TraceError(f"{path}: {problem}")
    return footer["trace_hash"]
