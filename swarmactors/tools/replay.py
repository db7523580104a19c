"""Replaying a trace: the viewer's time slider, and animations rendered with matplotlib.

``Replay(trace)`` reads a trace file (and the ``result.json`` beside it, when
there is one, for robot ranges and log lines) and gives the ``Scene`` at any
tick. It holds no tick record: it keeps each record's byte offset and reads the
records it needs from the file (of a zstd trace: a temporary decompressed copy, written as the trace is read
and checked, so a trace refused by the readers' bounds stops the copy too).
Scenes are rebuilt from checkpoints taken every ``CHECKPOINT_EVERY`` ticks (at
most ``CHECKPOINTS_MAX`` of them), so a seek reads at most that many records.

``render(trace, out)`` draws one frame per rendered tick (every ``every``-th
tick, and the last) into a GIF (Pillow) or an MP4 (ffmpeg), each with the
status field's legend, robot ids when readable and the whole run in view.
"""

from __future__ import annotations

import bisect
import json
import tempfile
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from swarmactors.oracle.trace import TraceError, TraceHasher, footer_problem, is_compressed, iter_offsets
from swarmactors.tools.scene import RECENT_TICKS, Scene

CHECKPOINT_EVERY = 64
CHECKPOINTS_MAX = 128  # a longer trace spaces its checkpoints further apart: the scenes kept stay O(N) in all


class Records(Sequence):
    """A trace's tick records, read from the file by their byte offsets when asked: none is held in memory.

    ``records[i]`` reads one record; ``records.iter_from(i)`` reads on from record i in one sequential pass.
    """

    def __init__(self, path: Path, stream, offsets: np.ndarray):
        self.path = path
        self._stream = stream  # the trace's plain msgpack stream (a decompressed temporary copy of a zstd trace)
        self._offsets = offsets

    def __len__(self) -> int:
        return len(self._offsets)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(len(self)))]
        if i < 0:
            i += len(self)
        if not 0 <= i < len(self):
            raise IndexError(i)
        return next(self.iter_from(i))

    def __iter__(self) -> Iterator[dict]:
        return self.iter_from(0)

    def iter_from(self, i: int) -> Iterator[dict]:
        """Records i, i + 1, ... to the last (the footer is not a record)."""
        if i >= len(self):
            return
        left = len(self) - i
        for _, obj in iter_offsets(self.path, self._stream, int(self._offsets[i])):
            yield obj
            left -= 1
            if not left:
                return

    def close(self) -> None:
        self._stream.close()


