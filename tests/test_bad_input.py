"""Bad input gets a clear error and loses nothing (issue 2, "Bad input").

* malformed scenarios are rejected by ``swarmactors run`` before anything
  starts: exit 2, the message names the file and the key, no output written;
* garbage and forged messages on the world's keys are dropped, counted as
  ``malformed``, and change nothing else in the run;
* the decoders (wire codec, the world's uplink/join/control handling, the trace
  reader) are fuzzed with hypothesis: they raise only their documented error
  types, or count the input as malformed;
* a truncated or corrupt trace file raises ``TraceError`` naming the file and
  the byte offset.
"""

from __future__ import annotations

import asyncio
import io
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import msgpack
import pytest
import zenoh
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from swarmactors.oracle.trace import TraceError, TraceWriter, iter_trace, read_trace, verify
from swarmactors.robot.host import RobotHost
from swarmactors.runs.launcher import new_run_id, run_world
from swarmactors.runs.scenario import resolve, resolve_scenario
from tests_support import FakeLink
from transport import Endpoints, Keys, Link, MalformedMessage, make_config, pack, seal, unpack
from transport.codec import unpack_map
from transport.messages import JoinReply, JoinRequest, Uplink, decode, encode
from world import Simulation, WorldSession

EXIT_INPUT = 2

# ---------------------------------------------------------------------------------------------
# 1. Scenario validation through the command line
# ---------------------------------------------------------------------------------------------

GOOD = """\
[run]
name = "bad-input"
ticks = 3

[radio]
range = 1.0
latency = 1
loss = 0.0

[[robots]]
positions = [[0.0, 0.0], [0.5, 0.0]]
behaviors = [{ use = "beacon" }]
"""


