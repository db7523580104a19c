"""A newcomer's pass (issue 25): errors, hosts, run directories, summary and check tables.

Errors without tracebacks, hosts that wait and talk, runs kept apart, tables that explain themselves: each
item of the issue has a test here (exit codes, one-line messages, directories kept apart, table contents).
The quick ones run commands in this process; those with several processes or a Ctrl-C are marked slow.
"""

from __future__ import annotations

import asyncio
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from swarmactors.cli import main
from swarmactors.oracle.result import Result
from swarmactors.robot import hosting
from swarmactors.runs.launcher import resolve_run, run_world
from swarmactors.runs.progress import bound_text, check_counts, check_rows, fmt, status
from transport import Endpoints
from transport.auth import RUN_SECRET_ENV

EXIT_OK, EXIT_CHECK, EXIT_INPUT, EXIT_RUNTIME, EXIT_INTERRUPTED = 0, 1, 2, 3, 130
TESTS = Path(__file__).parent

TINY = """\
[run]
name = "tiny"
seed = 5
ticks = {ticks}
clock = "{clock}"
{extra}

[radio]
range = 1.0
latency = 1

[[robots]]
positions = [[0.0, 0.0], [0.5, 0.0], [1.0, 0.0]]
behaviors = [{behaviors}]
{checks}
"""


def tiny(ticks: int = 3, clock: str = "lockstep", behaviors: str = '{ use = "beacon" }', checks: str = "",
         extra: str = "") -> str:
    return TINY.format(ticks=ticks, clock=clock, behaviors=behaviors, checks=checks, extra=extra)


def cli(args: list[str], cwd: Path, monkeypatch, capsys) -> tuple[int, str, str]:
    """``swarmactors ARGS`` in this process: (exit code, stdout, stderr)."""
    monkeypatch.chdir(cwd)
    monkeypatch.setenv("COLUMNS", "200")
    capsys.readouterr()
    try:
        code = main(args)
    except SystemExit as exc:  # argparse's own exits (--version, usage errors)
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line_error(err: str, *names: str) -> None:
    assert "Traceback" not in err, err
    errors = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1, err
    for name in names:
        assert name in errors[0], (name, err)


# ------------------------------------------------------------------------------------------------------------
# Errors: exit 2, one line, no traceback
# ------------------------------------------------------------------------------------------------------------

KINDS = ["missing", "directory", "empty", "binary"]


def bad_path(tmp_path: Path, kind: str) -> str:
    if kind == "missing":
        return "no-such-file.toml"
    if kind == "directory":
        (tmp_path / "adir").mkdir()
        (tmp_path / "adir" / "x.toml").write_text("")
        return "adir"
    if kind == "empty":
        (tmp_path / "empty.toml").write_text("")
        return "empty.toml"
    (tmp_path / "binary.toml").write_bytes(bytes(range(256)) * 4)
    return "binary.toml"


# every subcommand that reads a path, with the path in its place
COMMANDS = {
    "run": lambda p: ["run", p],
    "world": lambda p: ["world", p, "--listen", "tcp/127.0.0.1:0"],
    "sweep": lambda p: ["sweep", p, "--grid", "radio.loss=0,0.1"],
    "replay": lambda p: ["replay", p, "--events"],
    "export": lambda p: ["export", p],
    "schedule": lambda p: ["schedule", p],
    "check": lambda p: ["check", "flooding", "--behavior", p],
    "robots": lambda p: ["robots", "--connect", "tcp/127.0.0.1:9", "--secure", p, "--wait", "0.2"],
    "view": lambda p: ["view", "--connect", p],
}


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("command", list(COMMANDS))
def test_every_command_refuses_a_bad_path_in_one_line(tmp_path, monkeypatch, capsys, command, kind):
    path = bad_path(tmp_path, kind)
    before = sorted(p.name for p in tmp_path.iterdir())
    code, _, err = cli(COMMANDS[command](path), tmp_path, monkeypatch, capsys)
    assert code == EXIT_INPUT, (code, err)
    assert "Traceback" not in err, err
    assert path in err, err  # names what was wrong
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written


@pytest.mark.parametrize("kind", ["empty", "binary"])
def test_new_refuses_a_file_as_its_parent_directory(tmp_path, monkeypatch, capsys, kind):
    path = bad_path(tmp_path, kind)
    code, _, err = cli(["new", "proj", "--dir", path], tmp_path, monkeypatch, capsys)
    assert code == EXIT_INPUT and "Traceback" not in err and path in err, err


