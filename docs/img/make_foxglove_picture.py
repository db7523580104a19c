"""Draw a run's MCAP file (``swarmactors export RUN --format mcap``) as Foxglove's panels would show it.

Foxglove itself cannot run where the docs are built, so this reads the file back with the ``mcap`` library and
its protobuf decoder and draws, with matplotlib, what three panels of a Foxglove layout show: the 3D panel seen
from above at one tick (``/world``, ``/radio/links``, ``/radio/frames``, ``/robots/bodies`` placed by ``/tf``), a
Plot panel of ``/radio/counts`` over the run, and a Log panel of ``/events``. Every mark comes from the MCAP
file; nothing is read from the trace.

Usage: ``python docs/img/make_foxglove_picture.py RUN/run.mcap OUT.png --tick T``
(docs/img/foxglove-mcap.png: scenarios/maze-flood.toml with ``--set 'events=[{at = 2, kill = [5, 9]}]'``,
tick 3).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.collections import LineCollection, PatchCollection  # noqa: E402
from matplotlib.patches import Polygon, Rectangle  # noqa: E402
from mcap.reader import make_reader  # noqa: E402
from mcap_protobuf.decoder import DecoderFactory  # noqa: E402

LEVELS = {1: "DEBUG", 2: "INFO", 3: "WARN", 4: "ERROR", 5: "FATAL"}


def read(path: Path) -> dict[str, list]:
    """Topic -> [(log time ns, message)], JSON decoded as dicts and protobuf by the schema in the file."""
    out: dict[str, list] = {}
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message in reader.iter_messages(log_time_order=True):
            if channel.message_encoding == "json":
                msg = json.loads(message.data)
            else:
                msg = DecoderFactory().decoder_for("protobuf", schema)(message.data)
            out.setdefault(channel.topic, []).append((message.log_time, msg))
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
    out["_dt"] = float(meta["run"]["dt"])
    return out


def at(messages: list, ns: int):
    """The newest message at or before ``ns`` (what Foxglove shows at that time)."""
    before = [m for t, m in messages if t <= ns]
    return before[-1] if before else None


def draw_scene(ax, got: dict, ns: int) -> None:
    world = at(got["/world"], ns)
    for e in world.entities:
        for line in e.lines:
            pts = [(p.x, p.y) for p in line.points]
            ax.add_collection(LineCollection([pts[i:i + 2] for i in range(0, len(pts), 2)], colors="0.5", lw=0.8))
        if e.cubes and e.id == "obstacles":
            ax.add_collection(PatchCollection(
                [Rectangle((c.pose.position.x - c.size.x / 2, c.pose.position.y - c.size.y / 2), c.size.x, c.size.y)
                 for c in e.cubes], facecolor="0.35", edgecolor="none"))
        for tri in e.triangles:
            pts = [(p.x, p.y) for p in tri.points]
            ax.add_collection(PatchCollection([Polygon(pts[i:i + 3]) for i in range(0, len(pts), 3)], facecolor="0.35"))
        if e.id == "objects":
            for c, text in zip(e.cubes, e.texts, strict=True):
                ax.plot(c.pose.position.x, c.pose.position.y, "D", color="#f1a340", mec="k")
                ax.annotate(text.text, (c.pose.position.x, c.pose.position.y), xytext=(4, 4),
                            textcoords="offset points", fontsize=8)
    for topic in ("/radio/links", "/radio/frames"):
        update = at(got[topic], ns)
        for e in update.entities:
            for line in e.lines:
                pts = [(p.x, p.y) for p in line.points]
                idx = list(line.indices)
                segs = [(pts[idx[i]], pts[idx[i + 1]]) for i in range(0, len(idx), 2)]
                colour = (line.color.r, line.color.g, line.color.b)
                ax.add_collection(LineCollection(segs, colors=[colour], lw=0.6 if topic == "/radio/links" else 1.4,
                                                 zorder=1 if topic == "/radio/links" else 2))
    tf = at(got["/tf"], ns)
    where = {t.child_frame_id: (t.translation.x, t.translation.y) for t in tf.transforms}
    bodies = at(got["/robots/bodies"], ns)
    for e in bodies.entities:
        if e.id.startswith("robot/") and e.frame_id in where:
            x, y = where[e.frame_id]
            s = e.spheres[0]
            ax.add_patch(plt.Circle((x, y), s.size.x / 2, facecolor=(s.color.r, s.color.g, s.color.b),
                                    edgecolor="0.2", lw=0.5, zorder=3))
            ax.annotate(e.texts[0].text, (x, y), fontsize=5, ha="center", va="center", zorder=4)
        elif e.id.startswith("failed/"):
            pts = [(p.x, p.y) for p in e.lines[0].points]
            ax.add_collection(LineCollection([pts[0:2], pts[2:4]], colors="red", lw=1.5, zorder=4))
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_title(f"3D panel from above, t = {ns / 1e9:g} s: /world, /radio/links, /radio/frames, "
                 "/robots/bodies on /tf", fontsize=8)


def draw_counts(ax, got: dict, dt: float) -> None:
    counts = [m for _, m in got["/radio/counts"]]
    t = [c["tick"] * dt for c in counts]
    ax.plot(t, [c["sent"] for c in counts], label="/radio/counts.sent")
    ax.plot(t, [c["delivered"] for c in counts], label="/radio/counts.delivered")
    for cause in ("range", "occluded", "dead"):
        ax.plot(t, [c["dropped"].get(cause, 0) for c in counts], label=f"/radio/counts.dropped.{cause}", lw=1)
    ax.set_xlabel("time (s): tick × run.dt")
    ax.set_ylabel("frames per tick")
    ax.legend(fontsize=6)
    ax.set_title("Plot panel", fontsize=8)


def draw_log(ax, got: dict) -> None:
    lines = [f"{ns / 1e9:7.2f}  {LEVELS.get(m.level, '?'):5s} {m.name:9s} {m.message}" for ns, m in got["/events"]]
    ax.axis("off")
    ax.set_title("Log panel: /events", fontsize=8)
    ax.text(0.0, 1.0, "\n".join(lines[:14]) or "(no events)", family="monospace", fontsize=7, va="top",
            transform=ax.transAxes)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mcap", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument("--tick", type=int, default=0)
    args = ap.parse_args()
    got = read(args.mcap)
    fig = plt.figure(figsize=(12, 6.2), dpi=110)
    grid = fig.add_gridspec(2, 2, width_ratios=[1.15, 1], height_ratios=[1.2, 1])
    draw_scene(fig.add_subplot(grid[:, 0]), got, round(args.tick * got["_dt"] * 1e9))
    draw_counts(fig.add_subplot(grid[0, 1]), got, got["_dt"])
    draw_log(fig.add_subplot(grid[1, 1]), got)
    fig.suptitle(f"{args.mcap.name}, drawn from the MCAP file by matplotlib (what Foxglove's panels show)",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(args.out)
    print(args.out)


if __name__ == "__main__":
    main()
