"""Replaying a trace: the viewer's time slider, and animations rendered with matplotlib.

``Replay(trace)`` reads a trace file (and the ``result.json`` beside it, when
there is one, for robot ranges and log lines) and gives the ``Scene`` at any
tick. Scenes are rebuilt from checkpoints taken every ``CHECKPOINT_EVERY``
ticks, so a seek costs at most that many records.

``render(trace, out)`` draws one frame per rendered tick (every ``every``-th
tick, and the last) into a GIF (Pillow) or an MP4 (ffmpeg).
"""

from __future__ import annotations

import bisect
import json
from collections.abc import Callable
from pathlib import Path

from swarmactors.scene import Scene
from swarmactors.trace import TraceError, read_trace

CHECKPOINT_EVERY = 64


class Replay:
    """A trace file as a sequence of scenes."""

    def __init__(self, trace: str | Path):
        self.path = Path(trace)
        header, records, footer = read_trace(self.path)  # TraceError names the file and the offset
        if header is None:
            raise TraceError(f"{self.path}: no header")
        if not records:
            raise TraceError(f"{self.path}: the trace holds no tick record")
        self.header = header
        self.records = records
        self.footer = footer
        self.first = records[0]["t"]
        self.last = records[-1]["t"]
        self._ticks = [r["t"] for r in records]
        self.note = None if footer is not None else "this trace has no footer: the run was cut short"
        self.result = self._result_beside()
        sc = header.get("scenario") or {}
        self._base = Scene(run_id=header.get("run_id", ""), clock=header.get("clock", "lockstep"),
                           ticks=len(records), scenario=sc, mode="replay")
        if self.result is not None:
            for rid, r in self.result.get("robots", {}).items():
                if isinstance(r.get("range"), (int, float)):
                    self._base.ranges[int(rid)] = float(r["range"])
                if r.get("log"):
                    self._base.logs[int(rid)] = list(r["log"])
        self._checkpoints: list[tuple[int, Scene]] = []  # (index of the next record to feed, scene)
        self._full: Scene | None = None

    def _result_beside(self) -> dict | None:
        path = self.path.parent / "result.json"
        if not path.exists():
            return None
        try:
            data = json.loads(path.read_text())
        except (OSError, ValueError):
            return None
        if data.get("run_id") != self.header.get("run_id"):
            return None  # another run's result
        return data

    def scene_at(self, t: int) -> Scene:
        """The scene after tick ``t``'s record (clamped to the trace)."""
        idx = bisect.bisect_right(self._ticks, t)  # records to feed: [0, idx)
        idx = max(1, min(idx, len(self.records)))
        start, scene = 0, self._base
        if self._checkpoints:
            k = bisect.bisect_right([c[0] for c in self._checkpoints], idx) - 1
            if k >= 0:
                start, scene = self._checkpoints[k]
        scene = scene.copy()
        for i in range(start, idx):
            scene.feed_record(self.records[i])
            if (i + 1) % CHECKPOINT_EVERY == 0 and (not self._checkpoints or self._checkpoints[-1][0] < i + 1):
                self._checkpoints.append((i + 1, scene.copy()))
        scene.finished = idx == len(self.records) and self.footer is not None
        return scene

    def full_scene(self) -> Scene:
        if self._full is None:
            self._full = self.scene_at(self.last)
        return self._full

    def ticks(self) -> list[int]:
        return list(self._ticks)