def test_scenario_errors_name_directory_and_binary_file(tmp_path, monkeypatch, capsys):
    code, _, err = cli(["run", bad_path(tmp_path, "directory")], tmp_path, monkeypatch, capsys)
    assert code == EXIT_INPUT
    assert_one_line_error(err, "adir", "is a directory", "x.toml")
    code, _, err = cli(["run", bad_path(tmp_path, "binary")], tmp_path, monkeypatch, capsys)
    assert code == EXIT_INPUT
    assert_one_line_error(err, "binary.toml", "not UTF-8")


def test_python_api_names_a_directory_given_as_scenario(tmp_path):
    import swarmactors
    from swarmactors.runs.scenario import ScenarioError

    with pytest.raises(ScenarioError, match="is a directory"):
        swarmactors.run(TESTS.parent / "scenarios", out=tmp_path / "o")
    assert not (tmp_path / "o").exists()


def test_check_output_to_a_directory_is_refused_before_running(tmp_path, monkeypatch, capsys):
    (tmp_path / "adir").mkdir()
    started = time.monotonic()
    code, _, err = cli(["check", "flooding", "--json", "adir"], tmp_path, monkeypatch, capsys)
    assert code == EXIT_INPUT
    assert_one_line_error(err, "--json adir", "is a directory")
    assert time.monotonic() - started < 5  # refused before any case ran
    assert not (tmp_path / "out").exists()


USER_MODULE = '''
from swarmactors import Behavior, Outcome


class NotABehavior:
    """A class that is not a Behavior."""


def a_function():
    return None


def empty(result):
    """Passes with nothing to measure."""
    return Outcome("mine.empty", True)


def always_fails(result):
    return Outcome("mine.always_fails", False, value=3, bound=2, detail="three is more than two", op="<=")


def lockstep_only(result):
    return Outcome("mine.lockstep_only", True, value=1, bound=1)


lockstep_only.clocks = ("lockstep",)
lockstep_only.instead = {"realtime": "mine:empty"}


class Crash(Behavior):
    """Raises at tick 1 on robot 1."""

    def on_tick(self, ctx, sensed):
        if ctx.id == 1 and ctx.tick == 1:
            raise ValueError("boom on tick 1\\nsecond line not shown")
'''


@pytest.fixture
def project(tmp_path):
    (tmp_path / "mine.py").write_text(USER_MODULE)
    yield tmp_path
    sys.modules.pop("mine", None)


@pytest.mark.parametrize("use", ["mine:NotABehavior", "mine:a_function"])
def test_use_that_names_no_behavior_is_refused_at_load(project, monkeypatch, capsys, use):
    (project / "s.toml").write_text(tiny(behaviors=f'{{ use = "{use}" }}'))
    code, _, err = cli(["run", "s.toml"], project, monkeypatch, capsys)
    assert code == EXIT_INPUT
    assert_one_line_error(err, "s.toml", "robots[0].behaviors[0].use", use, "not a Behavior subclass")
    assert not (project / "out").exists()


def test_check_of_a_behaviour_the_scenario_lacks_is_refused_at_load(project, monkeypatch, capsys):
    (project / "s.toml").write_text(tiny(checks='[[checks]]\nuse = "flooding.reach"'))
    code, _, err = cli(["run", "s.toml"], project, monkeypatch, capsys)
    assert code == EXIT_INPUT
    assert_one_line_error(err, "s.toml", "checks[0].use", "flooding.reach", "beacon")
    assert not (project / "out").exists()


def test_check_for_another_clock_is_refused_at_load_naming_the_one_to_use(project, monkeypatch, capsys):
    checks = '[[checks]]\nuse = "mine:lockstep_only"'
    (project / "rt.toml").write_text(tiny(clock="realtime", checks=checks, extra="dt = 0.05"))
    code, _, err = cli(["run", "rt.toml"], project, monkeypatch, capsys)
    assert code == EXIT_INPUT
    assert_one_line_error(err, "rt.toml", "checks[0].use", "lockstep", "realtime", "use 'mine:empty' instead")
    (project / "ls.toml").write_text(tiny(checks=checks))
    monkeypatch.syspath_prepend(str(project))
    assert resolve_run(project / "ls.toml")["checks"][0]["use"] == "mine:lockstep_only"  # accepted in lockstep


def test_every_shipped_scenario_passes_the_load_time_checks():
    for path in sorted((TESTS.parent / "scenarios").glob("*.toml")):
        resolve_run(path)  # raises ScenarioError if a check or a behaviour were refused


