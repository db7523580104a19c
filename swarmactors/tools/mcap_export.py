"""``swarmactors export RUN --format mcap``: a run as one MCAP file that Foxglove opens as it is.

The trace is streamed once: each tick record feeds a ``Scene`` (as a replay's) and ``SwarmTopics`` turns it into
the messages of ``foxglove_topics.CHANNELS``, written by the ``mcap`` library's writer (zstd chunks, with
indexes and statistics) as they come. The scenario, run id, seed and trace hash go in a ``run`` metadata record,
and, when the run's ``result.json`` lies beside the trace, its behaviour reports, counters and checks
(``/run/result``) and the robots' log lines (``/robots/log``). Memory: one tick record, the scene and the chunk
being written (docs/benchmarks.md). The file is written under a temporary name and renamed when complete, so a
corrupt trace leaves no half file behind.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator
from pathlib import Path

from swarmactors.tools.foxglove_topics import FoxgloveMissing, SwarmTopics, channel_specs
from swarmactors.tools.scene import Scene

MCAP_NAME = "run.mcap"
CHUNK_BYTES = 1 << 20  # uncompressed bytes per MCAP chunk: what the writer holds at a time


def _writer_module():
    try:
        from mcap import writer
    except ImportError as exc:
        from swarmactors.tools.foxglove_topics import FOXGLOVE_MISSING

        raise FoxgloveMissing(FOXGLOVE_MISSING) from exc
    return writer


def write_mcap(header: dict, records: Callable[[], Iterator[dict]], path: str | Path,
               result: dict | None = None) -> Path:
    """Write the run whose trace ``header`` and tick ``records`` are given (and its ``result``) to ``path``.

    ``records()`` streams the tick records in order (called once). Returns ``path``.
    """
    mcap_writer = _writer_module()
    sc = header.get("scenario") or {}
    dt = float((sc.get("run") or {}).get("dt", 1.0))
    ranges = {int(k): float(r["range"]) for k, r in (result or {}).get("robots", {}).items()
              if isinstance(r.get("range"), (int, float))}
    topics = SwarmTopics(sc, dt, ranges)
    scene = Scene(run_id=header.get("run_id", ""), clock=header.get("clock", "lockstep"), scenario=sc,
                  mode="replay")
    scene.ranges.update(ranges)
    path = Path(path)
    partial = path.with_name(path.name + ".partial")
    try:
        with partial.open("wb") as f:
            writer = mcap_writer.Writer(f, chunk_size=CHUNK_BYTES, compression=mcap_writer.CompressionType.ZSTD)
            writer.start(profile="", library="swarmactors")
            channels: dict[str, int] = {}
            for spec in channel_specs():
                schema = writer.register_schema(spec.schema_name, spec.schema_encoding, spec.schema)
                channels[spec.topic] = writer.register_channel(spec.topic, spec.encoding, schema)
            sequence = dict.fromkeys(channels, 0)

            def write(messages) -> None:
                for topic, ns, data in messages:
                    sequence[topic] += 1
                    writer.add_message(channels[topic], log_time=ns, data=data, publish_time=ns,
                                       sequence=sequence[topic])

            last = 0
            for rec in records():
                scene.feed_record(rec)
                write(topics.update(scene, rec, every_tick=True))
                scene.events = []  # published: the scene need not keep them
                last = rec["t"]
            if result is not None:
                write(topics.result(result, last))
            writer.add_metadata("run", {
                "run_id": str(header.get("run_id", "")), "seed": str(header.get("seed", "")),
                "clock": str(header.get("clock", "")), "dt": repr(dt),
                "trace_hash": str((result or {}).get("trace_hash") or ""),
                "scenario": json.dumps(sc)})
            writer.finish()
        partial.replace(path)
    finally:
        partial.unlink(missing_ok=True)
    return path


def result_beside(trace: Path, run_id: str | None) -> dict | None:
    """The ``result.json`` beside a trace when it belongs to the same run (else None: the trace alone)."""
    path = trace.parent / "result.json"
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and data.get("run_id") == run_id else None