def _cli(args: list[str], cwd: Path, timeout: float = 60) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "COLUMNS"}
    return subprocess.run([sys.executable, "-m", "swarmactors", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=timeout)


def _replace(text: str, old: str, new: str) -> str:
    assert old in text, f"test bug: {old!r} not in the scenario"
    return text.replace(old, new, 1)


# (id, scenario text, extra CLI args, the key the message must name)
BAD_SCENARIOS = [
    ("unknown-key", _replace(GOOD, "ticks = 3", "ticks = 3\ncolour = \"red\""), [], "run.colour"),
    ("unknown-key-in-group", _replace(GOOD, "[[robots]]", "[[robots]]\nwheels = 3"), [], "robots[0].wheels"),
    ("unknown-section", GOOD + "\n[physics]\ngravity = 9.81\n", [], "physics"),
    ("wrong-type-str-for-number", _replace(GOOD, "range = 1.0", 'range = "far"'), [], "radio.range"),
    ("wrong-type-bool-for-int", _replace(GOOD, "ticks = 3", "ticks = true"), [], "run.ticks"),
    ("wrong-type-float-for-int-latency", _replace(GOOD, "latency = 1", "latency = 1.5"), [], "radio.latency"),
    ("negative-range", _replace(GOOD, "range = 1.0", "range = -1.0"), [], "radio.range"),
    ("zero-range", _replace(GOOD, "range = 1.0", "range = 0.0"), [], "radio.range"),
    ("negative-group-range", _replace(GOOD, "[[robots]]", "[[robots]]\nrange = -2.0"), [], "robots[0].range"),
    ("negative-latency", _replace(GOOD, "latency = 1", "latency = -1"), [], "radio.latency"),
    ("zero-latency", _replace(GOOD, "latency = 1", "latency = 0"), [], "radio.latency"),
    ("negative-latency-s", _replace(GOOD, "latency = 1", "latency_s = -0.01"), [], "radio.latency_s"),
    ("zero-latency-s", _replace(GOOD, "latency = 1", "latency_s = 0.0"), [], "radio.latency_s"),
    ("loss-above-1", _replace(GOOD, "loss = 0.0", "loss = 1.5"), [], "radio.loss"),
    ("loss-below-0", _replace(GOOD, "loss = 0.0", "loss = -0.1"), [], "radio.loss"),
    ("negative-ticks", _replace(GOOD, "ticks = 3", "ticks = -3"), [], "run.ticks"),
    ("unknown-behaviour", _replace(GOOD, 'use = "beacon"', 'use = "no_such_behaviour"'), [],
     "robots[0].behaviors[0].use"),
    ("unknown-behaviour-path", _replace(GOOD, 'use = "beacon"', 'use = "no_such_module_xyz:Thing"'), [],
     "robots[0].behaviors[0].use"),
    ("unknown-behaviour-param", _replace(GOOD, 'use = "beacon" }', 'use = "beacon", volume = 11 }'), [],
     "robots[0].behaviors[0]"),
    ("set-without-equals", GOOD, ["--set", "radio.loss"], "radio.loss"),
    ("set-out-of-range", GOOD, ["--set", "radio.loss=2"], "radio.loss"),
    ("set-unknown-key", GOOD, ["--set", "radio.colour=1"], "radio.colour"),
    ("set-negative-range", GOOD, ["--set", "radio.range=-5"], "radio.range"),
    ("set-missing-group", GOOD, ["--set", "robots.7.count=3"], "robots.7.count"),
    ("toml-syntax-error", GOOD + "\n[radio\nloss = 0.1\n", [], None),
    ("toml-duplicate-key", _replace(GOOD, "ticks = 3", "ticks = 3\nticks = 4"), [], None),
]


def _cli_inproc(args: list[str], cwd: Path, monkeypatch, capsys) -> tuple[int, str]:
    """``swarmactors ARGS`` in this process (fast: no interpreter start-up); (exit code, stderr)."""
    from swarmactors.cli import main

    monkeypatch.chdir(cwd)
    monkeypatch.delenv("COLUMNS", raising=False)
    capsys.readouterr()
    try:
        code = main(args)
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    return code, capsys.readouterr().err


def _assert_rejected(code: int, err: str, tmp_path: Path, file: str, key: str | None) -> None:
    assert code == EXIT_INPUT, err
    assert file in err, f"the error does not name the file: {err!r}"
    if key is not None:
        assert key in err, f"the error does not name the key {key!r}: {err!r}"
    assert "Traceback" not in err
    # nothing started: no out/ directory, no result.json, no trace anywhere under the working directory
    assert sorted(p.name for p in tmp_path.iterdir()) == [file]


@pytest.mark.parametrize("text,extra,key", [c[1:] for c in BAD_SCENARIOS], ids=[c[0] for c in BAD_SCENARIOS])
def test_cli_rejects_bad_scenario_before_starting(tmp_path, monkeypatch, capsys, text, extra, key):
    (tmp_path / "s.toml").write_text(text)
    code, err = _cli_inproc(["run", "s.toml", *extra], tmp_path, monkeypatch, capsys)
    _assert_rejected(code, err, tmp_path, "s.toml", key)


@pytest.mark.slow
@pytest.mark.parametrize("case", ["unknown-key", "loss-above-1", "toml-syntax-error"])
def test_cli_exit_code_2_from_a_real_process(tmp_path, case):
    """The same through ``python -m swarmactors`` (exit status of the process itself)."""
    _, text, extra, key = next(c for c in BAD_SCENARIOS if c[0] == case)
    (tmp_path / "s.toml").write_text(text)
    proc = _cli(["run", "s.toml", *extra], cwd=tmp_path)
    _assert_rejected(proc.returncode, proc.stderr, tmp_path, "s.toml", key)


@pytest.mark.slow
def test_cli_rejects_missing_file(tmp_path):
    proc = _cli(["run", "nowhere.toml"], cwd=tmp_path)
    assert proc.returncode == EXIT_INPUT, proc.stderr
    assert "nowhere.toml" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_cli_rejects_negative_processes(tmp_path):
    (tmp_path / "s.toml").write_text(GOOD)
    proc = _cli(["run", "s.toml", "--processes", "-1"], cwd=tmp_path)
    assert proc.returncode == EXIT_INPUT, proc.stderr
    assert "--processes" in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


@pytest.mark.parametrize("extra", [["--processes", "many"], ["--seed", "x"], ["--clock", "sundial"],
                                   ["--seed", "-4"]])
def test_cli_rejects_bad_options(tmp_path, monkeypatch, capsys, extra):
    (tmp_path / "s.toml").write_text(GOOD)
    code, err = _cli_inproc(["run", "s.toml", *extra], tmp_path, monkeypatch, capsys)
    assert code == EXIT_INPUT, err
    assert extra[0] in err or "run.seed" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


@pytest.mark.slow
def test_cli_good_scenario_runs_and_writes_output(tmp_path):
    """The control for the tests above: the same file, unbroken, runs and writes its output."""
    (tmp_path / "s.toml").write_text(GOOD)
    proc = _cli(["run", "s.toml", "--quiet"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "out" / "bad-input" / "latest" / "result.json").is_file()  # out/<name>/<UTC>-s<seed>


@pytest.mark.slow
def test_cli_error_names_a_long_path_verbatim(tmp_path):
    """The file name must survive intact on stderr (no wrapping at the console width).

    So that a user or a script can find it in the message.
    """
    deep = tmp_path / ("scenarios_with_a_rather_long_directory_name_" * 2) / "experiment_variant_b"
    deep.mkdir(parents=True)
    path = deep / "flooding_with_negative_loss.toml"
    path.write_text(_replace(GOOD, "loss = 0.0", "loss = -0.25"))
    proc = _cli(["run", str(path)], cwd=tmp_path)
    assert proc.returncode == EXIT_INPUT
    assert str(path) in proc.stderr, f"path mangled in the message: {proc.stderr!r}"
    assert re.search(re.escape(str(path)) + r": radio\.loss", proc.stderr), proc.stderr


# ---------------------------------------------------------------------------------------------
# 2a. Garbage and forged messages on a running world's keys
# ---------------------------------------------------------------------------------------------

FLOOD_RAW = {
    "run": {"name": "wire", "seed": 7, "ticks": 12, "watchdog_s": 0.5, "join_timeout_s": 20},
    "radio": {"range": 1.0, "latency": 1},
    "world": {"bounds": [[0.0, 0.0], [4.0, 4.0]]},
    "robots": [{"count": 30, "placement": "uniform", "connected": True,
                "behaviors": [{"use": "flooding", "origin": 0, "at": 2, "expiry": 6}]}],
}
PAUSE_AT = 3  # lockstep injections happen while the world is paused before this tick (the flood is in the air)


def _get(z: zenoh.Session, key: str, payload: bytes, timeout: float = 5.0) -> tuple[str, bytes]:
    """One query from a raw Zenoh session: ("ok", payload), ("err", payload) or ("none", b"")."""
    for reply in z.get(key, payload=payload, timeout=timeout):
        if reply.ok is not None:
            return "ok", reply.ok.payload.to_bytes()
        return "err", reply.err.payload.to_bytes()
    return "none", b""


class _HostThread:
    """A robot host in its own thread and asyncio loop, so that the test decides when it joins.

    Its Zenoh session (and liveliness token) stays open until ``stop()``, after the world
    has finished, as a host process that outlives the run would.
    """

    def __init__(self, endpoint: str, run_id: str, count: int | None):
        self.endpoint, self.run_id, self.count = endpoint, run_id, count
        self.loop: asyncio.AbstractEventLoop | None = None
        self.task: asyncio.Task | None = None
        self.error: BaseException | None = None
        self.ran_to_end = False
        self.release = threading.Event()
        self.thread = threading.Thread(target=self._main, daemon=True)
        self.thread.start()

    def _main(self) -> None:
        async def main() -> None:
            self.loop = asyncio.get_running_loop()
            self.task = asyncio.current_task()
            with Link(Endpoints(mode="peer", connect=[self.endpoint])) as link:
                host = RobotHost(link, Keys(self.run_id), self.count)
                await host.join()
                await host.run()
                self.ran_to_end = True
                await asyncio.to_thread(self.release.wait, 60)

        try:
            asyncio.run(main())
        except asyncio.CancelledError:
            pass
        except BaseException as exc:  # recorded for the test to report
            self.error = exc

    def stop(self) -> bool:
        """Let the host go (cancel it if the world never answered it); True if it had run to its end."""
        self.release.set()
        self.thread.join(5.0)
        if self.thread.is_alive() and self.loop is not None and self.task is not None:
            self.loop.call_soon_threadsafe(self.task.cancel)
            self.thread.join(10.0)
        return self.ran_to_end


class WireRun:
    """Run a scenario's world in this thread while a driver thread injects messages.

    The driver thread starts the hosts and a raw Zenoh session (connected to the world's endpoint like
    any outsider) that injects messages.

    Lockstep: the driver asks the world (``control`` ``run_to``) to pause before tick
    ``PAUSE_AT`` before any host joins, injects while it is paused, waits until the
    world has counted what it expects, and resumes. Realtime: it injects from tick 3 on.
    """

    def __init__(self, raw: dict, out: Path, inject=None, hosts: tuple = (None,), expect_malformed: int = 0):
        self.sc = resolve_scenario(raw, "<wire-test>")
        self.out, self.inject, self.hosts_counts, self.expect = out, inject, hosts, expect_malformed
        self.run_id = new_run_id("wire")
        self.keys = Keys(self.run_id)
        self.hosts: list[_HostThread] = []
        self.replies: dict[str, tuple[str, bytes]] = {}
        self.notes: dict = {}
        self.driver_error: BaseException | None = None
        self.hosts_ended_by_themselves: bool | None = None

    def run(self):
        driver: list[threading.Thread] = []

        def on_open(world: WorldSession, link) -> None:
            endpoint = link.locators()[0]
            t = threading.Thread(target=self._drive_safely, args=(endpoint,), daemon=True)
            t.start()
            driver.append(t)

        try:
            result = asyncio.run(run_world(self.sc, self.out, Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]),
                                           self.run_id, processes=0, local_host=False, on_open=on_open))
        finally:
            for t in driver:
                t.join(20)
            self.hosts_ended_by_themselves = all([h.stop() for h in self.hosts])
        if self.driver_error is not None:
            raise self.driver_error
        return result

    def _drive_safely(self, endpoint: str) -> None:
        try:
            self._drive(endpoint)
        except BaseException as exc:
            self.driver_error = exc

    def _status(self, z) -> dict:
        kind, data = _get(z, self.keys.control, pack({"cmd": "status"}))
        assert kind == "ok", (kind, data)
        return unpack(data)

    def _wait(self, z, cond, timeout: float = 10.0) -> dict:
        deadline = time.monotonic() + timeout
        while True:
            st_ = self._status(z)
            if cond(st_) or time.monotonic() > deadline:
                return st_
            time.sleep(0.01)

    def _drive(self, endpoint: str) -> None:
        lockstep = self.sc["run"]["clock"] == "lockstep"
        z = zenoh.open(make_config(Endpoints(mode="peer", connect=[endpoint])))
        try:
            if lockstep:
                kind, data = _get(z, self.keys.control, pack({"cmd": "run_to", "tick": PAUSE_AT}))
                assert kind == "ok" and unpack(data)["ok"], (kind, data)
            for i, count in enumerate(self.hosts_counts):
                self.hosts.append(_HostThread(endpoint, self.run_id, count))
                self._wait(z, lambda s, n=i + 1: len(s["hosts"]) >= n)
            if lockstep:
                before = self._wait(z, lambda s: s["started"] and s["paused"])
                assert before["paused"] and before["tick"] == PAUSE_AT - 1, f"the world did not pause: {before}"
            else:
                before = self._wait(z, lambda s: s["started"] and s["tick"] >= 3)
            self.notes["before"] = before
            if self.inject is not None:
                self.inject(self, z, before)
            self.notes["after"] = self._wait(
                z, lambda s: s["dropped"]["malformed"] >= self.expect, timeout=5.0)
        finally:
            if lockstep:  # never leave the world paused, whatever happened above
                _get(z, self.keys.control, pack({"cmd": "resume"}), timeout=2.0)
            z.close()