# ------------------------------------------------------------------------------------------------------------
# Outputs: one directory per run, summaries that say what happened
# ------------------------------------------------------------------------------------------------------------


def test_runs_without_out_get_their_own_directories_and_latest(project, monkeypatch, capsys):
    (project / "s.toml").write_text(tiny())
    dirs = []
    for _ in range(2):
        code, _, err = cli(["run", "s.toml", "--no-plots"], project, monkeypatch, capsys)
        assert code == EXIT_OK, err
        dirs.append(sorted(p for p in (project / "out" / "tiny").iterdir() if p.name != "latest"))
    first, second = dirs[0], sorted(set(dirs[1]) - set(dirs[0]))
    assert len(first) == 1 and len(second) == 1  # the second run did not replace the first
    assert re.fullmatch(r"\d{8}T\d{6}Z-s5(-\d+)?", second[0].name)
    for d in first + second:
        assert json.loads((d / "result.json").read_text())["seed"] == 5
    latest = project / "out" / "tiny" / "latest"
    assert latest.is_symlink() and latest.resolve() == second[0].resolve()
    # --out is used as given
    code, _, err = cli(["run", "s.toml", "--no-plots", "--out", "mine-out"], project, monkeypatch, capsys)
    assert code == EXIT_OK and (project / "mine-out" / "result.json").exists()
    assert len([p for p in (project / "out" / "tiny").iterdir() if p.name != "latest"]) == 2


def test_python_api_without_out_also_keeps_runs_apart(project, monkeypatch):
    import swarmactors

    (project / "s.toml").write_text(tiny())
    monkeypatch.chdir(project)
    a = swarmactors.run("s.toml")
    b = swarmactors.run("s.toml")
    assert a.path.parent != b.path.parent
    assert (project / "out" / "tiny" / "latest").resolve() == b.path.parent.resolve()


def test_summary_lists_crashed_robots_with_the_first_line_of_their_error(project, monkeypatch, capsys):
    (project / "s.toml").write_text(tiny(ticks=4, behaviors='{ use = "beacon" }, { use = "mine:Crash" }'))
    code, _, err = cli(["run", "s.toml", "--no-plots"], project, monkeypatch, capsys)
    assert code == EXIT_CHECK, err  # a crashed robot fails the run (swarmactors.exitcodes.run_exit)
    assert "2 alive at the end" in err and "1 robot crashed" in err
    line = next(ln for ln in err.splitlines() if "robot 1 at tick 1" in ln)
    assert "crashed" in line and "ValueError: boom on tick 1" in line
    assert "second line not shown" not in err


def test_check_table_groups_parts_shows_directions_and_nothing_to_judge(project, monkeypatch, capsys):
    flooding = (TESTS.parent / "scenarios" / "flooding.toml").read_text()
    text = flooding + '\n[[checks]]\nuse = "mine:empty"\n\n[[checks]]\nuse = "mine:always_fails"\n'
    (project / "f.toml").write_text(text)
    code, _, err = cli(["run", "f.toml", "--no-plots", "--out", "o"], project, monkeypatch, capsys)
    assert code == EXIT_CHECK, err  # always_fails fails the run; "nothing to judge" does not
    rows = [ln.strip("│ ") for ln in err.splitlines()]
    at = next(i for i, ln in enumerate(rows) if ln.startswith("check flooding.forwarding"))
    assert rows[at + 1].startswith("flooding.forward_once") and rows[at + 2].startswith("flooding.not_to_sender")
    reach = next(ln for ln in rows if ln.startswith("check flooding.reach"))
    assert "value 30 (bound = 30)" in reach
    assert "nothing to judge" in next(ln for ln in rows if ln.startswith("check mine:empty"))
    failing = next(ln for ln in rows if ln.startswith("check mine:always_fails"))
    assert "FAILED" in failing and "value 3 (bound ≤ 2)" in failing  # mine.always_fails declares op="<="
    assert "3 passed, 1 nothing to judge, 1 failed" in err
    result = Result.load(project / "o")
    assert [c["name"] for c in result.checks if not c["passed"]] == ["mine.always_fails"]