class Replay:
    """A trace file as a sequence of scenes.

    The trace is read once on opening (checked, its hashes verified) keeping only each record's tick and byte
    offset; a scene is rebuilt from the nearest checkpoint (a scene every ``CHECKPOINT_EVERY`` records, or
    fewer so that there are at most ``CHECKPOINTS_MAX``, kept as they are reached) by reading the records
    after it. A checkpoint keeps the indices of the scene's recent records, not the records: memory
    O(N · CHECKPOINTS_MAX), no tick record kept.
    """

    def __init__(self, trace: str | Path, verify: bool = True):
        """Read ``trace``.

        With ``verify`` a trace whose hashes do not match is refused (TraceError); without it the replay goes on
        with a warning in ``note``.
        """
        self.path = Path(trace)
        compressed = is_compressed(self.path)  # TraceError names the file
        try:
            stream = tempfile.TemporaryFile() if compressed else open(self.path, "rb")
        except OSError as exc:
            raise TraceError(f"{self.path}: cannot open: {exc.strerror}") from None
        header = footer = None
        offsets: list[int] = []
        ticks: list[int] = []
        hasher = TraceHasher()
        try:
            # TraceError names the file and the offset; a zstd trace is decompressed into ``stream`` as it is read
            scan = iter_offsets(self.path, tee=stream) if compressed else iter_offsets(self.path, stream)
            for offset, obj in scan:
                if header is None:
                    header = obj
                elif obj.get("end"):
                    footer = obj
                else:
                    offsets.append(offset)
                    ticks.append(obj["t"])
                    hasher.update(obj)
        except BaseException:
            stream.close()
            raise
        if header is None:
            stream.close()
            raise TraceError(f"{self.path}: no header")
        if not offsets:
            stream.close()
            raise TraceError(f"{self.path}: the trace holds no tick record")
        self.header = header
        self.records = Records(self.path, stream, np.asarray(offsets, dtype=np.int64))
        self.footer = footer
        self._ticks = np.asarray(ticks, dtype=np.int64)
        self.first = int(self._ticks[0])
        self.last = int(self._ticks[-1])
        self.note = None if footer is not None else "this trace has no footer: the run was cut short"
        problem = footer_problem(header, hasher.hexdigest(), footer)
        if problem and verify:
            self.records.close()
            raise TraceError(f"{self.path}: {problem}; replay --no-verify shows it anyway")
        if problem:
            self.note = f"warning: {problem}"
        self.result = self._result_beside()
        sc = header.get("scenario") or {}
        self._base = Scene(run_id=header.get("run_id", ""), clock=header.get("clock", "lockstep"),
                           ticks=len(offsets), scenario=sc, mode="replay")
        if self.result is not None:
            for rid, r in self.result.get("robots", {}).items():
                if isinstance(r.get("range"), (int, float)):
                    self._base.ranges[int(rid)] = float(r["range"])
                if r.get("log"):
                    self._base.logs[int(rid)] = list(r["log"])
        # (index of the next record to feed, the scene then without its recent records, their indices)
        self._checkpoints: list[tuple[int, Scene, tuple[int, ...]]] = []
        self._full: Scene | None = None

    def _result_beside(self) -> dict | None:
        path = self.path.parent / "result.json"
        if not path.exists():
            return None
        try:
            data = json.loads(path.read_text())
        except (OSError, ValueError):
            return None
        from swarmactors.oracle.result import result_problem

        if result_problem(data) or data.get("run_id") != self.header.get("run_id"):
            return None  # edited beyond use, or another run's result: the trace alone is replayed
        return data

    def scene_at(self, t: int) -> Scene:
        """The scene after tick ``t``'s record (clamped to the trace)."""
        idx = int(np.searchsorted(self._ticks, t, side="right"))  # records to feed: [0, idx)
        idx = max(1, min(idx, len(self.records)))
        start, scene, recent = 0, self._base.copy(), deque(maxlen=RECENT_TICKS)
        k = bisect.bisect_right([c[0] for c in self._checkpoints], idx) - 1
        if k >= 0:
            start, saved, recent_idx = self._checkpoints[k]
            scene, recent = saved.copy(), deque(recent_idx, maxlen=RECENT_TICKS)
            scene.recent = deque(self._read(recent_idx), maxlen=RECENT_TICKS)
        every = max(CHECKPOINT_EVERY, -(-len(self.records) // CHECKPOINTS_MAX))
        for i, rec in enumerate(self.records.iter_from(start), start):
            if i >= idx:
                break
            scene.feed_record(rec)
            if scene.recent and scene.recent[-1] is rec:
                recent.append(i)
            if (i + 1) % every == 0 and (not self._checkpoints or self._checkpoints[-1][0] < i + 1):
                saved = scene.copy()
                saved.recent = deque(maxlen=RECENT_TICKS)  # kept as record indices, read again on a seek
                self._checkpoints.append((i + 1, saved, tuple(recent)))
        scene.finished = idx == len(self.records) and self.footer is not None
        return scene

    def _read(self, indices: tuple[int, ...]) -> list[dict]:
        """The records at ``indices`` (ascending), in one pass over the file from the first."""
        want, out = set(indices), []
        if not indices:
            return out
        for i, rec in enumerate(self.records.iter_from(indices[0]), indices[0]):
            if i in want:
                out.append(rec)
            if i >= indices[-1]:
                break
        return out

    def full_scene(self) -> Scene:
        if self._full is None:
            self._full = self.scene_at(self.last)
        return self._full

    def ticks(self) -> list[int]:
        return self._ticks.tolist()


# ---------------------------------------------------------------- animations
@dataclass
class FrameStyle:
    """What stays fixed over an animation: colours, legend, limits and ids (so frames do not jump)."""

    field: str | None
    cats: list[str] | None  # categorical field: its legend, in colour order
    span: tuple[float, float] | None  # numeric field: the colour scale's range over the whole run
    lo: tuple[float, float]
    hi: tuple[float, float]
    labels: bool  # write robot ids
    size: float  # marker area (points^2)
    bounds: list | None  # the world's bounds, drawn as a dashed frame
    missing: bool  # some robot has no value of the field in some frame
    failed: bool  # some robot fails during the animation
    objects: bool
    world: dict | None = None  # the resolved [world] section: obstacles and maps are drawn (draw_space)


def render(trace: str | Path, out: str | Path, every: int = 1, fps: float = 10.0, field: str | None = None,
           progress: Callable[[int, int], None] | None = None, labels: bool | None = None,
           verify: bool = True) -> int:
    """Write an animation of the trace to ``out`` (.gif or .mp4); return the number of frames.

    Every frame has the legend of ``field`` (categories, or one colour bar on a scale fixed for the run), robot
    ids when they can be read (N <= ``plots.LABEL_MAX``, or ``labels``), and limits that hold every robot and
    object of the whole run with a margin, so nothing is cut off at the world's edge.
    """
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
    replay = Replay(trace, verify=verify)
    ticks = replay.ticks()[::every]
    if ticks[-1] != replay.last:
        ticks.append(replay.last)
    # two streamed passes: the style (legend, scale, limits) from every frame, then each frame drawn as it comes
    style = frame_style(replay, scenes_along(replay, ticks, copy=False), field or replay._base.field, labels)
    fig, ax = frame_figure(style)
    writer = animation.PillowWriter(fps=fps) if suffix == ".gif" else animation.FFMpegWriter(fps=fps)
    name = replay.header.get("scenario", {}).get("run", {}).get("name", replay.header.get("run_id", ""))
    with writer.saving(fig, str(out), dpi=80):
        for i, scene in enumerate(scenes_along(replay, ticks, copy=False)):
            ax.clear()
            draw_scene(ax, scene, style)
            ax.set_title(f"{name}: tick {scene.t}")  # every frame differs, so none is merged away
            writer.grab_frame()
            if progress:
                progress(i + 1, len(ticks))
    plt.close(fig)
    replay.records.close()
    return len(ticks)


def scenes_along(replay: Replay, ticks: list[int], copy: bool = True) -> Iterator[Scene]:
    """The scene at each of ``ticks`` (ascending), fed in one streamed pass (``copy=False``: one scene, updated)."""
    scene = replay._base.copy()
    records = replay.records.iter_from(0)
    pending = next(records, None)
    for t in ticks:
        while pending is not None and pending["t"] <= t:
            scene.feed_record(pending)
            pending = next(records, None)
        yield scene.copy() if copy else scene


def _scenes_along(replay: Replay, ticks: list[int]) -> list[Scene]:
    """``scenes_along`` as a list of independent scenes (tests, small traces)."""
    return list(scenes_along(replay, ticks))


def frame_style(replay: Replay, scenes: Iterable[Scene], field: str | None, labels: bool | None = None) -> FrameStyle:
    """Decide the animation's colours, legend, limits and ids from every scene it shows (read once, in order)."""
    from swarmactors.tools.plots import LABEL_MAX, categories, is_categorical, marker_size
    from swarmactors.tools.trajectories import _extent

    kinds: dict[type, object] = {}  # one value of each type the field takes (all is_categorical looks at)
    distinct: set[str] = set()  # the field's distinct values as text (its categories, when it has them)
    lo_v = hi_v = None
    lo = np.full(2, np.inf)
    hi = np.full(2, -np.inf)
    n, missing, failed, objects = 0, False, False, False
    for s in scenes:
        if field:
            for st in s.status.values():
                v = st.get(field)
                if v is None:
                    continue
                kinds.setdefault(type(v), v)
                if isinstance(v, (int, float)) and not isinstance(v, bool):
                    lo_v = v if lo_v is None else min(lo_v, v)
                    hi_v = v if hi_v is None else max(hi_v, v)
                distinct.add(str(v))  # categories() names values by their text
            missing = missing or any(s.status.get(row[0], {}).get(field) is None for row in s.pos)
        points = [row[1:3] for row in s.pos] + [d["pos"][:2] for d in s.dead.values() if d["pos"] is not None]
        points += [p[:2] for p in s.objects.values()]
        if points:
            xy = np.asarray(points, dtype=float).reshape(-1, 2)
            lo, hi = np.minimum(lo, xy.min(axis=0)), np.maximum(hi, xy.max(axis=0))
        n = max(n, len(s.pos) + len(s.dead))
        failed = failed or bool(s.dead)
        objects = objects or bool(s.objects)
    cats = span = None
    if kinds and is_categorical(list(kinds.values())):
        cats = categories(list(distinct))
    elif kinds:
        span = (float(lo_v), float(hi_v))
    xy = np.stack([lo, hi]) if np.isfinite(lo).all() else np.zeros((0, 2))
    lo, hi = _extent(xy, replay._base.bounds)  # the world's bounds unless far larger than where robots went
    pad = max(float((hi - lo).max()) * 0.06, 0.2)  # a disc (and its id) at the very edge stays whole
    labels = labels if labels is not None else n <= LABEL_MAX
    size = 150.0 if labels else min(marker_size(n), 70.0)  # a disc that holds its id when ids are written
    return FrameStyle(field, cats, span, (lo[0] - pad, lo[1] - pad), (hi[0] + pad, hi[1] + pad),
                      labels, size, replay._base.bounds, missing, failed, objects,
                      (replay.header.get("scenario") or {}).get("world"))


def frame_figure(style: FrameStyle):
    """The figure every frame is drawn on: room on the right for the legend, or one fixed colour bar."""
    import matplotlib.pyplot as plt
    from matplotlib import cm, colors

    fig, ax = plt.subplots(figsize=(8.0, 6.0), dpi=80)
    if style.span is not None:
        norm = colors.Normalize(*style.span) if style.span[1] > style.span[0] else colors.Normalize(
            style.span[0] - 0.5, style.span[1] + 0.5)
        fig.colorbar(cm.ScalarMappable(norm=norm, cmap="viridis"), ax=ax, label=style.field, shrink=0.8)
        fig.subplots_adjust(left=0.08, right=0.98, bottom=0.2, top=0.93)  # the legend goes under the axes
    else:
        fig.subplots_adjust(left=0.08, right=0.74, bottom=0.1, top=0.93)  # the legend goes on the right
    return fig, ax


def draw_scene(ax, scene: Scene, style: FrameStyle) -> None:
    """One animation frame: links, robots coloured by the style's field, ids, failed robots, objects, legend."""
    import matplotlib
    import numpy as np
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D
    from matplotlib.patches import Rectangle

    from swarmactors.tools.plots import category_cmap, category_codes, write_ids

    ids = [row[0] for row in scene.pos]
    xy = np.array([row[1:3] for row in scene.pos], dtype=float).reshape(-1, 2)
    rng = np.array([scene.ranges.get(i, scene.default_range) for i in ids])
    if len(ids) > 1 and len(ids) <= 1500:
        d = np.linalg.norm(xy[:, None, :] - xy[None, :, :], axis=2)
        a, b = np.nonzero(np.triu((d <= rng[:, None]) & (d <= rng[None, :]), 1))
        if len(a):
            ax.add_collection(LineCollection(np.stack([xy[a], xy[b]], axis=1), colors="0.82", linewidths=0.8,
                                             zorder=1))
    if style.world:
        from swarmactors.tools.draw_space import draw_space

        draw_space(ax, style.world)
    if style.bounds:
        (x0, y0), (x1, y1) = style.bounds[0][:2], style.bounds[1][:2]
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, ls="--", lw=0.8, ec="0.5", zorder=0))
    values = [scene.status.get(i, {}).get(style.field) if style.field else None for i in ids]
    handles = []
    if style.cats is not None:
        cmap = category_cmap(style.cats)
        codes = category_codes(style.cats, values)
        colours = [cmap(c) if v is not None else "white" for c, v in zip(codes, values, strict=True)]
        handles += [Line2D([], [], marker="o", ls="", color=cmap(i), markeredgecolor="0.3", label=c)
                    for i, c in enumerate(style.cats)]
    elif style.span is not None:
        vmin, vmax = style.span
        cmap = matplotlib.colormaps["viridis"]
        colours = [cmap(0.5 if vmax == vmin else (v - vmin) / (vmax - vmin)) if isinstance(v, (int, float))
                   and not isinstance(v, bool) else "white" for v in values]
    else:
        colours = ["white"] * len(ids)
    if style.missing:
        handles.append(Line2D([], [], marker="o", ls="", color="white", markeredgecolor="0.3",
                              label=f"no {style.field}"))
    if len(ids):
        talking = scene.activity()
        edge = ["#e15759" if str(i) in talking else "0.3" for i in ids]
        ax.scatter(xy[:, 0], xy[:, 1], c=colours, s=style.size, edgecolors=edge, linewidths=1.2, zorder=3)
    handles.append(Line2D([], [], marker="o", ls="", color="white", markeredgecolor="#e15759", markeredgewidth=1.2,
                          label="sent frames lately"))
    for rid, d in scene.dead.items():
        if d["pos"] is not None and rid not in ids:
            ax.scatter([d["pos"][0]], [d["pos"][1]], marker="x", c="red", s=50, zorder=4)
    if style.failed:
        handles.append(Line2D([], [], marker="x", ls="", color="red", label="failed"))
    for name, p in scene.objects.items():
        ax.scatter([p[0]], [p[1]], marker="D", c="#f1a340", s=80, edgecolors="k", zorder=5)
        ax.annotate(name, (p[0], p[1]), xytext=(5, 5), textcoords="offset points", fontsize=8)
    if style.objects:
        handles.append(Line2D([], [], marker="D", ls="", color="#f1a340", markeredgecolor="k", label="object"))
    if style.labels:
        write_ids(ax, {row[0]: row[1:3] for row in scene.pos}, fontsize=7)
    title = style.field if style.cats is not None else None
    if style.span is not None:
        ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=min(len(handles), 4),
                  fontsize=8, frameon=False)
    else:
        ax.legend(handles=handles, title=title, loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8,
                  frameon=False)
    ax.set_xlim(style.lo[0], style.hi[0])
    ax.set_ylim(style.lo[1], style.hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel("x (length units)")
    ax.set_ylabel("y (length units)")
