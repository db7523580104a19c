"""Parameter sweeps: rows per trial, deterministic seeds, interruption and resumption."""

from __future__ import annotations

import csv
import json
import signal
import subprocess
import sys
import time

import pytest

from swarmactors.cli import main
from swarmactors.runs.scenario import ScenarioError, load
from swarmactors.tools.sweep import SweepError, load_point, parse_grid, trial_seed

SCENARIO = """
[run]
name = "sw"
seed = 5
ticks = 500  # ~0.2 s a trial: time to interrupt a sweep between two rows

[[robots]]
count = 10
placement = "line"
spacing = 0.9
behaviors = [{ use = "flooding", origin = 0, at = 1, expiry = 8 }]

[[checks]]
use = "flooding.delivered"
"""
GRID = ["--grid", "radio.loss=0,0.3", "--trials", "3"]


def _sweep(scenario, out, *extra, **popen) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "swarmactors", "sweep", str(scenario), *GRID, "--out", str(out),
                             "--keep", "all", "--json", *extra], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, **popen)


def _rows(path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.mark.slow
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["sigint", "sigterm"])
def test_a_sweep_started_with_sigint_ignored_still_stops_on_sigint_or_sigterm(tmp_path, signum):
    """A shell's background job inherits SIGINT ignored; the sweep still stops (130) and keeps its rows."""
    scenario = tmp_path / "sw.toml"
    scenario.write_text(SCENARIO)
    cut = tmp_path / "cut"
    sweep = _sweep(scenario, cut, "--workers", "1", preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    deadline = time.monotonic() + 120
    while not (cut / "trials.csv").exists() or len(_rows(cut / "trials.csv")) < 1:
        assert time.monotonic() < deadline and sweep.poll() is None, sweep.communicate()
        time.sleep(0.02)
    sweep.send_signal(signum)
    _, err = sweep.communicate(timeout=60)
    assert sweep.returncode == 130, err
    assert 1 <= len(_rows(cut / "trials.csv")) < 6


@pytest.mark.slow
def test_sweep_rows_interruption_and_identical_resumption(tmp_path):
    scenario = tmp_path / "sw.toml"
    scenario.write_text(SCENARIO)
    whole, cut = tmp_path / "whole", tmp_path / "cut"
    uninterrupted = _sweep(scenario, whole, "--workers", "1")
    interrupted = _sweep(scenario, cut, "--workers", "1")
    deadline = time.monotonic() + 120
    while not (cut / "trials.csv").exists() or len(_rows(cut / "trials.csv")) < 2:
        assert time.monotonic() < deadline and interrupted.poll() is None, interrupted.communicate()
        time.sleep(0.02)
    interrupted.send_signal(signal.SIGINT)
    _, err = interrupted.communicate(timeout=60)
    assert interrupted.returncode == 130, err
    done = _rows(cut / "trials.csv")
    assert 2 <= len(done) < 6
    finished = {(r["radio.loss"], r["trial"]) for r in done}
    stamps = {p: p.stat().st_mtime_ns for p in cut.glob("trials/*/t*/result.json")}
    assert len(stamps) >= len(done)
    with open(cut / "trials.csv", "a") as f:  # as if the sweep had been killed while writing a row
        f.write("0.3,2,1234")
    out, err = uninterrupted.communicate(timeout=120)
    assert uninterrupted.returncode == 0, err
    assert json.loads(out)["ran"] == 6
    rows = _rows(whole / "trials.csv")
    assert [(r["radio.loss"], r["trial"]) for r in rows] == [(loss, t) for loss in ("0", "0.3") for t in "012"]
    assert len({r["seed"] for r in rows}) == 3  # trial i has the same seed at every grid point
    assert all(r["seed"] == str(trial_seed(5, int(r["trial"]))) for r in rows)
    assert {r["passed"] for r in rows} == {"true"} and all(r["trace_hash"] for r in rows)
    lossy = [r for r in rows if r["radio.loss"] == "0.3"]
    assert any(int(r["dropped.loss"]) > 0 for r in lossy)
    assert len({r["trace_hash"] for r in lossy}) == 3  # different seeds, different runs

    resumed = _sweep(scenario, cut, "--workers", "2")
    out, err = resumed.communicate(timeout=120)
    assert resumed.returncode == 0, err
    summary = json.loads(out)
    assert summary["skipped"] == len(done) and summary["ran"] == 6 - len(done)
    for p, stamp in stamps.items():  # the trials that had finished were not run again
        if (p.parent.parent.name.split("=")[1], p.parent.name[1:]) in finished:
            assert p.stat().st_mtime_ns == stamp, p
    assert (cut / "trials.csv").read_bytes() == (whole / "trials.csv").read_bytes()
    assert (cut / "summary-radio.loss.png").stat().st_size > 10_000


@pytest.mark.slow
def test_sweep_refuses_a_directory_of_another_sweep(tmp_path, capsys):
    scenario = tmp_path / "sw.toml"
    scenario.write_text(SCENARIO.replace("ticks = 500", "ticks = 4"))
    out = tmp_path / "s"
    assert main(["sweep", str(scenario), "--trials", "1", "--workers", "1", "--out", str(out), "--quiet"]) == 0
    assert len(_rows(out / "trials.csv")) == 1
    assert main(["sweep", str(scenario), "--trials", "1", "--out", str(out), "--set", "radio.loss=0.5",
                 "--quiet"]) == 2
    assert "holds another sweep" in capsys.readouterr().err
    assert main(["sweep", str(scenario), "--grid", "radio.los=0,1", "--out", str(tmp_path / "t"), "--quiet"]) == 2
    assert "radio.los" in capsys.readouterr().err


def test_grid_values_and_seeds():
    assert parse_grid("radio.loss=0,0.1, 0.2") == ("radio.loss", [0, 0.1, 0.2])
    assert parse_grid("robots.0.placement=grid,line") == ("robots.0.placement", ["grid", "line"])
    assert parse_grid('run.clock="lockstep","realtime"') == ("run.clock", ["lockstep", "realtime"])
    assert parse_grid("world.bounds=[[0,0],[1,1]],[[0,0],[2,2]]")[1] == [[[0, 0], [1, 1]], [[0, 0], [2, 2]]]
    for bad in ("radio.loss", "radio.loss=", "radio.loss=1,1"):
        with pytest.raises(SweepError):
            parse_grid(bad)
    seeds = [trial_seed(7, i) for i in range(100)]
    assert seeds == [trial_seed(7, i) for i in range(100)] and len(set(seeds)) == 100
    assert trial_seed(8, 0) != trial_seed(7, 0) and all(0 <= s < 2**31 for s in seeds)


def test_grid_values_are_set_as_values_not_toml_text(tmp_path):
    scenario = tmp_path / "sw.toml"
    scenario.write_text(SCENARIO)
    values = {"world.bounds": [[-1.0, -1.0], [12.0, 3.0]], "robots.0.placement": "grid", "run.seed": 11}
    sc = load_point(scenario, ["radio.loss=0.25"], values)
    assert (sc["world"]["bounds"], sc["robots"][0]["placement"], sc["run"]["seed"], sc["radio"]["loss"]) == (
        [[-1.0, -1.0], [12.0, 3.0]], "grid", 11, 0.25)
    text = ["radio.loss=0.25", "world.bounds=[[-1.0, -1.0], [12.0, 3.0]]", 'robots.0.placement="grid"', "run.seed=11"]
    assert sc == load(scenario, text)
    with pytest.raises(ScenarioError, match=r"robots\.3\.count"):
        load_point(scenario, [], {"robots.3.count": 2})
