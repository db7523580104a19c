"""``swarmactors figures``: the registry the families declare, its plots from saved results, the CLI's errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from swarmactors.cli import main
from swarmactors.tools import figures as fg

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def known():
    return fg.figures(root=REPO)


def test_every_family_with_experiments_declares_figures_and_their_saved_results_exist(known):
    families = {f.family for f in known.values()}
    assert {"lambda2", "roles", "biconnectivity", "relays", "secs", "tsc", "leader_follower", "cbaa",
            "stigmergy"} <= families
    for fig in known.values():
        assert fig.results is not None and fig.saved, f"{fig.id}: no saved results at {fig.results}"
        assert (REPO / "docs" / fig.docs.partition("#")[0]).is_file(), f"{fig.id}: docs page {fig.docs}"
        if fig.sweep:
            assert (REPO / fig.sweep).is_file(), f"{fig.id}: sweep file {fig.sweep}"
        for image in fig.images:
            assert (REPO / "docs" / "img" / image).is_file(), f"{fig.id}: {image} not in docs/img"


def test_every_plot_function_resolves(known):
    for fig in known.values():
        if fig.plot:
            assert callable(fg._function(fig.plot)), fig.id


@pytest.mark.parametrize("fid", ["lambda2-fig2", "cbaa-instances"])
def test_plot_draws_the_declared_images_from_saved_results(known, fid, tmp_path):
    paths = fg.plot(known[fid], tmp_path)
    assert {p.name for p in paths if p.suffix == ".png"} == set(known[fid].images)
    assert all(p.stat().st_size > 10_000 for p in paths)


@pytest.mark.slow
def test_every_plot_draws_its_images(known, tmp_path):
    for fig in known.values():
        if fig.plot:
            paths = fg.plot(fig, tmp_path / fig.id)
            assert {p.name for p in paths} >= set(fig.images), fig.id


def test_run_command_is_the_sweep_or_the_script(known):
    cmd = fg.run_command(known["lambda2-fig2"], "tcp://h:8786", 3, Path("out/x"))
    assert cmd[1:5] == ["-m", "swarmactors", "sweep", str(REPO / "protocols/lambda2/experiments/fig2.toml")]
    assert cmd[5:] == ["--cluster", "tcp://h:8786", "--trials", "3", "--out", "out/x"]
    assert fg.run_command(known["roles-fig3-6"])[1:] == ["-m", "protocols.roles.experiments.paper", "--replot"]
    with pytest.raises(fg.FigureError, match="takes no --cluster"):
        fg.run_command(known["secs-fig5"], "tcp://h:8786")
    with pytest.raises(fg.FigureError, match="no repetition option"):
        fg.run_command(known["secs-fig5"], trials=2)


def test_bad_declarations_name_the_figure_and_the_key(tmp_path):
    with pytest.raises(fg.FigureError, match="'x'.*unknown key.*colour"):
        fg._figure("f", tmp_path, {"id": "x", "paper": "p", "title": "t", "docs": "d", "colour": 1,
                                   "script": ["-m", "m"]}, "pkg.FIGURES")
    with pytest.raises(fg.FigureError, match="'x' needs 'sweep' or 'script'"):
        fg._figure("f", tmp_path, {"id": "x", "paper": "p", "title": "t", "docs": "d"}, "pkg.FIGURES")
    with pytest.raises(fg.FigureError, match="plot but no 'results'"):
        fg._figure("f", tmp_path, {"id": "x", "paper": "p", "title": "t", "docs": "d", "plot": "m:f",
                                   "script": ["-m", "m"]}, "pkg.FIGURES")


def test_cli_lists_and_rejects_unknown_ids(capsys):
    assert main(["figures"]) == 0
    out = capsys.readouterr().out
    assert "lambda2-fig2" in out and "seed 003, Fig. 2" in out
    assert main(["figures", "--plot", "no-such-figure"]) == 2
    err = capsys.readouterr().err
    assert "unknown figure id 'no-such-figure'" in err and "lambda2-fig2" in err
    assert main(["figures", "--run"]) == 2
    assert "--run needs figure ids" in capsys.readouterr().err
    assert main(["figures", "--plot", "secs-fig5"]) == 2
    assert "drawn only from a run" in capsys.readouterr().err
    assert main(["figures", "--trials", "3"]) == 2
    assert main(["figures", "--command", "lambda2-fig2", "--trials", "0"]) == 2
    assert main(["figures", "--command", "lambda2-fig2", "--trials", "2"]) == 0
    assert "sweep" in capsys.readouterr().out


def test_figure_files_resolve_in_the_checkout_not_in_an_installed_package(tmp_path):
    installed = tmp_path / "site-packages" / "protocols" / "lambda2" / "experiments" / "__init__.py"
    assert fg.checkout_root(REPO / "docs" / "img") == REPO
    assert fg.checkout_root(tmp_path) is None
    in_checkout = fg._package_dir("protocols.lambda2.experiments", str(installed), REPO)
    assert in_checkout == REPO / "protocols" / "lambda2" / "experiments"
    assert fg._package_dir("protocols.lambda2.experiments", str(installed), None) == installed.parent
    assert fg._package_dir("protocols.lambda2.experiments", str(installed), tmp_path) == installed.parent