def test_table_rules_bound_direction_status_rounding():
    assert bound_text({"passed": True, "value": 20, "bound": 25}) == "≤ 25"
    assert bound_text({"passed": True, "value": 0.9, "bound": 0.5}) == "≥ 0.5"
    assert bound_text({"passed": True, "value": 30, "bound": 30}) == "= 30"
    assert bound_text({"passed": False, "value": 0.2, "bound": 0.5}) == "≥ 0.5"  # below a lower bound
    assert bound_text({"passed": False, "value": 3, "bound": 2}) == "≤ 2"  # above an upper bound
    assert bound_text({"passed": False, "value": 30, "bound": 30}) == "= 30"
    assert bound_text({"passed": False, "value": 3, "bound": 0, "op": "<="}) == "≤ 0"  # a declared op wins
    assert bound_text({"passed": True, "value": 3, "bound": 3, "op": ">="}) == "≥ 3"
    gabriel = {"name": "roles.gabriel_formed", "passed": True, "value": 1.0, "bound": 0.9,
               "detail": "0 of 0 Gabriel edges formed at tick 99; mean over the run 1.000"}
    assert status(gabriel) == "nothing to judge"
    assert status({**gabriel, "detail": "10 of 10 Gabriel edges formed"}) == "passed"
    assert status({**gabriel, "passed": False}) == "FAILED"
    assert check_counts([gabriel, {**gabriel, "detail": ""}]) == "1 passed, 1 nothing to judge, 0 failed"
    by_role = {"base_station": 76.42618300542381, "explorer": 12.0, "n": 3}
    assert fmt(by_role) == "{base_station: 76.43, explorer: 12, n: 3}"
    assert fmt([0.123456789, True, None]) == "[0.1235, True, None]"
    # parts under the asked check, in the scenario's order
    outcomes = [{"name": n, "passed": True, "value": 1, "bound": 1} for n in ("a.x", "a.y", "b")]
    rows = check_rows(outcomes, [{"use": "a.parts"}, {"use": "b"}])
    assert [r[0] for r in rows] == ["check a.parts", "  a.x", "  a.y", "check b"]
    tagged = [{**o, "check": c} for o, c in zip(outcomes, ["a:parts", "a:parts", "b:other"], strict=True)]
    assert [r[0] for r in check_rows(tagged, [])] == ["check a:parts", "  a.x", "  a.y", "check b:other (b)"]


def test_check_table_not_wrapped_off_a_terminal_with_an_eta(tmp_path, monkeypatch, capsys):
    code, _, err = cli(["check", "flooding", "--clock", "realtime", "--no-determinism", "--out", "o"], tmp_path,
                       monkeypatch, capsys)
    assert code == EXIT_OK, err
    assert "ETA" in err
    row = next(ln for ln in err.splitlines() if "flooding/rgg-12-s2-realtime" in ln and "flooding.component" in ln)
    assert len(row) > 80  # one row, not wrapped at 80 columns
    assert any("flooding.not_to_sender" in ln and "(bound = 0)" in ln for ln in err.splitlines())
    assert "1 passed, 0 failed (checks: 3 passed, 0 nothing to judge, 0 failed)" in err


def test_compose_world_prints_its_summary_table():
    """The compose world runs without --quiet, so a compose run ends with the world's summary table."""
    text = (TESTS.parent / "docker" / "compose.yaml").read_text()
    worlds = re.findall(r'command: \["world",[^\]]*\]', text)
    assert len(worlds) == 2 and all("--quiet" not in w for w in worlds)
    robots = re.findall(r'command: \["robots",[^\]]*\]', text)
    assert len(robots) == 2 and all("--quiet" not in r for r in robots)


def test_version_and_list(tmp_path, monkeypatch, capsys):
    from importlib.metadata import version

    code, out, _ = cli(["--version"], tmp_path, monkeypatch, capsys)
    assert code == 0 and out.strip() == f"swarmactors {version('swarmactors')}"
    expected = {"behaviors": ("flooding", "Forward-once flooding"), "checks": ("flooding.reach", "Lockstep"),
                "families": ("cbaa", "CBAA"), "scenarios": ("flooding.toml", "Message-expiration flooding")}
    for what, (name, words) in expected.items():
        code, out, err = cli(["list", what], TESTS.parent, monkeypatch, capsys)
        assert code == 0, err
        line = next(ln for ln in out.splitlines() if name in ln.split()[1 if what == "scenarios" else 0])
        assert words in line, (what, line)


def test_final_graph_is_the_graph_of_the_last_tick(run):
    import tomllib

    result = run(tomllib.loads(tiny(ticks=4) + "\n[[events]]\nat = 2\nkill = [2]\n"))
    last = result.trace[-1]["t"]
    assert last == 3
    g = result.final_graph()
    assert sorted(g.nodes) == [0, 1]  # robot 2 died at tick 2
    assert sorted(g.edges) == sorted(result.graph_at(last).edges) == [(0, 1)]
    assert len(result.graph_at(0).edges) == 3
    assert sorted(result.final_graph(directed=True).edges) == sorted(result.graph_at(last, directed=True).edges)