def _flood_outcome(result) -> dict:
    """What the flood did, independent of the trace's malformed-record list."""
    return {
        rid: (r["alive"], r["failed"], r["flooding"]["received"], r["flooding"]["forwarded"])
        for rid, r in result.robots.items()
    }


def _trace_without_malformed(result) -> list[dict]:
    return [{k: v for k, v in rec.items() if k != "mal"} for rec in result.trace]


def _garbage(wr: WireRun, z: zenoh.Session, status: dict) -> None:
    """Garbage on every key the world listens on; every item must be dropped and counted once."""
    k = wr.keys
    (host,) = status["hosts"]  # the one real host
    ghost = "h7"  # a host name the world never gave out
    puts = {
        "put-not-msgpack": (k.up(host), b"\xc1\xc1garbage"),
        "put-truncated-msgpack": (k.up(host), pack({"h": host, "t": 2, "r": []})[:-3]),
        "put-trailing-bytes": (k.up(host), pack({"h": host, "t": 2, "r": []}) + b"\x00\x01"),
        "put-not-a-map": (k.up(host), pack([host, 2, []])),
        "put-forged-h": (k.up(host), pack({"h": "h9", "t": 2, "r": []})),
        "put-forged-robot-id": (k.up(host), pack({"h": host, "t": 2, "r": [[999, [1.0, 0.0], [], None, None]]})),
        "put-unknown-host-garbage": (k.up(ghost), b"\xff\xfe"),
    }
    queries = {
        "step-not-msgpack": (k.up(host), b"\xc1"),
        "step-empty": (k.up(host), b""),
        "step-forged-h": (k.up(host), pack({"h": "h9", "t": PAUSE_AT - 1, "r": []})),
        "step-missing-h": (k.up(host), pack({"t": PAUSE_AT - 1, "r": []})),
        "step-tick-not-int": (k.up(host), pack({"h": host, "t": "soon", "r": []})),
        "step-tick-bool": (k.up(host), pack({"h": host, "t": True, "r": []})),
        "step-robots-not-list": (k.up(host), pack({"h": host, "t": PAUSE_AT - 1, "r": {"0": []}})),
        "join-not-msgpack": (k.join, b"\xc1\x00"),
        "join-not-a-map": (k.join, pack([1, 2])),
        "join-negative-count": (k.join, pack({"count": -3})),
        "join-zero-count": (k.join, pack({"count": 0})),
        "join-count-str": (k.join, pack({"count": "all"})),
        "join-count-bool": (k.join, pack({"count": True})),
    }
    wr.notes["expected"] = len(puts) + len(queries)
    for key, data in puts.values():
        z.put(key, data)
    for name, (key, data) in queries.items():
        wr.replies[name] = _get(z, key, data)


