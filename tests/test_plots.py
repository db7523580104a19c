"""swarm.png and trajectories.png (issue 26): categorical legends, ids only when readable, paths and density."""

from __future__ import annotations

import matplotlib.image as mpimg
import numpy as np
import pytest

from swarmactors import plots
from swarmactors.trajectories import plot_trajectories, tracks


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
    monkeypatch.setattr("swarmactors.trajectories.LineCollection", lambda *a, **k: drawn.append(1))
    plot_trajectories(_records(250, 4), tmp_path / "t.png")
    assert drawn == []
