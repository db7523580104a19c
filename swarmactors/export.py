"""``swarmactors export RUN``: a run's trace as tables for pandas, R or a spreadsheet.

Two tables, both built from the trace (``trace.msgpack``) beside ``result.json``:

* **poses**: one row per (tick, alive robot): ``tick, id, x, y[, z], heading`` and one column per status field,
  holding the robot's value of that field at that tick (the trace records changes; they are carried forward).
  The trace records positions, not headings: ``heading`` is derived (``headings``), exact where a robot's
  last recorded move was a whole step, as docs/analysis.md says.
* **frames**: one row per frame sent and per (frame, receiver) outcome, in each tick deliveries, then
  overheard copies, then transmissions, then drops: ``tick, src, seq, kind, dst, size,
  outcome, sent_tick``. ``outcome`` is ``sent`` (the transmission, ``dst`` empty for a broadcast),
  ``delivered`` (``tick`` is the delivery tick, ``sent_tick`` the send tick), ``overheard`` (a copy that
  reached a robot on the broadcast's exclude list, which discarded it) or the drop cause (``range``,
  ``loss``, ``cut``, ``bandwidth``, ``dead``).

Formats: ``csv`` (``poses.csv``, ``frames.csv``), ``json`` (``poses.json``, ``frames.json``: lists of
records), ``parquet`` (needs pyarrow: ``pip install 'swarmactors[export]'``); ``mcap`` writes instead one file,
``run.mcap``, for Foxglove (``swarmactors.mcap_export``; needs ``pip install 'swarmactors[foxglove]'``).
Status values that are lists or maps are written as JSON text in csv and parquet.

The trace is streamed twice (once for the columns and their types, once for the rows) and the rows are
written as they come, so an export's memory is O(N), not O(ticks) (parquet: one row group of
``PARQUET_ROWS`` rows at a time). A DataFrame (``dataframe``) holds its whole table, by its nature.
"""

from __future__ import annotations

import csv
import json
import math
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

FORMATS = ("csv", "json", "parquet", "mcap")
TABLES = ("poses", "frames")
FRAME_COLUMNS = ("tick", "src", "seq", "kind", "dst", "size", "outcome", "sent_tick")
PARQUET_ROWS = 65_536  # rows per parquet row group: what an export holds at a time
PARQUET_MISSING = ("parquet export needs pyarrow, which is not installed: pip install 'swarmactors[export]' "
                   "(or pip install pyarrow); csv and json need nothing more")
PANDAS_MISSING = "this needs pandas, which is not installed: pip install pandas"


class ExportError(Exception):
    """Bad input for an export (no trace, unknown format, missing optional dependency)."""


def _source(run) -> tuple[dict, Callable[[], Iterator[dict]]]:
    """The run's resolved scenario and a function that streams its tick records afresh at each call."""
    from swarmactors.result import Result
    from swarmactors.trace import iter_trace

    if isinstance(run, Result):
        if run.trace_path is None:
            raise ExportError("this run has no trace (run.trace = false?): nothing to export")
        return run["scenario"], run.records
    path = Path(run)
    if path.is_dir():
        path = path / "trace.msgpack"
    elif path.name == "result.json":
        return _source(Result.load(path))
    if not path.exists():
        raise ExportError(f"{path}: no such trace (give a run directory, its result.json or its trace)")
    header = next(iter_trace(path))

    def records() -> Iterator[dict]:
        for obj in iter_trace(path):
            if "t" in obj and not obj.get("end"):
                yield obj

    return header.get("scenario", {}), records


def initial_headings(scenario: dict) -> dict[int, float]:
    """Robot id -> heading at the start, from the resolved scenario's groups (robots in id order)."""
    out: dict[int, float] = {}
    for g in scenario.get("robots", []):
        for _ in g.get("positions") or []:
            out[len(out)] = float(g.get("heading") or 0.0)
    return out