N_GARBAGE = 20


@pytest.fixture(scope="module")
def garbage_run(tmp_path_factory):
    wr = WireRun(FLOOD_RAW, tmp_path_factory.mktemp("garbage") / "run", inject=_garbage, expect_malformed=N_GARBAGE)
    return wr, wr.run()


@pytest.mark.slow
def test_wire_garbage_is_dropped_counted_and_changes_nothing(garbage_run, clean_flood):
    wr, result = garbage_run
    assert wr.notes["expected"] == N_GARBAGE  # keep the count in step with _garbage
    # the run went on to its end, and every robot of the real host took part in it
    assert result["ticks"] == FLOOD_RAW["run"]["ticks"]
    assert not result["interrupted"]
    assert all(r["alive"] for r in result.robots.values())
    assert wr.hosts_ended_by_themselves
    # every garbage query was refused (an error reply): no step answered, no robots handed out
    for name, (kind, data) in wr.replies.items():
        assert kind == "err", f"{name}: the world answered garbage with {kind} {data[:80]!r}"
    assert len(result.robots) == 30
    # counted, once each
    assert result["world"]["dropped"]["malformed"] == N_GARBAGE
    assert clean_flood["world"]["dropped"]["malformed"] == 0
    assert len(result["world"]["malformed_examples"]) == N_GARBAGE
    # the flood's outcome, the counters and the trace are those of the clean run
    assert _flood_outcome(result) == _flood_outcome(clean_flood)
    for key in ("frames_sent", "deliveries"):
        assert result["world"][key] == clean_flood["world"][key]
    assert _trace_without_malformed(result) == _trace_without_malformed(clean_flood)


@pytest.mark.slow
def test_wire_garbage_is_recorded_in_the_trace(garbage_run):
    """Every malformed drop counted in result.json is also in the trace (tick records' ``mal``).

    Including garbage that arrives between two ticks (here: while the world is paused).
    """
    wr, result = garbage_run
    in_trace = sum(len(rec.get("mal", ())) for rec in result.trace)
    assert in_trace == result["world"]["dropped"]["malformed"] == N_GARBAGE


CONTROL_GARBAGE = {
    "not-msgpack": b"\xc1",
    "not-a-map": pack([1, 2]),
    "cmd-not-a-string": pack({"cmd": 5}),
    "unknown-cmd": pack({"cmd": "explode"}),
    "kill-not-ids": pack({"cmd": "kill", "args": "all"}),
    "kill-no-such-robot": pack({"cmd": "kill", "args": [999]}),
    "loss-out-of-range": pack({"cmd": "loss", "args": 2.0}),
    "partition-not-lists": pack({"cmd": "partition", "args": 5}),
    "run-to-not-a-tick": pack({"cmd": "run_to", "tick": "soon"}),
    "move-no-such-object": pack({"cmd": "move", "args": {"object": "nowhere", "pos": [0.0, 0.0]}}),
}


