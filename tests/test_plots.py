"""swarm.png and trajectories.png (issue 26): categorical legends, ids only when readable, paths and density."""

from __future__ import annotations

import matplotlib.image as mpimg
import numpy as np
import pytest

from swarmactors.tools import plots
from swarmactors.tools.trajectories import plot_trajectories, tracks


def _swarm(n: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, np.sqrt(n), size=(n, 2))
    pos = {i: tuple(p) for i, p in enumerate(xy)}
    edges = [(i, i + 1) for i in range(n - 1)]
    return pos, edges


def test_is_categorical():
    assert plots.is_categorical(["leader", "explorer", None])
    assert plots.is_categorical([True, False])
    assert plots.is_categorical([1, "x"])
    assert not plots.is_categorical([1, 2.5, None])
    assert not plots.is_categorical([None])


def test_marker_size_shrinks_with_the_swarm():
    assert plots.marker_size(10) > plots.marker_size(1000) >= plots.marker_size(100_000) > 0


@pytest.mark.parametrize("values", [{0: "leader", 1: "explorer", 2: "leader"}, {0: 1, 1: 2.5, 2: 3}, {}])
def test_draw_swarm_writes_a_png(tmp_path, values):
    pos, edges = _swarm(3)
    path = plots.draw_swarm(tmp_path / "s.png", pos, edges, "role", values, {9: (0.0, 0.0)}, "t")
    assert mpimg.imread(path).shape[2] in (3, 4)


def test_ids_only_when_readable(tmp_path, monkeypatch):
    calls = []
    real = plots.plt.Axes.text

    def counting(self, *a, **k):
        calls.append(a[2])
        return real(self, *a, **k)

    monkeypatch.setattr(plots.plt.Axes, "text", counting)
    plots.draw_swarm(tmp_path / "a.png", *_swarm(plots.LABEL_MAX))
    assert len(calls) == plots.LABEL_MAX
    calls.clear()
    plots.draw_swarm(tmp_path / "b.png", *_swarm(plots.LABEL_MAX + 1))
    assert calls == []
    plots.draw_swarm(tmp_path / "c.png", *_swarm(plots.LABEL_MAX + 1), labels=True)
    assert len(calls) == plots.LABEL_MAX + 1


def test_many_categories_fold_into_other(tmp_path):
    pos, edges = _swarm(40)
    path = plots.draw_swarm(tmp_path / "s.png", pos, edges, "kind", {i: f"k{i}" for i in pos})
    assert path.exists()


def _records(n: int, ticks: int):
    return [{"t": t, "pos": [[i, i + 0.1 * t, np.sin(t / 5) + i] for i in range(n) if not (i == 0 and t > 5)]}
            for t in range(ticks)]


def test_tracks_mark_dead_robots_missing():
    ticks, by = tracks(_records(3, 10))
    assert list(ticks) == list(range(10))
    assert np.isnan(by[0][6:]).all() and not np.isnan(by[1]).any()


@pytest.mark.parametrize("density", [None, True])
def test_trajectories(tmp_path, density):
    path = plot_trajectories(_records(5, 30), tmp_path / "t.png", "x", [[-1, -2], [10, 10]], density=density)
    assert mpimg.imread(path).ndim == 3


def test_trajectories_of_a_large_swarm_is_a_heat_map(tmp_path, monkeypatch):
    drawn = []
    monkeypatch.setattr("swarmactors.tools.trajectories.LineCollection", lambda *a, **k: drawn.append(1))
    plot_trajectories(_records(250, 4), tmp_path / "t.png")
    assert drawn == []


# ---------------------------------------------------------------- GIF / MP4 frames (swarmactors.tools.replay)
def _trace(path, n: int, ticks: int, role=True):
    """A trace on disk (no run needed): robots on the world's edges, a categorical role, one failure."""
    import msgpack

    side = 4.0
    header = {"trace": "swarmactors", "version": 1, "run_id": "edge", "clock": "lockstep", "seed": 1,
              "scenario": {"run": {"name": "edge"}, "radio": {"range": 1.0},
                           "world": {"bounds": [[0.0, 0.0], [side, side]]}}}
    from swarmactors.oracle.trace import TraceHasher

    hasher = TraceHasher()  # the footer holds the records' real hash: the replay verifies it
    with open(path, "wb") as f:
        f.write(msgpack.packb(header))
        for t in range(ticks):
            alive = range(n) if t < ticks - 1 else range(1, n)  # robot 0 fails at the last tick
            pos = [[i, side * (i % 2), side * i / (n - 1)] for i in alive]  # x = 0 or 4: on the edge
            rec = {"t": t, "pos": pos}
            if role:
                rec["status"] = {i: {"role": ("leader", "relay", "explorer")[(i + t) % 3]} for i in alive}
            if t == ticks - 1:
                rec["ev"] = [{"t": t, "robot": 0, "failed": "killed"}]
            hasher.update(rec)
            f.write(msgpack.packb(rec))
        f.write(msgpack.packb({"end": True, "ticks": ticks, "trace_hash": hasher.hexdigest()}))
    return path


