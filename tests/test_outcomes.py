"""Truthful outcomes (issue 43): what a run's summary and exit code say is what happened.

One test per item of the issue's "The outcome must be true": an interrupted run's checks are shown as not run,
and a world that no host joined says its robots never ran; crashed robots change the exit code (1, or 3 when no
robot ever ran; robots the scenario kills do not), in one line per kind of failure whatever the number of host
processes, with the traceback under ``-v``; a ``robots`` host that refuses a ``module:Class`` says so at join,
naming ``--allow``; a sweep names the checks its trials failed and exits 1; ``list scenarios`` works outside a
checkout; SIGINT and SIGTERM reach a Python caller of a run once result.json is written. Commands run in this
process where they can; those with host processes, signals or a sweep's workers are marked slow.
"""

from __future__ import annotations

import io
import json
import os
import re
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pytest
from rich.console import Console

from swarmactors import cli as cli_module
from swarmactors.exitcodes import EXIT_CHECK, EXIT_INPUT, EXIT_INTERRUPTED, EXIT_OK, EXIT_RUNTIME, run_exit
from swarmactors.oracle.result import Result
from swarmactors.runs.progress import metric_rows, summary_table, verdict
from swarmactors.tools.suggest import did_you_mean
from test_newcomer import cli, free_port, swarmactors_proc, tiny  # the newcomer tests' helpers

REPO = Path(__file__).resolve().parent.parent

MINE = '''
from swarmactors import Behavior


class Crash(Behavior):
    """Raises in on_tick at tick 1 on robot 1 (every robot with who = -1)."""

    def __init__(self, who: int = 1):
        self.who = who

    def on_tick(self, ctx, sensed):
        if ctx.tick == 1 and self.who in (ctx.id, -1):
            raise ValueError("boom in on_tick")


class BadInit(Behavior):
    """Cannot be built."""

    def __init__(self):
        raise RuntimeError("cannot build this behaviour")
'''


def scenario(behaviors: str, ticks: int = 4, extra: str = "", clock: str = "lockstep") -> str:
    """Three robots on a line (test_newcomer's ``tiny``); ``extra`` goes at the end (events, checks)."""
    return tiny(ticks, clock, behaviors, checks=extra, extra="dt = 0.05" if clock == "realtime" else "")


FLOOD_CHECK = '\n[[checks]]\nuse = "flooding.reach"\n'
FLOOD = '{ use = "flooding", origin = 0, at = 1, expiry = 3 }'


@pytest.fixture
def project(tmp_path):
    (tmp_path / "truthmine.py").write_text(MINE)
    yield tmp_path
    sys.modules.pop("truthmine", None)  # a module name of its own: other tests leave their dirs on sys.path


def text(table) -> str:
    buf = io.StringIO()
    Console(file=buf, width=250, no_color=True).print(table)
    return buf.getvalue()


def wait_for(path: Path, seconds: float = 60.0) -> None:
    deadline = time.monotonic() + seconds
    while not path.exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert path.exists(), path


def check_rows(err: str) -> list[str]:
    return [ln for ln in err.splitlines() if re.match(r"│ check \S", ln)]


# ------------------------------------------------------------------------------------------------------------
# An interrupted run: its checks did not run, and nothing says they passed
# ------------------------------------------------------------------------------------------------------------


def test_an_interrupted_result_shows_its_checks_not_run_and_a_world_no_host_joined():
    data = {"scenario": {"run": {"name": "f", "ticks": 12}, "checks": [{"use": "flooding.reach"},
                                                                      {"use": "flooding.forwarding"}]},
            "clock": "lockstep", "seed": 7, "ticks": 0, "wall_s": 0.0, "interrupted": True,
            "stop_reason": "interrupted (SIGINT)", "trace_hash": "0" * 32, "checks": [], "metrics": {},
            "world": {"frames_sent": 0, "deliveries": 0, "dropped": {}},
            "robots": {str(i): {"alive": True, "host": None, "failed": None} for i in range(30)}}
    shown = text(summary_table(data))
    assert "passed" not in shown
    assert shown.count("not run (the run was interrupted)") == 2
    assert "30, none ran: no robot host joined the world" in shown and "alive at the end" not in shown
    assert "interrupted (SIGINT): checks not run (exit 130)" in shown
    assert run_exit(data)[0] == EXIT_INTERRUPTED
    assert not Result(data).passed  # the Python API says the same