def _control_garbage(wr: WireRun, z, status):
    wr.notes["expected"] = len(CONTROL_GARBAGE)
    for name, data in CONTROL_GARBAGE.items():
        wr.replies[name] = _get(z, wr.keys.control, data, timeout=2.0)


@pytest.mark.slow
def test_control_garbage_is_refused_counted_and_changes_nothing(tmp_path, clean_flood):
    """Every malformed or inapplicable ``control`` command is refused at once.

    It gets ``{"ok": false, "error": ...}`` at once (none is queued to fail later), is counted as
    malformed, and the run is the clean run.
    """
    wr = WireRun(FLOOD_RAW, tmp_path / "run", inject=_control_garbage, expect_malformed=len(CONTROL_GARBAGE))
    result = wr.run()
    answers = {}
    for name, (kind, data) in wr.replies.items():
        answers[name] = unpack(data).get("ok") if kind == "ok" else kind
    assert answers == {name: False for name in CONTROL_GARBAGE}, answers
    assert result["ticks"] == FLOOD_RAW["run"]["ticks"]
    assert _flood_outcome(result) == _flood_outcome(clean_flood)
    assert result["world"]["dropped"]["malformed"] == len(CONTROL_GARBAGE)


def _forged_step_robot(wr: WireRun, z, status):
    """A well-formed step on the real host's key, but for a robot that host does not run."""
    (host,) = status["hosts"]
    wr.replies["forged"] = _get(z, wr.keys.up(host), pack({"h": host, "t": PAUSE_AT - 1,
                                                            "r": [[999, [1.0, 0.0], [], None, None]]}), timeout=3)


def _forged_step_crash(wr: WireRun, z, status):
    """A well-formed step on the real host's key that claims one of its robots crashed."""
    (host,) = status["hosts"]
    wr.replies["forged"] = _get(z, wr.keys.up(host), pack({"h": host, "t": PAUSE_AT - 1,
                                                            "r": [[5, None, [], None, "forged crash"]]}), timeout=3)


def _step_from_unknown_host(wr: WireRun, z, status):
    """A well-formed step from a host name the world never gave out."""
    wr.replies["forged"] = _get(z, wr.keys.up("h7"), pack({"h": "h7", "t": PAUSE_AT - 1, "r": []}), timeout=3)


@pytest.mark.slow
@pytest.mark.parametrize("inject", [_forged_step_robot, _forged_step_crash, _step_from_unknown_host],
                         ids=["forged-robot-id", "forged-crash-report", "unknown-host"])
def test_forged_step_query_is_dropped_and_counted(tmp_path, clean_flood, inject):
    """A step query forged by an outsider on ``up/{host}`` is refused.

    It must not take the real host's place at the barrier, nor speak for robots: it is refused and
    counted as malformed, and the run is the clean run.
    """
    wr = WireRun(FLOOD_RAW, tmp_path / "run", inject=inject, expect_malformed=1)
    result = wr.run()
    assert result["ticks"] == FLOOD_RAW["run"]["ticks"]
    failed = {rid: r["failed"] for rid, r in result.robots.items() if r["failed"]}
    assert failed == {}, f"the forged step failed robots: {dict(list(failed.items())[:3])}"
    assert wr.hosts_ended_by_themselves, "the real host was left waiting for an answer to its step"
    assert result["world"]["dropped"]["malformed"] >= 1
    assert wr.replies["forged"][0] == "err"
    assert _flood_outcome(result) == _flood_outcome(clean_flood)


BEACON_RT_RAW = {
    "run": {"name": "wire-rt", "seed": 3, "clock": "realtime", "ticks": 30, "dt": 0.05, "watchdog_s": 1.0,
            "join_timeout_s": 20},
    "radio": {"range": 2.0, "latency_s": 0.005},
    "robots": [{"positions": [[0.0, 0.0], [0.5, 0.0], [1.0, 0.0], [1.5, 0.0], [2.0, 0.0], [2.5, 0.0]],
                "behaviors": [{"use": "beacon"}]}],
}


def _forge_realtime(wr: WireRun, z, status):
    """Realtime puts on host A's key, in host A's name, that speak for host B's robot."""
    hosts = status["hosts"]
    a, b = sorted(hosts)
    victim = hosts[b][0]
    wr.notes["victim"] = victim
    forged_frame = [None, "BEACON", 10**6, pack([0.0, b"forged"]), []]
    items = [
        pack({"h": a, "t": status["tick"], "r": [[victim, [3.0, 3.0], [], None, None]]}),
        pack({"h": a, "t": status["tick"], "r": [[victim, None, [], None, "forged crash"]]}),
        pack({"h": a, "t": status["tick"], "r": [[victim, None, [forged_frame], None, None]]}),
        pack({"h": a, "t": status["tick"], "r": [[999, None, [forged_frame], None, None]]}),
        pack({"h": a, "t": status["tick"], "r": [[-1, None, [], {"role": "x"}, None]]}),
        pack({"h": b, "t": status["tick"], "r": []}),  # forged h (b's name on a's key)
        b"\xc1",
    ]
    wr.notes["expected"] = len(items)
    for data in items:
        z.put(wr.keys.up(a), data)