class Headings:
    """Each robot's heading as far as the trace determines it, fed one tick record at a time.

    The world turns a holonomic robot to the direction of each step it takes, and a unicycle advances along its
    new heading (world/kinematics.py); the record of tick t holds the positions before tick t's step. So the
    heading at tick t is the direction (atan2 in the xy plane) of the last recorded move before it, and the
    scenario's ``heading`` before any move (``start``; None for a robot added during the run, whose heading the
    trace does not hold). It differs from the world's heading when that move was cut (the world's bounds, a
    wall, ``world.blocking``), for a unicycle that turned without advancing (a turn of more than 90° to go), and
    by up to ~1e-6 / step length rad from the positions' rounding.
    """

    def __init__(self, start: dict[int, float] | None = None):
        self.heading: dict[int, float | None] = dict(start or {})
        self.last: dict[int, tuple[float, float]] = {}

    def feed(self, rec: dict) -> dict[int, float | None]:
        """The headings of the robots alive at this record's tick."""
        for row in rec.get("pos", ()):
            rid, xy = row[0], (row[1], row[2])
            before = self.last.get(rid)
            if before is not None and xy != before:
                self.heading[rid] = math.atan2(xy[1] - before[1], xy[0] - before[0])
            self.last[rid] = xy
        return {row[0]: self.heading.get(row[0]) for row in rec.get("pos", ())}


def pose_columns(records: Iterable[dict]) -> tuple[list[str], dict[str, set]]:
    """The poses table's columns, in order, and the Python types each one holds (one pass over the records)."""
    kinds: dict[str, set] = {}
    dims = 2
    for rec in records:
        for changed in rec.get("status", {}).values():
            for k, v in changed.items():
                kinds.setdefault(k, set()).add(type(v))
        for row in rec.get("pos", ()):
            dims = max(dims, len(row) - 1)
    fields = [f for f in sorted(kinds) if f not in ("tick", "id", "x", "y", "z", "heading")]
    return ["tick", "id", "x", "y"] + (["z"] if dims > 2 else []) + ["heading"] + fields, kinds


def iter_pose_rows(records: Iterable[dict], start: dict[int, float] | None = None) -> Iterator[dict]:
    """Per-tick per-robot rows (heading derived, status fields carried forward), streamed."""
    status: dict[int, dict] = {}
    heads = Headings(start)
    for rec in records:
        heading = heads.feed(rec)
        for rid, changed in rec.get("status", {}).items():
            status.setdefault(int(rid), {}).update(changed)
        for row in rec.get("pos", ()):
            out = {"tick": rec["t"], "id": row[0], "x": row[1], "y": row[2]}
            if len(row) > 3:
                out["z"] = row[3]
            out["heading"] = heading[row[0]]
            out.update(status.get(row[0], {}))
            yield out


def pose_rows(records: list[dict], start: dict[int, float] | None = None) -> tuple[list[str], list[dict]]:
    """The poses table in memory: its columns and rows (small runs and tests; ``export`` streams)."""
    return pose_columns(records)[0], list(iter_pose_rows(records, start))


def iter_frame_rows(records: Iterable[dict], within: int | None = None) -> Iterator[dict]:
    """Rows of every frame sent, delivered and dropped (see the module's docstring), streamed.

    A delivery or drop names its frame by (src, seq) only, so the kind, size and send tick of each frame sent
    are kept until no row can name it any more: ``within`` ticks after its send (lockstep: ``radio.latency``;
    deliveries, and drops of receivers that died meanwhile, come exactly that many ticks after the send, other
    drops at it), or to the end of the run when ``within`` is None (realtime). A tick's frames sent are known
    before its deliveries are written: in realtime a frame is often delivered within the tick it was sent.
    """
    meta: dict[tuple[int, int], tuple] = {}
    sent_at: deque = deque()  # (send tick, [(src, seq), ...]) oldest first, when frames are forgotten
    for rec in records:
        t = rec["t"]
        while within is not None and sent_at and sent_at[0][0] < t - within:
            for key in sent_at.popleft()[1]:
                meta.pop(key, None)
        for src, seq, kind, _dst, size in rec.get("sent", ()):
            meta[src, seq] = (kind, size, t)
        for src, seq, dst, sent_tick in rec.get("del", ()):
            kind, size, _ = meta.get((src, seq), (None, None, None))
            yield {"tick": t, "src": src, "seq": seq, "kind": kind, "dst": dst, "size": size,
                   "outcome": "delivered", "sent_tick": sent_tick}
        for src, seq, dst, sent_tick in rec.get("ovh", ()):
            kind, size, _ = meta.get((src, seq), (None, None, None))
            yield {"tick": t, "src": src, "seq": seq, "kind": kind, "dst": dst, "size": size,
                   "outcome": "overheard", "sent_tick": sent_tick}
        for src, seq, kind, dst, size in rec.get("sent", ()):
            yield {"tick": t, "src": src, "seq": seq, "kind": kind, "dst": dst, "size": size,
                   "outcome": "sent", "sent_tick": t}
        if within is not None and rec.get("sent"):
            sent_at.append((t, [(row[0], row[1]) for row in rec["sent"]]))
        for src, seq, dst, cause in rec.get("drop", ()):
            kind, size, sent_tick = meta.get((src, seq), (None, None, None))
            yield {"tick": t, "src": src, "seq": seq, "kind": kind, "dst": dst, "size": size,
                   "outcome": cause, "sent_tick": sent_tick}