# ---------------------------------------------------------------- animations
def render(trace: str | Path, out: str | Path, every: int = 1, fps: float = 10.0, field: str | None = None,
           progress: Callable[[int, int], None] | None = None) -> int:
    """Write an animation of the trace to ``out`` (.gif or .mp4); return the number of frames."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import animation

    out = Path(out)
    suffix = out.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise ValueError(f"{out}: the animation file must end in .gif or .mp4")
    if every < 1:
        raise ValueError(f"--every {every}: must be >= 1")
    if suffix == ".mp4" and not animation.writers.is_available("ffmpeg"):
        raise ValueError(f"{out}: writing MP4 needs ffmpeg on the PATH (apt-get install ffmpeg), or write a .gif")
    replay = Replay(trace)
    ticks = replay.ticks()[::every]
    if ticks[-1] != replay.last:
        ticks.append(replay.last)
    scenes = _scenes_along(replay, ticks)
    field = field or replay._base.field
    lo, hi = _extent(replay, scenes)
    fig, ax = plt.subplots(figsize=(6.4, 6.0), dpi=80)
    writer = animation.PillowWriter(fps=fps) if suffix == ".gif" else animation.FFMpegWriter(fps=fps)
    name = replay.header.get("scenario", {}).get("run", {}).get("name", replay.header.get("run_id", ""))
    with writer.saving(fig, str(out), dpi=80):
        for i, scene in enumerate(scenes):
            ax.clear()
            draw_scene(ax, scene, field, lo, hi)
            ax.set_title(f"{name}: tick {scene.t}")  # every frame differs, so none is merged away
            writer.grab_frame()
            if progress:
                progress(i + 1, len(scenes))
    plt.close(fig)
    return len(scenes)


def _scenes_along(replay: Replay, ticks: list[int]) -> list[Scene]:
    """The scene at each of ``ticks`` (ascending), fed in one pass."""
    out = []
    scene = replay._base.copy()
    i = 0
    for t in ticks:
        while i < len(replay.records) and replay.records[i]["t"] <= t:
            scene.feed_record(replay.records[i])
            i += 1
        out.append(scene.copy())
    return out


def _extent(replay: Replay, scenes: list[Scene]):
    b = replay._base.bounds
    if b:
        return b[0][:2], b[1][:2]
    xs = [row[1] for s in scenes for row in s.pos] or [0.0]
    ys = [row[2] for s in scenes for row in s.pos] or [0.0]
    pad = max(max(xs) - min(xs), max(ys) - min(ys), 1.0) * 0.05
    return [min(xs) - pad, min(ys) - pad], [max(xs) + pad, max(ys) + pad]


def draw_scene(ax, scene: Scene, field: str | None, lo, hi) -> None:
    """One animation frame: links, robots coloured by ``field``, failed robots, objects, senders."""
    import numpy as np

    ids = [row[0] for row in scene.pos]
    xy = np.array([row[1:3] for row in scene.pos], dtype=float).reshape(-1, 2)
    rng = np.array([scene.ranges.get(i, scene.default_range) for i in ids])
    if len(ids) > 1 and len(ids) <= 1500:
        d = np.linalg.norm(xy[:, None, :] - xy[None, :, :], axis=2)
        a, b = np.nonzero(np.triu((d <= rng[:, None]) & (d <= rng[None, :]), 1))
        if len(a):
            from matplotlib.collections import LineCollection

            ax.add_collection(LineCollection(np.stack([xy[a], xy[b]], axis=1), colors="0.82", linewidths=0.8,
                                             zorder=1))
    values = [scene.status.get(i, {}).get(field) if field else None for i in ids]
    numeric = [v for v in values if isinstance(v, (int, float)) and not isinstance(v, bool)]
    colours = []
    if numeric:
        import matplotlib

        cmap = matplotlib.colormaps["viridis"]
        vmin, vmax = min(numeric), max(numeric)
        for v in values:
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                colours.append(cmap(0.5 if vmax == vmin else (v - vmin) / (vmax - vmin)))
            else:
                colours.append("white")
    else:
        palette = ["#4e79a7", "#f28e2b", "#59a14f", "#b07aa1", "#76b7b2", "#edc948", "#ff9da7", "#9c755f"]
        names = sorted({str(v) for v in values if v is not None})
        colours = ["white" if v is None else palette[names.index(str(v)) % len(palette)] for v in values]
    if len(ids):
        talking = scene.activity()
        edge = ["#e15759" if str(i) in talking else "0.3" for i in ids]
        ax.scatter(xy[:, 0], xy[:, 1], c=colours, s=70, edgecolors=edge, linewidths=1.2, zorder=3)
    for rid, d in scene.dead.items():
        if d["pos"] is not None and rid not in ids:
            ax.scatter([d["pos"][0]], [d["pos"][1]], marker="x", c="red", s=50, zorder=4)
    for name, p in scene.objects.items():
        ax.scatter([p[0]], [p[1]], marker="D", c="#f1a340", s=80, edgecolors="k", zorder=5)
        ax.annotate(name, (p[0], p[1]), xytext=(5, 5), textcoords="offset points", fontsize=8)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel("x (length units)")
    ax.set_ylabel("y (length units)")