@pytest.mark.slow
@pytest.mark.parametrize("command", ["run", "world"])
def test_ctrl_c_leaves_every_check_not_run(tmp_path, command):
    """``run`` interrupted mid-run, ``world`` interrupted before any host joined: no check row says passed."""
    checks = '\n[[checks]]\nuse = "flooding.component"\n\n[[checks]]\nuse = "flooding.forwarding"\n'
    (tmp_path / "s.toml").write_text(scenario(FLOOD, ticks=400, clock="realtime") + checks)
    where = [] if command == "run" else ["--listen", f"tcp/127.0.0.1:{free_port()}"]
    proc = swarmactors_proc([command, "s.toml", *where, "--no-plots", "--out", "o"], tmp_path)
    wait_for(tmp_path / "o" / "trace.msgpack")
    time.sleep(1.5)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == EXIT_INTERRUPTED, err
    rows = check_rows(err)
    assert len(rows) == 2 and all("not run" in r and "passed" not in r for r in rows), err
    assert json.loads((tmp_path / "o" / "result.json").read_text())["checks"] == []
    if command == "world":
        assert "none ran: no robot host joined the world" in err, err


# ------------------------------------------------------------------------------------------------------------
# Crashed robots change the exit code
# ------------------------------------------------------------------------------------------------------------


def test_a_robot_raising_in_on_tick_fails_the_run_in_one_line_and_v_shows_its_traceback(project, monkeypatch,
                                                                                          capsys):
    (project / "s.toml").write_text(scenario('{ use = "truthmine:Crash", who = -1 }'))
    code, _, err = cli(["run", "s.toml", "--no-plots", "--out", "o"], project, monkeypatch, capsys)
    assert code == EXIT_CHECK, err
    assert "3 robots crashed" in err and "3 robots crashed (exit 1)" in err
    kinds = [ln for ln in err.splitlines() if "crashed robots 0-2 at tick 1" in ln]
    assert len(kinds) == 1, err  # one line for the three robots' one kind of failure
    assert "WARNING" not in err and "Traceback" not in err
    result = Result.load(project / "o")
    assert "ValueError: boom in on_tick" in result.robots[0]["traceback"]
    assert result.robots[0].get("started") is not False  # it ran, then crashed
    code, _, err = cli(["-v", "run", "s.toml", "--no-plots", "--quiet", "--out", "v"], project, monkeypatch,
                       capsys)
    assert code == EXIT_CHECK
    assert [ln for ln in err.splitlines() if ln.startswith("tiny:")] == [
        f"tiny: 3 robots crashed (exit 1; {Path('v') / 'result.json'})"]
    assert "robots 0-2 crashed with:\nTraceback (most recent call last):" in err
    assert 'truthmine.py", line' in err and "ValueError: boom in on_tick" in err


def test_every_robot_failing_to_build_means_no_robot_ever_ran(project, monkeypatch, capsys):
    (project / "s.toml").write_text(scenario('{ use = "truthmine:BadInit" }'))
    code, _, err = cli(["run", "s.toml", "--no-plots", "--out", "o"], project, monkeypatch, capsys)
    assert code == EXIT_RUNTIME, err
    assert "none ran: every robot failed before its first step" in err
    assert "RuntimeError: cannot build this behaviour" in err
    assert "no robot ever ran" in err and "(exit 3)" in err
    assert all(r["started"] is False for r in Result.load(project / "o").robots.values())


def test_robots_the_scenario_kills_do_not_fail_the_run(project, monkeypatch, capsys):
    (project / "s.toml").write_text(scenario('{ use = "beacon" }', ticks=5, extra="[[events]]\nat = 2\nkill = [1]"))
    code, _, err = cli(["run", "s.toml", "--no-plots", "--out", "o"], project, monkeypatch, capsys)
    assert code == EXIT_OK, err
    assert "killed robot 1 at tick 2" in err and "crashed" not in err
    assert "no checks (exit 0)" in err


@pytest.mark.slow
def test_crash_lines_are_the_same_with_host_processes(project, monkeypatch, capsys):
    """K = 0 and K = 2: no per-robot log line, the same one summary line (the log format does not depend on K)."""
    (project / "s.toml").write_text(scenario('{ use = "truthmine:Crash", who = -1 }'))
    for k in (0, 2):
        proc = swarmactors_proc(["run", "s.toml", "--no-plots", "--quiet", "--processes", str(k), "--out", f"k{k}"],
                                project)
        _, err = proc.communicate(timeout=120)
        assert proc.returncode == EXIT_CHECK, err
        assert err.splitlines() == [f"tiny: 3 robots crashed (exit 1; {Path(f'k{k}') / 'result.json'})"], err


# ------------------------------------------------------------------------------------------------------------
# A robots host without --allow, or in the wrong directory, says so at join
# ------------------------------------------------------------------------------------------------------------