# ------------------------------------------------------------------------------------------------------------
# Hosts that wait and talk (several processes or a live world)
# ------------------------------------------------------------------------------------------------------------


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def swarmactors_proc(args: list[str], cwd: Path, secret: str | None = None, **kw) -> subprocess.Popen:
    env = {k: v for k, v in os.environ.items() if k != "COLUMNS"}
    if secret:
        env[RUN_SECRET_ENV] = secret
    return subprocess.Popen([sys.executable, "-m", "swarmactors", *args], cwd=cwd, env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, **kw)


@pytest.mark.slow
def test_host_without_a_world_waits_then_exits_3_in_one_line(tmp_path):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    started = time.monotonic()
    proc = swarmactors_proc(["robots", "--connect", endpoint, "--wait", "2"], tmp_path, secret="00" * 32)
    _, err = proc.communicate(timeout=60)
    took = time.monotonic() - started
    assert proc.returncode == EXIT_RUNTIME, err
    assert_one_line_error(err, endpoint, "no world answered")
    assert 2 <= took < 15, took


@pytest.mark.slow
def test_host_started_before_its_world_joins_and_reports(tmp_path):
    """Host first, world 2 s later (as in a compose file): the host joins, names its robots and sums up."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    secret = "11" * 32
    (tmp_path / "s.toml").write_text(tiny(ticks=20))
    host = swarmactors_proc(["robots", "--connect", endpoint, "--run-id", "early", "--wait", "60"], tmp_path, secret)
    time.sleep(2.0)
    world = swarmactors_proc(["world", "s.toml", "--listen", endpoint, "--mode", "peer", "--run-id", "early",
                              "--out", "w", "--no-plots"], tmp_path, secret)
    _, world_err = world.communicate(timeout=120)
    _, host_err = host.communicate(timeout=60)
    assert world.returncode == EXIT_OK, world_err
    assert host.returncode == EXIT_OK, host_err
    assert "Traceback" not in host_err
    assert f"joined run 'early' at {endpoint} as host h0 (lockstep, 20 ticks): robots 0-2 (3)" in host_err
    assert re.search(r"host h0 done: 20 ticks in [\d.]+ s, frames sent 60, 3 robots \(3 alive\)", host_err), host_err
    assert "trace hash" in world_err  # the world's summary table


def test_host_progress_lines_and_no_robot_left(tmp_path, monkeypatch):
    """A host prints progress while its world runs; a second one finds no robot left and says so, in one line.

    In one process, over real Zenoh; the second host is refused because world.max_robots is reached.
    """
    monkeypatch.setattr(hosting, "PROGRESS_EVERY_S", 0.1)
    from swarmactors.runs.scenario import resolve_scenario

    raw = {"run": {"name": "talk", "ticks": 30, "clock": "realtime", "dt": 0.05},
           "radio": {"range": 1.0, "latency_s": 0.02}, "world": {"max_robots": 2},
           "robots": [{"positions": [[0.0, 0.0], [0.5, 0.0]], "behaviors": [{"use": "beacon"}]}]}
    sc = resolve_scenario(raw, "<talk>")
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    first: list[str] = []
    second: list[str] = []

    async def main_() -> str:
        world = asyncio.create_task(run_world(sc, tmp_path / "w", Endpoints(mode="peer", listen=[endpoint]), "talk",
                                              local_host=False, run_secret=b"k" * 32))
        monkeypatch.setenv(RUN_SECRET_ENV, (b"k" * 32).hex())
        joined = asyncio.Event()

        def say(line: str) -> None:
            first.append(line)
            if line.startswith("joined"):
                joined.set()

        host = asyncio.create_task(hosting.serve_host(Endpoints(mode="peer", connect=[endpoint]), "talk", None,
                                                      wait=20, say=say))
        await asyncio.wait_for(joined.wait(), 20)
        try:
            await hosting.serve_host(Endpoints(mode="peer", connect=[endpoint]), "talk", None, wait=1.0,
                                     say=second.append)
            refused = ""
        except hosting.HostError as exc:
            refused = str(exc)
        await host
        await world
        return refused

    refused = asyncio.run(main_())
    # joined before the world's first tick: an empty share, said and waited out; after it: refused (exit 3)
    said = refused or (second[0] if second else "")
    assert said.startswith("no robot left") and endpoint in said and "\n" not in said, (refused, second)
    assert first[0].startswith(f"joined run 'talk' at {endpoint} as host h0 (realtime, 30 ticks): robots 0-1 (2)")
    progress = [ln for ln in first if ln.startswith("host h0: tick")]
    assert progress and all(re.fullmatch(r"host h0: tick \d+/30, frames sent \d+, 2/2 robots alive", ln)
                            for ln in progress)
    assert first[-1].startswith("host h0 done:")


@pytest.mark.slow
def test_ctrl_c_summary_says_interrupted_at_tick(tmp_path):
    (tmp_path / "s.toml").write_text(tiny(ticks=400, clock="realtime", extra="dt = 0.05"))
    proc = swarmactors_proc(["run", "s.toml", "--no-plots", "--out", "o"], tmp_path, start_new_session=True)
    deadline = time.monotonic() + 60
    while not (tmp_path / "o" / "trace.msgpack").exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    time.sleep(1.5)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == EXIT_INTERRUPTED, err
    assert "Traceback" not in err
    k = int(re.search(r"interrupted at tick (\d+)", err).group(1))
    assert 0 < k < 399
    assert json.loads((tmp_path / "o" / "result.json").read_text())["interrupted"] is True


# ------------------------------------------------------------------------------------------------------------
# check's reproduce command, a resumed sweep's counts
# ------------------------------------------------------------------------------------------------------------


@pytest.mark.slow
def test_reproduce_command_works_from_any_directory(tmp_path, monkeypatch):
    from swarmactors.runs import conformance as cf

    monkeypatch.syspath_prepend(str(TESTS))
    monkeypatch.chdir(TESTS)
    fam, case = cf.case_by_name("flooding", "flooding/ring-8", "quick")
    res = cf.run_case(fam, case, "mutants:FloodIgnoresExpiry", tmp_path / "o", determinism=False)
    assert not res.passed and Path(res.reproduce).is_absolute()
    assert res.reproduce_command.startswith(f"PYTHONPATH={TESTS} swarmactors run {res.reproduce}")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PATH"] = f"{Path(sys.executable).parent}:{env.get('PATH', '')}"
    proc = subprocess.run(res.reproduce_command + " --out again --quiet --json --no-plots", shell=True,
                          cwd=elsewhere, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == EXIT_CHECK, proc.stderr
    checks = {c["name"]: c for c in json.loads(proc.stdout)["checks"]}
    assert not checks["flooding.reach"]["passed"]
    assert checks["flooding.reach"]["first_tick"] == res.first_tick


@pytest.mark.slow
def test_resumed_sweep_counts_the_failures_already_in_the_csv(project, monkeypatch):
    from swarmactors.tools import sweep as sw

    (project / "s.toml").write_text(tiny(checks='[[checks]]\nuse = "mine:always_fails"'))
    monkeypatch.chdir(project)
    monkeypatch.syspath_prepend(str(project))  # spawned workers inherit sys.path
    plan = sw.prepare(project / "s.toml", [], ["radio.loss=0"], 2, project / "sw")
    first = sw.run_sweep(plan, workers=1)
    assert (first.failed, first.skipped) == (2, 0)
    plan = sw.prepare(project / "s.toml", [], ["radio.loss=0"], 3, project / "sw")
    again = sw.run_sweep(plan, workers=1)
    assert (again.skipped, again.ran, again.failed) == (2, 1, 3)


def test_flooding_reach_is_refused_under_realtime_naming_the_check_to_use(tmp_path, monkeypatch, capsys):
    """flooding.reach holds only in lockstep (exact arrival ticks).

    A realtime scenario asking for it is refused at load, naming flooding.component instead (issue 25).
    """
    from swarmactors.cli import main

    (tmp_path / "rt.toml").write_text(
        '[run]\nticks = 3\nclock = "realtime"\ndt = 0.05\n[[robots]]\ncount = 3\nplacement = "line"\n'
        'behaviors = [{ use = "flooding", origin = 0, at = 1, expiry = 1.0 }]\n[[checks]]\nuse = "flooding.reach"\n')
    monkeypatch.chdir(tmp_path)
    capsys.readouterr()
    assert main(["run", "rt.toml"]) == 2
    err = capsys.readouterr().err
    assert "flooding.reach" in err and "flooding.component" in err and "Traceback" not in err