@pytest.mark.slow
def test_realtime_forged_robot_ids_are_dropped_and_counted(tmp_path):
    wr = WireRun(BEACON_RT_RAW, tmp_path / "run", inject=_forge_realtime, hosts=(2, None), expect_malformed=7)
    result = wr.run()
    assert wr.notes["expected"] == 7
    victim = wr.notes["victim"]
    assert result["world"]["dropped"]["malformed"] == 7, result["world"]["malformed_examples"]
    assert all(r["alive"] for r in result.robots.values()), {i: r["failed"] for i, r in result.robots.items()}
    v = result.robots[victim]
    # not moved by the forged velocity, and no frame sent in its name beyond its own beacons
    assert v["pose"][:2] == BEACON_RT_RAW["robots"][0]["positions"][victim]
    assert result.frames(victim)["sent"] == v["beacon"]["sent"]
    assert result["world"]["frames_sent"] == sum(r["beacon"]["sent"] for r in result.robots.values())


# ---------------------------------------------------------------------------------------------
# 2b. Fuzzing the decoders
# ---------------------------------------------------------------------------------------------

INTS = st.integers(min_value=-(2**63), max_value=2**64 - 1)  # what msgpack can carry
SCALARS = st.none() | st.booleans() | INTS | st.floats() | st.text(max_size=8) | st.binary(max_size=8)
VALUES = st.recursive(
    SCALARS,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=4) | INTS, inner, max_size=4),
    max_leaves=12,
)
FUZZ = settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])


FUZZ_RAW = {
    "run": {"ticks": 10, "seed": 1},
    "radio": {"range": 1.5, "loss": 0.3},
    "world": {"objects": [{"name": "target", "pos": [1.0, 1.0]}]},
    "robots": [{"positions": [[0, 0], [1, 0], [2, 0], [0, 1], [1, 1]], "behaviors": [{"use": "beacon"}]}],
}
_FUZZ_SPEC = resolve(FUZZ_RAW, "<fuzz>")
H0_ROBOTS, H1_ROBOTS = {0, 1, 2}, {3, 4}


def _fuzz_sim() -> Simulation:
    """The fuzz scenario's simulation at tick 0, robots 0-2 run by host h0 and 3-4 by h1."""
    import copy

    sim = Simulation(copy.deepcopy(_FUZZ_SPEC))
    sim.claim("h0", len(H0_ROBOTS))
    sim.claim("h1", len(H1_ROBOTS))
    sim.begin(0, 0.0)
    return sim


def _fuzz_session(register: bool = True) -> tuple[WorldSession, FakeLink, dict[str, JoinReply]]:
    """The fuzz scenario's world session on a fake link, hosts h0 (robots 0-2) and h1 (3-4) joined (and registered)."""
    import copy

    link = FakeLink()
    world = WorldSession(copy.deepcopy(_FUZZ_SPEC), link, Keys("fuzz"), sinks=[TraceWriter(None, {})])
    world.open()
    joined = {}
    for count in (len(H0_ROBOTS), len(H1_ROBOTS)) if register else ():
        q = link.query(world.keys.join, encode(JoinRequest(count)))
        j = decode(q.replies[0][1], JoinReply, what="join reply")
        joined[j.host] = j
        link.query(world.keys.up(j.host), seal(j.key, encode(Uplink(j.host, -1))))
    return world, link, joined


@FUZZ
@given(st.binary(max_size=64))
def test_fuzz_codec_unpack_raises_only_malformed(data):
    try:
        unpack(data)
    except MalformedMessage:
        pass
    try:
        unpack_map(data, what="fuzz", required={"h": str, "t": int})
    except MalformedMessage:
        pass


@pytest.mark.slow  # no Zenoh, but about 4 s of examples
@FUZZ
@given(VALUES)
def test_fuzz_codec_roundtrip(value):
    assert unpack(pack(value)) == value or value != value or _has_nan(value)


def _has_nan(v) -> bool:
    if isinstance(v, float):
        return v != v
    if isinstance(v, list):
        return any(_has_nan(x) for x in v)
    if isinstance(v, dict):
        return any(_has_nan(x) for x in v.values())
    return False


@FUZZ
@given(st.binary(max_size=64) | VALUES.map(pack) | st.builds(
    lambda h, t, r: pack({"h": h, "t": t, "r": r}), st.sampled_from(["h0", "h1", "hx"]) | VALUES, VALUES, VALUES))
def test_fuzz_decode_up_returns_a_map_or_counts_malformed(payload):
    """Whatever comes on up/h0, sealed with h0's key or not, the session counts it once or holds it as a step."""
    world, link, joined = _fuzz_session()
    counted = world.sim.counters.dropped
    link.put(world.keys.up("h0"), payload)  # not sealed with h0's key: counted, whatever it holds
    assert counted["malformed"] == 1
    link.put(world.keys.up("h0"), seal(joined["h0"].key, payload))  # sealed: a step (held) or counted once
    assert counted["malformed"] in (1, 2)


ROBOT_IDS = st.sampled_from([0, 1, 2, 3, 4, -1, 5, 99, True, False, 2**64 - 1]) | INTS
FRAMES = (
    st.tuples(st.none() | st.sampled_from([0, 1, 2, 3, 4, 7, -1]) | INTS, st.text(max_size=70),
              st.integers(min_value=0, max_value=2**64 - 1), st.binary(max_size=8),
              st.lists(st.sampled_from([0, 1, 2, 3, 4]) | INTS, max_size=3)).map(list)
    | st.lists(VALUES, min_size=5, max_size=5)
    | VALUES
)
RECORDS = (
    st.tuples(ROBOT_IDS, st.none() | st.lists(st.floats() | INTS, max_size=3) | VALUES,
              st.lists(FRAMES, max_size=3) | VALUES,
              st.none() | st.dictionaries(st.text(max_size=4), VALUES, max_size=3) | VALUES,
              st.none() | VALUES).map(list)
    | VALUES
)