@pytest.mark.slow
def test_a_host_that_cannot_build_a_module_says_why_at_join_in_one_line(project, tmp_path_factory):
    (project / "s.toml").write_text(scenario('{ use = "truthmine:Crash" }'))
    elsewhere = tmp_path_factory.mktemp("elsewhere")
    cases = [("refused", [], project, "refused_behavior"),  # no --allow
             ("missing", ["--allow", "truthmine"], elsewhere, "ModuleNotFoundError")]  # allowed, but not importable
    for run_id, allow, cwd, cause in cases:
        endpoint = f"tcp/127.0.0.1:{free_port()}"
        world = swarmactors_proc(["world", "s.toml", "--listen", endpoint, "--mode", "peer", "--run-id", run_id,
                                  "--out", run_id, "--no-plots"], project, "22" * 32)
        host = swarmactors_proc(["robots", "--connect", endpoint, "--run-id", run_id, *allow], cwd, "22" * 32)
        _, world_err = world.communicate(timeout=120)
        _, host_err = host.communicate(timeout=60)
        assert world.returncode == EXIT_RUNTIME, world_err
        assert "none ran: every robot failed before its first step" in world_err and cause in world_err
        errors = [ln for ln in host_err.splitlines() if ln.startswith("error:")]
        assert host.returncode == EXIT_INPUT, host_err
        assert len(errors) == 1 and "'truthmine:Crash' (robots 0-2)" in errors[0], host_err
        if run_id == "refused":
            assert errors[0].endswith("start the host with --allow truthmine"), host_err
        else:
            assert "cannot import" in errors[0] and "the directory that holds truthmine (.py)" in errors[0], host_err


# ------------------------------------------------------------------------------------------------------------
# Sweeps name what failed
# ------------------------------------------------------------------------------------------------------------


@pytest.mark.slow
def test_a_sweep_names_its_failed_checks_and_exits_1(project, monkeypatch, capsys):
    (project / "s.toml").write_text(scenario(FLOOD, ticks=6) + FLOOD_CHECK)
    code, out, err = cli(["sweep", "s.toml", "--grid", "radio.loss=0,0.9", "--workers", "1", "--out", "sw",
                          "--json"], project, monkeypatch, capsys)
    assert code == EXIT_CHECK, err
    outcome = json.loads(out)
    assert outcome["failed_checks"] == 1 and outcome["failed_by_check"] == {"flooding.reach": 1}
    code, _, err = cli(["sweep", "s.toml", "--grid", "radio.loss=0,0.9", "--workers", "1", "--out", "sw"],
                       project, monkeypatch, capsys)  # resumed: nothing to run, the same verdict, in words
    assert code == EXIT_CHECK
    assert re.search(r"failed checks\s+│ 1 trials \(flooding\.reach 1\)", err), err


# ------------------------------------------------------------------------------------------------------------
# list scenarios outside a checkout
# ------------------------------------------------------------------------------------------------------------


def test_list_scenarios_outside_a_checkout_finds_the_installed_ones_or_says_where_it_looked(tmp_path, monkeypatch,
                                                                                             capsys):
    installed = tmp_path / "venv" / "share" / "swarmactors" / "scenarios"
    installed.mkdir(parents=True)
    (installed / "relays.toml").write_text((REPO / "scenarios" / "relays.toml").read_text())
    elsewhere = tmp_path / "work"
    elsewhere.mkdir()
    monkeypatch.setattr(cli_module, "scenario_folders", lambda: [tmp_path / "no-checkout", elsewhere / "scenarios",
                                                                 installed])
    code, out, _ = cli(["list", "scenarios"], elsewhere, monkeypatch, capsys)
    assert code == EXIT_OK
    family, path, description = out.split(maxsplit=2)
    assert (family, Path(path)) == ("relays", installed / "relays.toml")
    assert description.startswith("Swarm Relays (Varadharajan et al. 2020):") and description.strip().endswith(".")
    code, _, err = cli(["run", "relays.toml", "--set", "run.ticks=1"], elsewhere, monkeypatch, capsys)
    assert code == EXIT_INPUT and f"the shipped scenario of that name is {installed / 'relays.toml'}" in err
    monkeypatch.setattr(cli_module, "scenario_folders", lambda: [tmp_path / "no-checkout"])
    code, out, err = cli(["list", "scenarios"], elsewhere, monkeypatch, capsys)
    assert code == EXIT_RUNTIME and out == ""
    assert err.count("\n") == 1 and err.startswith("error: no scenario files found (looked in ")