def frame_window(scenario: dict) -> int | None:
    """How long after its send a frame can still be named by a trace row (``iter_frame_rows``'s ``within``)."""
    run, radio = scenario.get("run") or {}, scenario.get("radio") or {}
    latency = radio.get("latency")
    if run.get("clock", "lockstep") == "lockstep" and isinstance(latency, int) and not isinstance(latency, bool):
        return latency
    return None


def frame_rows(records: list[dict]) -> list[dict]:
    """The frames table's rows in memory (small runs and tests; ``export`` streams)."""
    return list(iter_frame_rows(records))


FRAME_KINDS = {"tick": {int}, "src": {int}, "seq": {int}, "kind": {str}, "dst": {int}, "size": {int},
               "outcome": {str}, "sent_tick": {int}}


def _table(name: str, scenario: dict, records: Callable[[], Iterator[dict]]):
    """(columns, {column: Python types}, rows iterator) of one table; the poses' columns take a first pass."""
    if name == "poses":
        columns, kinds = pose_columns(records())
        kinds = kinds | {"tick": {int}, "id": {int}, "x": {float}, "y": {float}, "z": {float}, "heading": {float}}
        return columns, kinds, iter_pose_rows(records(), initial_headings(scenario))
    return list(FRAME_COLUMNS), FRAME_KINDS, iter_frame_rows(records(), frame_window(scenario))


def tables(run) -> dict[str, tuple[list[str], list[dict]]]:
    """``{"poses": (columns, rows), "frames": (columns, rows)}`` in memory (small runs; ``export`` streams)."""
    scenario, records = _source(run)
    out = {}
    for name in TABLES:
        columns, _, rows = _table(name, scenario, records)
        out[name] = (columns, list(rows))
    return out


def export(run, out_dir: str | Path, fmt: str = "csv") -> list[Path]:
    """Write the run's tables as ``out_dir/poses.<fmt>`` and ``out_dir/frames.<fmt>``, streamed; returns the paths."""
    if fmt not in FORMATS:
        raise ExportError(f"--format {fmt}: choose one of {', '.join(FORMATS)}")
    if fmt == "parquet":
        _pyarrow()
    scenario, records = _source(run)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if fmt == "mcap":
        return [_export_mcap(run, records, out_dir)]
    paths = []
    for name in TABLES:
        columns, kinds, rows = _table(name, scenario, records)
        path = out_dir / f"{name}.{fmt}"
        if fmt == "csv":
            nested = {c for c in columns if kinds.get(c, set()) & {list, dict, tuple}}  # written as JSON text
            with path.open("w", newline="") as f:
                w = csv.writer(f)
                w.writerow(columns)
                w.writerows([_flat(r.get(c)) if c in nested else r.get(c) for c in columns] for r in rows)
        elif fmt == "json":
            with path.open("w") as f:
                f.write("[")
                for i, r in enumerate(rows):
                    f.write((", " if i else "") + json.dumps({c: r.get(c) for c in columns}))
                f.write("]")
        else:
            _write_parquet(path, columns, kinds, rows)
        paths.append(path)
    return paths


