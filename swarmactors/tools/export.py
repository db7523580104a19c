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
``run.mcap``, for Foxglove (``swarmactors.tools.mcap_export``; needs ``pip install 'swarmactors[foxglove]'``).
Status values that are lists or maps are written as JSON text in csv and parquet.

The trace is streamed twice (once for the columns and their types, once for the rows) and the rows are
written as they come, so an export's memory is O(N), not O(ticks) (parquet: one row group of
``PARQUET_ROWS`` rows at a time). A DataFrame (``dataframe``) holds its whole table, by its nature.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from swarmactors.oracle.trace_tables import (  # noqa: F401 (the tables' rows, also read from here)
    FRAME_COLUMNS,
    FRAME_KINDS,
    PANDAS_MISSING,
    TABLES,
    Headings,
    frame_rows,
    frame_window,
    initial_headings,
    iter_frame_rows,
    iter_pose_rows,
    pose_columns,
    pose_rows,
    table_frame,
)
from swarmactors.oracle.trace_tables import table as _table

FORMATS = ("csv", "json", "parquet", "mcap")
PARQUET_ROWS = 65_536  # rows per parquet row group: what an export holds at a time
PARQUET_MISSING = ("parquet export needs pyarrow, which is not installed: pip install 'swarmactors[export]' "
                   "(or pip install pyarrow); csv and json need nothing more")


class ExportError(Exception):
    """Bad input for an export (no trace, unknown format, missing optional dependency)."""


def _source(run) -> tuple[dict, Callable[[], Iterator[dict]]]:
    """The run's resolved scenario and a function that streams its tick records afresh at each call."""
    from swarmactors.oracle.result import Result
    from swarmactors.oracle.trace import iter_trace

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
    from swarmactors.oracle.result import Result
    from swarmactors.oracle.trace import iter_trace
    from swarmactors.tools.foxglove_topics import FoxgloveMissing
    from swarmactors.tools.mcap_export import MCAP_NAME, result_beside, write_mcap

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
    try:
        import pandas  # noqa: F401 (said before the run is read)
    except ImportError:
        raise ExportError(PANDAS_MISSING) from None
    if name not in TABLES:
        raise ExportError(f"no table {name!r}: choose one of {', '.join(TABLES)}")
    return table_frame(name, *_source(run))


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