def test_animation_frames_have_a_legend_ids_and_the_whole_world(tmp_path):
    import matplotlib.pyplot as plt
    from PIL import Image

    from swarmactors.tools.replay import Replay, _scenes_along, draw_scene, frame_figure, frame_style, render

    trace = _trace(tmp_path / "trace.msgpack", 8, 5)
    replay = Replay(trace)
    scenes = _scenes_along(replay, replay.ticks())
    style = frame_style(replay, scenes, "role")
    assert style.cats == ["explorer", "leader", "relay"] and style.labels and style.failed
    fig, ax = frame_figure(style)
    draw_scene(ax, scenes[-1], style)
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend[:3] == ["explorer", "leader", "relay"] and "failed" in legend
    assert ax.get_legend().get_title().get_text() == "role"
    assert sorted(t.get_text() for t in ax.texts) == [str(i) for i in range(1, 8)]  # ids of the alive robots
    fig.canvas.draw()
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert x0 < 0 and x1 > 4 and y0 < 0 and y1 > 4  # robots on the world's edge are not cut
    radius = np.sqrt(style.size) / 2 * fig.dpi / 72  # the disc's radius in pixels
    box = ax.get_window_extent()
    for row in scenes[-1].pos:
        px, py = ax.transData.transform(row[1:3])
        assert box.x0 + radius <= px <= box.x1 - radius and box.y0 + radius <= py <= box.y1 - radius, row
    for text in ax.get_legend().get_texts():  # the legend is inside the figure, not cut at its edge
        ext = text.get_window_extent()
        assert ext.x1 <= fig.bbox.x1 and ext.y0 >= fig.bbox.y0
    plt.close(fig)
    assert render(trace, tmp_path / "edge.gif", every=2) == 3  # ticks 0, 2, 4
    with Image.open(tmp_path / "edge.gif") as img:
        assert img.n_frames == 3


def test_animation_of_a_numeric_field_keeps_one_scale_and_many_robots_have_no_ids(tmp_path):
    import matplotlib.pyplot as plt

    from swarmactors.tools.plots import LABEL_MAX
    from swarmactors.tools.replay import Replay, _scenes_along, draw_scene, frame_figure, frame_style

    trace = _trace(tmp_path / "trace.msgpack", LABEL_MAX + 5, 3, role=False)
    replay = Replay(trace)
    scenes = _scenes_along(replay, replay.ticks())
    for s in scenes:
        for row in s.pos:
            s.status.setdefault(row[0], {})["hop"] = row[0] * s.t
    style = frame_style(replay, scenes, "hop")
    assert style.cats is None and style.span == (0.0, 2.0 * (LABEL_MAX + 4)) and not style.labels
    fig, ax = frame_figure(style)
    draw_scene(ax, scenes[0], style)
    assert not ax.texts and len(fig.axes) == 2  # no ids; the axes and one colour bar
    draw_scene(ax, scenes[1], style)
    assert len(fig.axes) == 2  # still one colour bar
    plt.close(fig)


def test_trajectories_by_a_status_field(tmp_path, monkeypatch):
    from swarmactors.tools.trajectories import status_track

    records = _records(4, 12)
    for rec in records:
        if rec["t"] % 4 == 1:  # robot i changes role at ticks 1, 5, 9; robot 3 never says
            rec["status"] = {i: {"role": ("relay", "leader", "explorer")[(i + rec["t"]) % 3]} for i in range(3)}
    track = status_track(records, [0, 1, 2, 3], "role")
    assert track[1][0] is None and track[1][1] == track[1][4] == "explorer" and track[3] == [None] * 12
    drawn = []
    real = plot_trajectories.__globals__["LineCollection"]
    monkeypatch.setattr("swarmactors.tools.trajectories.LineCollection",
                        lambda segs, **k: drawn.append((len(segs), k)) or real(segs, **k))
    path = plot_trajectories(records, tmp_path / "t.png", "x", field="role")
    assert mpimg.imread(path).ndim == 3
    (count, kw), = drawn
    colours = [tuple(c) for c in kw["colors"]]
    assert count == len(colours) and colours.count((0.7, 0.7, 0.7, 1.0)) == 11  # robot 3 has no role: grey
    assert len(set(colours)) == 4  # three roles and grey
    for rec in records:
        if rec["t"] % 4 == 1:
            rec["status"] = {i: {"hop": i * rec["t"]} for i in range(4 if rec["t"] >= 5 else 3)}
    drawn.clear()
    plot_trajectories(records, tmp_path / "n.png", field="hop")
    (count, kw), = drawn
    assert np.isnan(kw["array"]).sum() == 4 and np.nanmax(kw["array"]) == 27  # robot 3 before tick 5: grey
