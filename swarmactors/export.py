"""``swarmactors export RUN``: a run's trace as tables for pandas, R or a spreadsheet.

Two tables, both built from the trace (``trace.msgpack``) beside ``result.json``:

* **poses**: one row per (tick, alive robot): ``tick, id, x, y[, z]`` and one column per status field,
  holding the robot's value of that field at that tick (the trace records changes; they are carried forward).
  Headings are not in the trace, so not in the table.
* **frames**: one row per frame sent and per (frame, receiver) outcome, in each tick deliveries, then
  transmissions, then drops: ``tick, src, seq, kind, dst, size,
  outcome, sent_tick``. ``outcome`` is ``sent`` (the transmission, ``dst`` empty for a broadcast),
  ``delivered`` (``tick`` is the delivery tick, ``sent_tick`` the send tick) or the drop cause (``range``,
  ``loss``, ``cut``, ``bandwidth``, ``dead``).

Formats: ``csv`` (``poses.csv``, ``frames.csv``), ``json`` (``poses.json``, ``frames.json``: lists of
records), ``parquet`` (needs pyarrow: ``pip install 'swarmactors[export]'``). Status values that are lists or
maps are written as JSON text in csv and parquet.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

FORMATS = ("csv", "json", "parquet")
FRAME_COLUMNS = ("tick", "src", "seq", "kind", "dst", "size", "outcome", "sent_tick")
PARQUET_MISSING = ("parquet export needs pyarrow, which is not installed: pip install 'swarmactors[export]' "
                   "(or pip install pyarrow); csv and json need nothing more")
PANDAS_MISSING = "this needs pandas, which is not installed: pip install pandas"


class ExportError(Exception):
    """Bad input for an export (no trace, unknown format, missing optional dependency)."""


def _records(run) -> tuple[dict, list[dict]]:
    from swarmactors.result import Result
    from swarmactors.trace import read_trace

    if isinstance(run, Result):
        if run.trace_path is None:
            raise ExportError("this run has no trace (run.trace = false?): nothing to export")
        return run["scenario"], run.trace
    path = Path(run)
    if path.is_dir():
        path = path / "trace.msgpack"
    elif path.name == "result.json":
        return _records(Result.load(path))
    if not path.exists():
        raise ExportError(f"{path}: no such trace (give a run directory, its result.json or its trace)")
    header, records, _ = read_trace(path)
    return header.get("scenario", {}), records


def pose_rows(records: list[dict]) -> tuple[list[str], list[dict]]:
    """Per-tick per-robot rows (status fields carried forward) and the column names, in order."""
    status: dict[int, dict] = {}
    fields: dict[str, None] = {}
    rows = []
    dims = 2
    for rec in records:
        for rid, changed in rec.get("status", {}).items():
            status.setdefault(int(rid), {}).update(changed)
            fields.update(dict.fromkeys(changed))
        for row in rec.get("pos", ()):
            dims = max(dims, len(row) - 1)
            out = {"tick": rec["t"], "id": row[0], "x": row[1], "y": row[2]}
            if len(row) > 3:
                out["z"] = row[3]
            out.update(status.get(row[0], {}))
            rows.append(out)
    columns = ["tick", "id", "x", "y"] + (["z"] if dims > 2 else []) + sorted(fields)
    return columns, rows


def frame_rows(records: list[dict]) -> list[dict]:
    """Rows of every frame sent, delivered and dropped (see the module's docstring)."""
    meta: dict[tuple[int, int], tuple] = {}
    rows = []
    for rec in records:
        t = rec["t"]
        for src, seq, dst, sent_tick in rec.get("del", ()):
            kind, size, _ = meta.get((src, seq), (None, None, None))
            rows.append({"tick": t, "src": src, "seq": seq, "kind": kind, "dst": dst, "size": size,
                         "outcome": "delivered", "sent_tick": sent_tick})
        for src, seq, kind, dst, size in rec.get("sent", ()):
            meta[src, seq] = (kind, size, t)
            rows.append({"tick": t, "src": src, "seq": seq, "kind": kind, "dst": dst, "size": size,
                         "outcome": "sent", "sent_tick": t})
        for src, seq, dst, cause in rec.get("drop", ()):
            kind, size, sent_tick = meta.get((src, seq), (None, None, None))
            rows.append({"tick": t, "src": src, "seq": seq, "kind": kind, "dst": dst, "size": size,
                         "outcome": cause, "sent_tick": sent_tick})
    return rows


def tables(run) -> dict[str, tuple[list[str], list[dict]]]:
    """``{"poses": (columns, rows), "frames": (columns, rows)}`` for a run (directory, result.json, trace or Result)."""
    _, records = _records(run)
    return {"poses": pose_rows(records), "frames": (list(FRAME_COLUMNS), frame_rows(records))}


def export(run, out_dir: str | Path, fmt: str = "csv") -> list[Path]:
    """Write the run's tables as ``out_dir/poses.<fmt>`` and ``out_dir/frames.<fmt>``; returns the paths."""
    if fmt not in FORMATS:
        raise ExportError(f"--format {fmt}: choose one of {', '.join(FORMATS)}")
    if fmt == "parquet":
        _pyarrow()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, (columns, rows) in tables(run).items():
        path = out_dir / f"{name}.{fmt}"
        if fmt == "csv":
            with path.open("w", newline="") as f:
                w = csv.DictWriter(f, fieldnames=columns, extrasaction="ignore")
                w.writeheader()
                w.writerows({k: _flat(v) for k, v in r.items()} for r in rows)
        elif fmt == "json":
            path.write_text(json.dumps([{c: r.get(c) for c in columns} for r in rows]))
        else:
            _write_parquet(path, columns, rows)
        paths.append(path)
    return paths


def poses_frame(run):
    """The poses table as a pandas DataFrame (needs pandas)."""
    pd = _pandas()
    columns, rows = tables(run)["poses"]
    return pd.DataFrame.from_records(rows, columns=columns)


def frames_frame(run):
    """The frames table as a pandas DataFrame (needs pandas)."""
    pd = _pandas()
    return pd.DataFrame.from_records(frame_rows(_records(run)[1]), columns=list(FRAME_COLUMNS))


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


def _write_parquet(path: Path, columns: list[str], rows: list[dict]) -> None:
    pa = _pyarrow()
    import pyarrow.parquet as pq

    data = {}
    for c in columns:
        col = [r.get(c) for r in rows]
        if any(isinstance(v, (list, dict, tuple)) for v in col) or len({type(v) for v in col} - {type(None)}) > 1:
            col = [None if v is None else (v if isinstance(v, str) else json.dumps(v)) for v in col]
        data[c] = col
    pq.write_table(pa.table(data), path)


def add_parser(sub) -> None:
    """Register ``swarmactors export`` on the command line's subparsers."""
    sp = sub.add_parser("export", help="write a run's trace as tables (poses, frames) in csv, json or parquet")
    sp.add_argument("run", type=Path, help="run directory (with result.json and trace.msgpack), or the trace file")
    sp.add_argument("--format", choices=FORMATS, default="csv", help="table format (parquet needs pyarrow)")
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