def test_a_wheel_installs_the_shipped_scenarios_where_list_looks():
    data_files = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["data-files"]
    assert data_files["share/swarmactors/scenarios"] == ["scenarios/*.toml"]
    assert any(str(f).endswith(os.path.join("share", "swarmactors", "scenarios"))
               for f in cli_module.scenario_folders())


def test_every_shipped_scenario_has_a_family_and_a_whole_sentence_to_list(monkeypatch, capsys):
    code, out, _ = cli(["list", "scenarios"], REPO, monkeypatch, capsys)
    assert code == EXIT_OK
    rows = [ln.split(maxsplit=2) for ln in out.splitlines()]
    assert len(rows) == len(list((REPO / "scenarios").glob("*.toml")))
    assert ["relays", "scenarios/relays.toml"] in [r[:2] for r in rows]
    for _family, path, description in rows:
        assert description.endswith(".") and description.count("(") == description.count(")"), (path, description)
        assert not re.search(r"seed 00\d|issue \d", description), (path, description)


# ------------------------------------------------------------------------------------------------------------
# SIGINT and SIGTERM reach whoever called a run from Python (a test suite, a script)
# ------------------------------------------------------------------------------------------------------------

CALLER = """
import sys
import swarmactors
print("started", flush=True)
result = swarmactors.run(sys.argv[1], out=sys.argv[2])
print("the run returned and the script went on", flush=True)
"""


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_during_a_python_run_reaches_the_caller_after_result_json(project, sig):
    (project / "s.toml").write_text(scenario('{ use = "beacon" }', ticks=2000, clock="realtime"))
    proc = subprocess.Popen([sys.executable, "-c", CALLER, "s.toml", "o"], cwd=project, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    wait_for(project / "o" / "trace.msgpack")
    time.sleep(1.0)
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=60)
    assert "the script went on" not in out, (out, err)
    assert proc.returncode == -sig, err  # SIGINT as an uncaught KeyboardInterrupt, which Python ends by SIGINT
    if sig == signal.SIGINT:
        assert err.rstrip().endswith("KeyboardInterrupt"), err
    result = json.loads((project / "o" / "result.json").read_text())
    assert result["interrupted"] is True and result["checks"] == []


# ------------------------------------------------------------------------------------------------------------
# The summary's rows
# ------------------------------------------------------------------------------------------------------------


def test_summary_rows_keep_directions_round_numbers_and_flatten_nested_metrics():
    assert "(bound" not in verdict({"name": "x", "passed": True, "value": 0, "bound": None})
    assert "value 0" in verdict({"name": "x", "passed": True, "value": 0, "bound": None})
    failed = verdict({"name": "x", "passed": False, "value": 0.42, "bound": 0.9})
    assert "(bound ≥ 0.9)" in failed
    assert "median 0.2723 (of 12)" in verdict({"name": "x", "passed": True, "value": None, "bound": None,
                                               "detail": "median 0.27232963119160386 (of 12)"})
    rows = metric_rows("biconnectivity", {"robots": 10, "periods": {1: {"robots": 10, "mean_received": {"CR": 191.6}}},
                                          "verdicts": {True: 3}})
    assert rows == [("biconnectivity", "robots 10"), ("  periods 1", "robots 10, mean_received.CR 191.6"),
                    ("  verdicts", "True 3")]
    assert not any("{" in value for _, value in rows)


def test_a_key_typo_suggests_the_right_key_or_none():
    radio = ["bandwidth", "delta", "exclude", "latency", "latency_min_s", "latency_s", "loss", "loss_model",
             "model", "occlusion", "range"]
    assert did_you_mean("rnage", radio) == "; did you mean 'range'?"
    assert did_you_mean("Range", radio) == "; did you mean 'range'?"
    assert did_you_mean("los", radio) == "; did you mean 'loss'?"
    assert did_you_mean("latncy", radio) == "; did you mean 'latency'?"
    assert did_you_mean("delay", radio) == ""  # two edits from delta: not what the user meant
    assert did_you_mean("speed", radio) == ""


def test_a_realtime_export_names_the_kind_and_size_of_every_delivered_frame(tmp_path):
    import swarmactors
    from swarmactors.tools.export import frame_rows

    result = swarmactors.run({"run": {"name": "rt", "ticks": 10, "clock": "realtime", "dt": 0.05},
                              "radio": {"range": 1.0, "latency_s": 0.01},
                              "robots": [{"positions": [[0.0, 0.0], [0.5, 0.0]], "behaviors": [{"use": "beacon"}]}]},
                             out=tmp_path)
    delivered = [r for r in frame_rows(list(result.records())) if r["outcome"] == "delivered"]
    assert delivered and all(r["kind"] == "BEACON" and r["size"] > 0 for r in delivered), delivered[:3]