@pytest.mark.slow  # no Zenoh, but about 4 s of examples
@FUZZ
@given(st.lists(RECORDS, max_size=4), st.none() | VALUES)
@example([[3, [1.0, 1.0], [[None, "K", 1, b"", []]], None, "forged crash"]], {3: {"beacon": {}}})  # h1's robot
@example([[True, None, [], None, None]], None)  # a bool is not a robot id
@example([[0, None, 1, None, None]], None)  # frames that are not a list
@example([[0, None, [], {1: "a", "b": 2}, None]], None)  # status keys of mixed types
@example([[0, None, [[None, "K", 2**63, b"", []]], None, None]], None)  # seq beyond int64, with loss > 0
def test_fuzz_absorb_and_record_never_crash_the_world(records, reports):
    """Whatever a (buggy or hostile) host h0 sends, the world survives it.

    It counts what it cannot use, never touches robots h0 does not run, and can still record and end
    the tick.
    """
    sim = _fuzz_sim()
    data = pack(unpack(pack({"h": "h0", "t": 0, "r": records, "rep": reports})))  # as it arrives off the wire
    try:
        msg = decode(data, Uplink, what="uplink")
    except MalformedMessage:  # refused whole by the message definition (the session counts it once)
        return
    if msg.reports is not None:
        sim.take_reports("h0", msg.reports)
    sim.take("h0", msg)
    sim.transmit()
    sim.end()
    for rid in H1_ROBOTS:
        assert sim.robots.alive[rid], f"h0 killed h1's robot {rid}"
        assert not sim.robots.vel[rid].any(), f"h0 moved h1's robot {rid}"
        assert sim.counters.sent_by.get(rid, 0) == 0, f"h0 sent a frame as h1's robot {rid}"
        assert rid not in sim.reports, f"h0 wrote h1's robot {rid}'s report"


@FUZZ
@given(st.integers(min_value=0, max_value=4), FRAMES)
@example(0, [None, "K", 2**63, b"", []])
@example(0, [2**64 - 1, "K", 1, b"", []])
@example(0, [None, "K", 1, b"", [2**64 - 1, -(2**63)]])
def test_fuzz_check_frame_and_transmit(src, frame):
    sim = _fuzz_sim()
    row = [src, None, [frame], None, None]
    try:
        msg = decode(pack({"h": "h0", "t": 0, "r": [row]}), Uplink, what="uplink")
    except MalformedMessage:
        return
    sim.take("h0", msg)
    sim.transmit()
    sim.end()
    sim.begin(1, 1.0)  # the copies fall due
    sim.end()


@FUZZ
@given(st.binary(max_size=32) | VALUES.map(pack) | st.builds(
    lambda cmd, args, tick: pack({"cmd": cmd, "args": args, "tick": tick}),
    st.sampled_from(["status", "pause", "resume", "step", "run_to", "stop", "kill", "kill_fraction", "add",
                     "cut", "restore", "partition", "heal", "loss", "move", "explode"]) | VALUES,
    VALUES, VALUES))
@example(pack({"cmd": "partition", "args": 5}))
@example(pack({"cmd": "cut", "args": [[0, "a"]]}))
@example(pack({"cmd": "kill", "args": True}))
@example(pack({"cmd": "kill_fraction", "args": "half"}))
@example(pack({"cmd": "add", "args": [{"pos": "here"}]}))
@example(pack({"cmd": "move", "args": {"object": "target", "pos": "there"}}))
@example(pack({"cmd": "run_to", "tick": "soon"}))
def test_fuzz_control_answers_once_and_never_crashes_the_world(payload):
    world, link, _ = _fuzz_session()
    q = link.query(world.keys.control, payload)
    assert len(q.replies) == 1, q.replies
    kind, data = q.replies[0]
    assert kind == "ok"
    answer = unpack(data)
    assert isinstance(answer, dict) and isinstance(answer.get("ok"), bool)
    # what it queued is applied at the next tick: that must not crash the world either
    world.sim.begin(1, 1.0)
    world.sim.end()


@FUZZ
@given(st.binary(max_size=32) | VALUES.map(pack) | VALUES.map(lambda c: pack({"count": c})))
def test_fuzz_join_answers_once_and_never_crashes(payload):
    world, link, _ = _fuzz_session(register=False)
    q = link.query(world.keys.join, payload)
    assert len(q.replies) == 1
    kind, data = q.replies[0]
    if kind == "ok":
        reply = unpack(data)
        assert reply["host"] == "h0" and reply["robots"]


_TRACE_HEADER = pack({"trace": "swarmactors", "version": 1, "run_id": "x", "clock": "lockstep", "seed": 0,
                      "pos_digits": 6, "scenario": {}})


@pytest.mark.slow  # no Zenoh, but about 4 s of examples
@FUZZ
@given(st.binary(max_size=200) | st.builds(
    lambda recs, tail: _TRACE_HEADER + b"".join(pack(r) for r in recs) + tail,
    st.lists(VALUES | st.builds(lambda t, rest: {"t": t, **rest}, VALUES, st.dictionaries(st.text(max_size=3), VALUES,
                                                                                          max_size=3)),
             max_size=4),
    st.binary(max_size=8)))