def _export_mcap(run, records: Callable[[], Iterator[dict]], out_dir: Path) -> Path:
    """``out_dir/run.mcap``, from the run's trace and the result.json beside it (``mcap_export``)."""
    from swarmactors.foxglove_topics import FoxgloveMissing
    from swarmactors.mcap_export import MCAP_NAME, result_beside, write_mcap
    from swarmactors.result import Result
    from swarmactors.trace import iter_trace

    path = run.trace_path if isinstance(run, Result) else Path(run)
    path = path / "trace.msgpack" if path.is_dir() else path
    if path.name == "result.json":
        path = Result.load(path).trace_path
    header = next(iter_trace(path))
    try:
        return write_mcap(header, records, out_dir / MCAP_NAME, result_beside(path, header.get("run_id")))
    except FoxgloveMissing as exc:
        raise ExportError(str(exc)) from None


def dataframe(run, name: str):
    """The ``poses`` or ``frames`` table as a pandas DataFrame (needs pandas): the export's rows and columns."""
    pd = _pandas()
    if name not in TABLES:
        raise ExportError(f"no table {name!r}: choose one of {', '.join(TABLES)}")
    columns, _, rows = _table(name, *_source(run))
    return pd.DataFrame.from_records(rows, columns=columns)


def poses_frame(run):
    """The poses table as a pandas DataFrame (``dataframe(run, "poses")``)."""
    return dataframe(run, "poses")


def frames_frame(run):
    """The frames table as a pandas DataFrame (``dataframe(run, "frames")``)."""
    return dataframe(run, "frames")


def _flat(v):
    return json.dumps(v) if isinstance(v, (list, dict, tuple)) else v


def _pyarrow():
    try:
        import pyarrow
        import pyarrow.parquet  # noqa: F401
    except ImportError as exc:
        raise ExportError(PARQUET_MISSING) from exc
    return pyarrow


def _pandas():
    try:
        import pandas
    except ImportError as exc:
        raise ExportError(PANDAS_MISSING) from exc
    return pandas


def _arrow_type(pa, kinds: set):
    """A column's Arrow type from the Python types it holds: bool, int64, float64 (ints and floats), else text."""
    kinds = kinds - {type(None)}
    if kinds == {bool}:
        return pa.bool_()
    if kinds and kinds <= {int}:
        return pa.int64()
    if kinds and kinds <= {int, float}:
        return pa.float64()
    return pa.string()  # strings; lists, maps and mixed types as JSON text


def _cell(v, text: bool):
    if v is None or not text or isinstance(v, str):
        return v
    return json.dumps(v)


def _write_parquet(path: Path, columns: list[str], kinds: dict[str, set], rows: Iterable[dict]) -> None:
    pa = _pyarrow()
    import pyarrow.parquet as pq

    schema = pa.schema([(c, _arrow_type(pa, kinds.get(c, set()))) for c in columns])
    text = {c: schema.field(c).type == pa.string() for c in columns}
    with pq.ParquetWriter(path, schema) as writer:
        batch: list[dict] = []
        for r in rows:
            batch.append(r)
            if len(batch) >= PARQUET_ROWS:
                writer.write_table(_arrow_table(pa, schema, columns, text, batch))
                batch = []
        writer.write_table(_arrow_table(pa, schema, columns, text, batch))


def _arrow_table(pa, schema, columns: list[str], text: dict[str, bool], rows: list[dict]):
    return pa.table({c: [_cell(r.get(c), text[c]) for r in rows] for c in columns}, schema=schema)


def add_parser(sub) -> None:
    """Register ``swarmactors export`` on the command line's subparsers."""
    sp = sub.add_parser("export", help="write a run's trace as tables (poses, frames) in csv, json or parquet, "
                                      "or as an MCAP file for Foxglove")
    sp.add_argument("run", type=Path, help="run directory (with result.json and trace.msgpack), or the trace file")
    sp.add_argument("--format", choices=FORMATS, default="csv",
                    help="table format (parquet needs pyarrow), or mcap: one run.mcap file for Foxglove "
                         "(needs the [foxglove] extra)")
    sp.add_argument("--out", type=Path, help="directory for the tables (default: the run's directory)")


def command(args) -> int:
    """``swarmactors export``: exit 0, or 2 with a message on bad input or a missing optional dependency."""
    import sys

    from swarmactors.exitcodes import EXIT_INPUT, EXIT_OK

    out = args.out or (args.run if args.run.is_dir() else args.run.parent)
    try:
        for path in export(args.run, out, args.format):
            print(path)
    except ExportError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    return EXIT_OK