def test_fuzz_iter_trace_raises_only_trace_error(data):
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "t.msgpack"
        path.write_bytes(data)
        try:
            for _ in iter_trace(path):
                pass
        except TraceError as exc:
            assert str(path) in str(exc)


# ---------------------------------------------------------------------------------------------
# 6. Trace files: truncated or corrupt
# ---------------------------------------------------------------------------------------------

TRACE_RAW = {
    "run": {"name": "trace", "ticks": 6},
    "radio": {"range": 1.0},
    "robots": [{"positions": [[0, 0], [0.5, 0], [1.0, 0]], "behaviors": [{"use": "beacon"}]}],
}


def _offsets(data: bytes) -> list[int]:
    u = msgpack.Unpacker(io.BytesIO(data), raw=False, strict_map_key=False)
    starts, pos = [], 0
    for _ in u:
        starts.append(pos)
        pos = u.tell()
    assert pos == len(data)
    return starts


@pytest.fixture(scope="module")
def trace_bytes(tmp_path_factory):
    """A real trace file's bytes and the byte offset at which each of its objects starts."""
    sc = resolve_scenario(TRACE_RAW, "<trace-test>")
    result = asyncio.run(run_world(sc, tmp_path_factory.mktemp("trace") / "run",
                                   Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]), new_run_id("trace")))
    data = result.trace_path.read_bytes()
    starts = _offsets(data)
    assert len(starts) == 1 + 6 + 1  # header, 6 ticks, footer
    return data, starts


def _offset_in(message: str) -> int:
    m = re.search(r"byte offset (\d+)", message)
    assert m, f"no byte offset in {message!r}"
    return int(m.group(1))


@pytest.mark.slow
def test_intact_trace_reads_and_verifies(tmp_path, trace_bytes):
    data, _ = trace_bytes
    path = tmp_path / "trace.msgpack"
    path.write_bytes(data)
    header, records, footer = read_trace(path)
    assert [r["t"] for r in records] == list(range(6))
    assert verify(path) == footer["trace_hash"]


@pytest.mark.slow
@pytest.mark.parametrize("record", [0, 1, 3, 7])  # 0 = header, 7 = footer
def test_truncated_trace_names_file_and_offset(tmp_path, trace_bytes, record):
    data, starts = trace_bytes
    path = tmp_path / "trace.msgpack"
    path.write_bytes(data[: starts[record] + 2])
    with pytest.raises(TraceError) as info:
        read_trace(path)
    assert str(path) in str(info.value)
    assert _offset_in(str(info.value)) == starts[record]


@pytest.mark.slow
@pytest.mark.parametrize("record", [1, 4, 7])
def test_corrupt_trace_names_file_and_offset(tmp_path, trace_bytes, record):
    data, starts = trace_bytes
    path = tmp_path / "trace.msgpack"
    s = starts[record]
    path.write_bytes(data[:s] + b"\xc1" + data[s + 1:])  # 0xc1: never used in msgpack
    with pytest.raises(TraceError) as info:
        read_trace(path)
    assert str(path) in str(info.value)
    assert _offset_in(str(info.value)) == s


@pytest.mark.slow
def test_trace_record_that_is_not_a_map(tmp_path, trace_bytes):
    data, starts = trace_bytes
    path = tmp_path / "trace.msgpack"
    path.write_bytes(data[: starts[2]] + pack([1, 2, 3]) + data[starts[2]:])
    with pytest.raises(TraceError) as info:
        read_trace(path)
    assert str(path) in str(info.value) and _offset_in(str(info.value)) == starts[2]


@pytest.mark.slow
def test_trace_tick_record_without_tick(tmp_path, trace_bytes):
    data, starts = trace_bytes
    path = tmp_path / "trace.msgpack"
    path.write_bytes(data[: starts[3]] + pack({"pos": []}) + data[starts[3]:])
    with pytest.raises(TraceError) as info:
        read_trace(path)
    assert str(path) in str(info.value) and _offset_in(str(info.value)) == starts[3]


def test_not_a_trace(tmp_path):
    path = tmp_path / "trace.msgpack"
    path.write_bytes(pack({"hello": "world"}) + pack({"t": 0}))
    with pytest.raises(TraceError) as info:
        read_trace(path)
    assert str(path) in str(info.value) and _offset_in(str(info.value)) == 0


def test_empty_trace_file_is_an_error(tmp_path):
    """A zero-byte trace is a trace truncated at byte 0, not an empty run.

    E.g. a run killed before its buffered header reached the disk.
    """
    path = tmp_path / "trace.msgpack"
    path.write_bytes(b"")
    with pytest.raises(TraceError) as info:
        read_trace(path)
    assert str(path) in str(info.value)


def test_missing_trace_file(tmp_path):
    path = tmp_path / "nope.msgpack"
    with pytest.raises(TraceError) as info:
        read_trace(path)
    assert str(path) in str(info.value)


@pytest.mark.slow
def test_verify_trace_without_footer(tmp_path, trace_bytes):
    data, starts = trace_bytes
    path = tmp_path / "trace.msgpack"
    path.write_bytes(data[: starts[7]])  # cut cleanly before the footer
    header, records, footer = read_trace(path)
    assert footer is None and len(records) == 6
    with pytest.raises(TraceError) as info:
        verify(path)
    assert str(path) in str(info.value)
