"""Attacks on a run, tried as an attacker would (issue 27): no code from the wire, no crash from one message.

Each attack test drives a real world over Zenoh on 127.0.0.1 with a raw Zenoh client (the WireRun harness of
test_bad_input) and asserts: no code ran (a marker file is absent), the world finished with result.json, the
attack is counted under a named cause, and in lockstep the honest robots' deliveries are those of the
undisturbed run.
"""

from __future__ import annotations

import asyncio
import functools
import inspect
import json
import math
import os
import re
import signal
import stat
import subprocess
import sys
import threading
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest
import tomli_w
import zenoh

from protocols.cbaa.rules import SCORES
from protocols.stigmergy.table import CONFLICT_RULES
from swarmactors.oracle.trace import TraceHasher
from swarmactors.robot.behavior import Behavior
from swarmactors.robot.host import Robot, RobotHost, WorldLost
from swarmactors.robot.plugins import (
    BEHAVIORS,
    RefusedBehavior,
    UnknownRule,
    allowed,
    available,
    resolve,
    resolve_behavior,
)
from swarmactors.runs.launcher import new_run_id, private_endpoints, run_world
from swarmactors.runs.launcher import run as launcher_run
from swarmactors.runs.scenario import ScenarioError, resolve_scenario
from swarmactors.runs.scenario import resolve as resolve_typed
from swarmactors.tools.scene import Scene
from swarmactors.tools.viewer import Source, ViewerServer
from test_bad_input import FLOOD_RAW, PAUSE_AT, FakeLink, WireRun, _get, _HostThread
from transport import Endpoints, Keys, Link, host_loss_s, make_config, pack, seal, unpack
from transport.messages import (
    MAX_PER_REQUEST,
    PROTOCOL_VERSION,
    Ack,
    Inputs,
    JoinReply,
    JoinRequest,
    RobotDescr,
    RunInfo,
    Uplink,
    action_problem,
    decode,
    encode,
)
from world import WorldSession
from world.counters import MORE_MALFORMED, SAMPLES_PER_TICK
from world.kinematics import MAX_SPEED, bad_positions, velocity_problem

HONEST = 30  # FLOOD_RAW's robots
SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"


def _honest_deliveries(result) -> list:
    return [(rec["t"], sorted(tuple(d) for d in rec.get("del", []) if d[0] < HONEST and d[2] < HONEST))
            for rec in result.trace]


@pytest.fixture(scope="module")
def undisturbed(clean_flood):
    """The reference run, through the same harness (pause and resume included): tests/conftest.py's clean_flood."""
    return clean_flood


@pytest.fixture
def marker_module(tmp_path, monkeypatch):
    """A module that, if ever imported, writes a marker file; returns (module name, marker path)."""
    marker = tmp_path / "pwned"
    name = f"attack_mod_{tmp_path.name.replace('-', '_')}"
    (tmp_path / f"{name}.py").write_text(
        f"import pathlib\npathlib.Path({str(marker)!r}).write_text('imported')\n"
        "class Evil:\n    def __init__(self, **kw):\n"
        f"        pathlib.Path({str(marker)!r}).write_text('called')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    yield name, marker
    sys.modules.pop(name, None)


# ------------------------------------------------------------------ 1. behaviour allowlist
def test_allowlist_refuses_without_importing(marker_module):
    name, marker = marker_module
    assert allowed("flooding") and allowed(available(BEHAVIORS)["flooding"])
    assert not allowed("os:system") and not allowed(f"{name}:Evil") and not allowed(None) and not allowed("")
    with pytest.raises(RefusedBehavior, match="not a registered behaviour"):
        resolve_behavior(f"{name}:Evil")
    assert not marker.exists()
    assert name not in sys.modules


def test_allowed_module_must_give_a_behavior_subclass(tmp_path, marker_module):
    name, marker = marker_module
    with pytest.raises(RefusedBehavior, match="not a Behavior subclass"):
        resolve_behavior("os:system", allow={"os"})
    with pytest.raises(RefusedBehavior, match="not a Behavior subclass"):
        resolve_behavior(f"{name}:Evil", allow={name})
    assert marker.read_text() == "imported"  # the operator allowed the module: imported, never called
    assert resolve_behavior("tests_support:RandomWalk", allow={"tests_support"}).__name__ == "RandomWalk"


def test_refused_spec_crashes_its_robot_with_the_reason(tmp_path):
    marker = tmp_path / "shell"
    run = RunInfo("lockstep", 1.0, 1, 10, 1.0, 0)
    descr = RobotDescr(0, [0.0, 0.0, 0.0], [{"use": "os:system", "command": f"touch {marker}"}], "ground",
                       1.0, 1.0, 1.0)
    robot = Robot(descr, run, allow=("os",))
    assert not robot.alive and robot.error.startswith("refused behaviour 'os:system'")
    robot = Robot(descr, run)
    assert robot.error.startswith("refused behaviour 'os:system'")
    assert not marker.exists()


def _add_evil(marker, module):
    specs = [{"pos": [3.9, 3.9], "behaviors": [{"use": "os:system", "command": f"touch {marker}"}]},
             {"pos": [3.8, 3.9], "behaviors": [{"use": f"{module}:Evil"}]},
             {"pos": [3.9, 3.8], "behaviors": [{"use": "subprocess:run", "args": ["touch", str(marker)]}]}]

    def inject(wr, z, status):
        kind, data = _get(z, wr.keys.control, pack({"cmd": "add", "args": specs}))
        wr.replies["add"] = (kind, unpack(data))
    return inject


@pytest.mark.slow
def test_attack_control_add_with_foreign_behaviour(tmp_path, marker_module, undisturbed):
    """Control ``add`` naming ``os:system``, a module with import side effects, ``subprocess:run``: refused."""
    name, marker = marker_module
    shell_marker = tmp_path / "shell"
    wr = WireRun(FLOOD_RAW, tmp_path / "run", inject=_add_evil(shell_marker, name))
    result = wr.run()
    assert wr.replies["add"][1]["ok"]  # the world may add robots; the host refuses to build them
    assert not marker.exists() and not shell_marker.exists()
    assert (tmp_path / "run" / "result.json").is_file()
    added = [rid for rid in result.robots if rid >= HONEST]
    assert len(added) == 3
    for rid in added:
        assert result.robots[rid]["failed"]["cause"] == "refused_behavior"
        assert "refused behaviour" in result.robots[rid]["failed"]["error"]
    assert result["world"]["refused"] == {"refused_behavior": 3}
    events = [ev for rec in result.trace for ev in rec.get("ev", []) if ev.get("failed") == "refused_behavior"]
    assert sorted(ev["robot"] for ev in events) == added
    assert _honest_deliveries(result) == _honest_deliveries(undisturbed)


# ------------------------------------------------------------------ 0. no code from parameters
def _planted(module: str, marker: Path) -> list[dict]:
    """Behaviour specs whose string parameters name code.

    A marker module's function, and the shell-reaching ``cProfile:run`` with a write whose key is a Python
    statement (two robots' equal-timestamp writes conflict, so the conflict rule is called with that key);
    CBAA's scores likewise (``this:s`` imports ``this``).
    """
    statement = f"__import__('pathlib').Path({str(marker)!r}).write_text('shell')"
    writes = [{"at": 1, "robot": r, "key": statement, "value": r} for r in (0, 1)]
    return [{"use": "stigmergy", "conflict": f"{module}:Evil", "writes": writes},
            {"use": "stigmergy", "conflict": "cProfile:run", "writes": writes},
            {"use": "cbaa", "tasks": [[1.0, 1.0]], "score": f"{module}:Evil"},
            {"use": "cbaa", "tasks": [[1.0, 1.0]], "score": "this:s"}]


def _no_code_ran(module: str, marker: Path) -> None:
    assert not marker.exists(), marker.read_text()
    assert module not in sys.modules and "this" not in sys.modules


def _adds(specs: list[dict]) -> list[dict]:
    """Two robots side by side per planted spec (a conflict needs two writers)."""
    return [{"pos": [1.0 + 0.2 * i, 1.0 + 0.1 * j], "behaviors": [spec]}
            for i, spec in enumerate(specs) for j in range(2)]


@pytest.mark.parametrize("which", range(4))
def test_a_scenario_naming_code_in_a_parameter_is_refused_at_load(tmp_path, marker_module, which):
    name, marker = marker_module
    spec = _planted(name, marker)[which]
    raw = {"run": {"name": "p", "ticks": 5}, "robots": [{"count": 2, "behaviors": [spec]}]}
    param = "conflict" if spec["use"] == "stigmergy" else "score"
    with pytest.raises(ScenarioError, match=rf"robots\[0\]\.behaviors\[0\]: {spec['use']}: .*{param}.*chosen by name"):
        resolve_scenario(raw, "<t>")
    _no_code_ran(name, marker)


@pytest.mark.slow
def test_the_cli_refuses_a_scenario_file_naming_code_with_exit_2(tmp_path, marker_module):
    name, marker = marker_module
    path = tmp_path / "evil.toml"
    spec = _planted(name, marker)[1]
    path.write_text(tomli_w.dumps({"run": {"name": "evil", "ticks": 5},
                                   "robots": [{"count": 2, "behaviors": [spec]}]}))
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    done = subprocess.run([sys.executable, "-m", "swarmactors", "run", str(path), "--out", str(tmp_path / "o")],
                          capture_output=True, text=True, env=env, timeout=60)
    assert done.returncode == 2, done.stderr
    assert "evil.toml: robots[0].behaviors[0]: stigmergy: conflict" in done.stderr
    assert not marker.exists()


def test_a_host_refuses_a_wire_spec_naming_code(marker_module):
    """What a host builds from a join reply or an ``add`` is validated as a scenario's spec: refused, not built."""
    name, marker = marker_module
    run = RunInfo("lockstep", 1.0, 1, 10, 1.0, 0)
    for spec in _planted(name, marker):
        robot = Robot(RobotDescr(0, [0.0, 0.0, 0.0], [spec], "ground", 1.0, 1.0, 1.0), run)
        assert not robot.alive and robot.error.startswith(f"refused behaviour {spec['use']!r}"), robot.error
        assert "chosen by name" in robot.error
    _no_code_ran(name, marker)


def test_rules_are_chosen_by_name_only(marker_module):
    name, marker = marker_module
    for rules in (CONFLICT_RULES, SCORES):
        for bad in (f"{name}:Evil", name, "os:system", "", None, 3):
            assert rules.problem(bad) and "chosen by name" in rules.problem(bad)
            with pytest.raises(UnknownRule):
                rules.get(bad)
        first = next(iter(rules))
        assert rules.problem(first) is None and rules.get(first) is rules[first]
        assert rules.get(len) is len  # a callable passed in Python is the caller's own code
    _no_code_ran(name, marker)


def test_every_registered_behaviours_string_parameters_never_become_code(tmp_path, marker_module):
    """Walk every registered behaviour: each parameter that takes a string gets a path to a marker module.

    The spec must be refused at load, or, if the parameter is plain data (a table id, a name prefix), a run of
    the behaviour with it must never import the module.
    """
    name, marker = marker_module
    shipped = {}
    for path in sorted(SCENARIOS.glob("*.toml")):
        raw = tomllib.loads(path.read_text())
        for gi, group in enumerate(raw.get("robots", [])):
            for bi, spec in enumerate(group.get("behaviors", [])):
                shipped.setdefault(spec["use"], (path, gi, bi))
    exercised = 0
    for use in sorted(available(BEHAVIORS)):
        cls = resolve(BEHAVIORS, use)
        strings = [p.name for p in inspect.signature(cls).parameters.values()
                   if isinstance(p.default, str) or "str" in str(p.annotation)]
        for param in strings:
            for plant in (f"{name}:Evil", name):
                if use not in shipped:
                    raw = {"run": {"name": "walk", "ticks": 3}, "robots": [{"count": 2, "behaviors": [{"use": use}]}]}
                    gi = bi = 0
                else:
                    path, gi, bi = shipped[use]
                    raw = tomllib.loads(path.read_text())
                raw["robots"][gi]["behaviors"][bi][param] = plant
                raw["run"] = {**raw["run"], "ticks": 3, "trace": False}
                raw["checks"] = []
                try:
                    resolve_scenario(raw, f"{use}.{param}")
                except ScenarioError:
                    continue  # refused at load
                launcher_run(raw, out=tmp_path / f"{use}-{param}")  # plain data: the run must not import it
                exercised += 1
                _no_code_ran(name, marker)
    assert exercised >= 2  # sid and task_prefix are data: the walk did run behaviours with the planted strings
    _no_code_ran(name, marker)


def _add_planted(specs: list[dict]):
    def inject(wr, z, status):
        wr.replies["add"] = _get(z, wr.keys.control, pack({"cmd": "add", "args": _adds(specs)}))
    return inject


@pytest.mark.slow
def test_attack_control_add_naming_code_in_parameters(tmp_path, marker_module, undisturbed):
    """Control ``add`` of stigmergy and CBAA robots whose conflict rule and score name code: refused, counted."""
    name, marker = marker_module
    specs = _planted(name, marker)
    wr = WireRun(FLOOD_RAW, tmp_path / "run", inject=_add_planted(specs))
    result = wr.run()
    kind, data = wr.replies["add"]
    assert kind == "ok" and unpack(data)["ok"]
    _no_code_ran(name, marker)
    added = [rid for rid in result.robots if rid >= HONEST]
    assert len(added) == 2 * len(specs)
    for rid in added:
        failed = result.robots[rid]["failed"]
        assert failed["cause"] == "refused_behavior" and "chosen by name" in failed["error"], failed
    assert result["world"]["refused"] == {"refused_behavior": len(added)}
    assert _honest_deliveries(result) == _honest_deliveries(undisturbed)


def _find_control_and_add(specs: list[dict], replies: dict):
    """An outsider on the run's TCP port: finds the control queryable with a wildcard (no run id), adds, stops."""
    def on_open(world, link):
        def attack():
            z = zenoh.open(make_config(Endpoints(mode="peer", connect=[link.locators()[0]])))
            try:
                replies["add"] = _get(z, "swarmactors/*/control", pack({"cmd": "add", "args": _adds(specs)}))
                deadline = time.monotonic() + 30
                while time.monotonic() < deadline:
                    st_ = unpack(_get(z, "swarmactors/*/control", pack({"cmd": "status"}))[1])
                    if st_["robots"] == 2 + 2 * len(specs) and st_["alive"] == 2:
                        break
                    time.sleep(0.05)
                replies["stop"] = _get(z, "swarmactors/*/control", pack({"cmd": "stop"}))
            finally:
                z.close()
        threading.Thread(target=attack, daemon=True).start()
    return on_open


@pytest.mark.slow
@pytest.mark.parametrize("processes", [0, 2])
def test_attack_run_tcp_add_naming_code_in_parameters(tmp_path, marker_module, monkeypatch, processes):
    """``run --tcp`` with K = 0 and K = 2: the control queryable is open on loopback; the planted robots are refused."""
    name, marker = marker_module
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(marker.parent), os.environ.get("PYTHONPATH", "")]))
    specs = _planted(name, marker)
    raw = {"run": {"name": "tcp", "seed": 2, "ticks": 100_000, "watchdog_s": 5.0},
           "robots": [{"positions": [[0.0, 0.0], [0.5, 0.0]], "behaviors": [{"use": "beacon"}]}]}
    replies: dict = {}
    with private_endpoints(tcp=True) as endpoints:
        result = asyncio.run(run_world(resolve_scenario(raw, "<t>"), tmp_path / "run", endpoints,
                                       new_run_id("tcp"), processes=processes,
                                       on_open=_find_control_and_add(specs, replies)))
    assert replies["add"][0] == "ok" and unpack(replies["add"][1])["ok"]
    _no_code_ran(name, marker)
    added = [rid for rid in result.robots if rid >= 2]
    assert len(added) == 2 * len(specs)
    assert all(result.robots[rid]["failed"]["cause"] == "refused_behavior" for rid in added)


@pytest.mark.slow
def test_attack_rogue_join_reply_naming_code_to_a_host_without_the_run_secret(marker_module, monkeypatch):
    """A host started without the run secret takes a rogue's join reply on trust: its planted robots are refused."""
    name, marker = marker_module
    monkeypatch.delenv("SWARMACTORS_RUN_SECRET", raising=False)
    keys = Keys(new_run_id("rogue"))
    run = RunInfo("lockstep", 1.0, 0, 15, 2.0, 0)
    descrs = [RobotDescr(i, [0.2 * i, 0.0, 0.0], [spec], "ground", 1.0, 1.0, 1.0)
              for i, spec in enumerate(_planted(name, marker))]
    reply = encode(JoinReply("h0", bytes(32), PROTOCOL_VERSION, descrs, run))

    async def join() -> RobotHost:
        with Link(Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"])) as link:
            rogue = zenoh.open(make_config(Endpoints(mode="peer", connect=[link.locators()[0]])))
            try:
                rogue.declare_queryable(keys.join, lambda q: q.reply(q.key_expr, reply))
                host = RobotHost(link, keys)
                await host.join(timeout=10)
                return host
            finally:
                rogue.close()

    host = asyncio.run(join())
    assert sorted(host.robots) == [0, 1, 2, 3]
    for robot in host.robots.values():
        assert not robot.alive and robot.error.startswith("refused behaviour"), robot.error
    _no_code_ran(name, marker)


# ------------------------------------------------------------------ 2. velocities and positions
class Still(Behavior):
    """Does nothing: the undisturbed stand-in of an attacker."""

    def __init__(self, **params):
        pass


class Overflow(Behavior):
    """Commands a velocity the world cannot integrate, from tick 3 on."""

    def __init__(self, velocity=(1e308, 1e308)):
        self.velocity = list(velocity)

    def on_tick(self, ctx, sensed) -> None:
        if ctx.tick >= 3:
            ctx.move(self.velocity)


def _velocity_scenario(attacker: str) -> dict:
    line = {"positions": [[0.8 * i, 0.0] for i in range(6)], "behaviors": [{"use": "beacon"}]}
    attack = [{"positions": [[50.0, 50.0]], "behaviors": [{"use": f"test_attacks:{attacker}"}]},
              {"positions": [[60.0, 50.0]], "speed": 1.0, "behaviors": [{"use": f"test_attacks:{attacker}"}]},
              {"positions": [[70.0, 50.0]], "behaviors": [{"use": f"test_attacks:{attacker}", "velocity": [2e6]}]}]
    return {"run": {"name": "velocity", "seed": 3, "ticks": 12}, "radio": {"range": 1.0, "latency": 1},
            "robots": [line, *attack]}


@pytest.mark.slow
def test_attack_velocity_overflow_crashes_only_its_robot(run):
    """[1e308, 1e308] (with and without a speed cap) and 2e6 units/s: the robots crash, the run goes on."""
    clean = run(_velocity_scenario("Still"))
    result = run(_velocity_scenario("Overflow"))
    assert result.path.is_file() and result["ticks"] == 12
    for rid in (6, 7, 8):
        failed = result.robots[rid]["failed"]
        assert failed["cause"] == "invalid_velocity" and failed["tick"] == 3, failed
    assert "not finite" not in result.robots[6]["failed"]["error"]  # finite, but beyond the world's limit
    assert result["world"]["refused"] == {"invalid_velocity": 3}
    assert all(result.robots[r]["alive"] for r in range(6))
    assert all(math.isfinite(v) for r in result.robots.values() for v in r["pose"])
    honest = lambda res: [(rec["t"], rec.get("del", [])) for rec in res.trace]  # noqa: E731
    assert honest(result) == honest(clean)


def test_positions_beyond_the_limit_are_found():
    pos = np.array([[0.0, 0.0], [np.inf, 0.0], [np.nan, 1.0], [2e9, 0.0], [1e9, -1e9]])
    assert bad_positions(pos, np.array([True] * 5)).tolist() == [1, 2, 3]
    assert bad_positions(pos, np.array([True, False, True, True, True])).tolist() == [2, 3]
    assert velocity_problem([1e308, 1e308], 2) and velocity_problem([math.nan], 2)
    assert velocity_problem([1.0, 0.0, 0.0], 2) and velocity_problem([], 2)
    assert velocity_problem([MAX_SPEED, 0.0], 2) is None


# ------------------------------------------------------------------ 2b, 3. control specs and caps
BAD_ADDS = [
    {"pos": [1.0, 1.0], "range": "x"},
    {"pos": [1.0, 1.0], "sensing": -1.0},
    {"pos": [1.0, 1.0], "noise": float("nan")},
    {"pos": [1.0, 1.0], "heading": float("inf")},
    {"pos": [1.0, 1.0], "kind": "submarine"},
    {"pos": [1.0, 1.0], "behaviors": "beacon"},
    {"pos": [1.0, 1.0], "behaviors": [{"params": 1}]},
    {"pos": [1.0, 1.0], "colour": "red"},
    {"pos": [float("nan"), 1.0]},
    # values a scenario refuses, which an add once took (issue 42): the world crashed in cKDTree or overflowed
    {"pos": [1e200, 1.0]},
    {"pos": [1.0, 1.0], "range": 1e308},
    {"pos": [1.0, 1.0], "speed": 1e308},
    {"pos": [1.0, 1.0], "sensing": 1e308},
    {"pos": [1.0, 1.0], "body_radius": 1e308},
    {"pos": [1.0, 1.0], "clock_drift": 1e308},
    {"pos": [1.0, 1.0], "clock_offset": 1e308},
    {"pos": [1.0, 1.0], "obstacle_rays": 2**62},
    {"pos": [1.0, 1.0], "obstacle_rays": 10**12},
    {"pos": [1.0, 1.0], "altitude": [float("inf"), float("-inf")]},
]


def test_add_specs_are_validated_by_the_scenario_model():
    for spec in BAD_ADDS:
        assert action_problem({"add": [spec]}, dims=2), spec
    good = {"pos": [1.0, 1.0], "range": 1, "sensing": 2.0, "speed": 3.0, "turn_rate": 0.1, "noise": 0.0,
            "heading": 0.5, "kind": "flying", "behaviors": [{"use": "beacon", "as": "b"}]}
    assert action_problem({"add": [good]}, dims=2) is None
    assert "1 to" in action_problem({"add": [{"pos": [0.0, 0.0]}] * (MAX_PER_REQUEST + 1)}, dims=2)


CAPPED_RAW = {**FLOOD_RAW, "world": {**FLOOD_RAW["world"], "max_robots": 31}}


def _caps_and_bad_specs(wr, z, status):
    ctl = wr.keys.control
    for i, spec in enumerate(BAD_ADDS):
        wr.replies[f"bad{i}"] = _get(z, ctl, pack({"cmd": "add", "args": [spec]}))
    wr.replies["add-too-many"] = _get(z, ctl, pack({"cmd": "add", "args": [{"pos": [1.0, 1.0]}] * 5000}))
    wr.replies["add-over-total"] = _get(z, ctl, pack({"cmd": "add", "args": [{"pos": [1.0, 1.0]}] * 2}))
    wr.replies["join-3M"] = _get(z, wr.keys.join, pack({"count": 3_000_000}))
    wr.replies["join-over-total"] = _get(z, wr.keys.join, pack({"count": 2}))


@pytest.mark.slow
def test_attack_bad_add_specs_and_caps_are_refused_and_counted(tmp_path, undisturbed):
    wr = WireRun(CAPPED_RAW, tmp_path / "run", inject=_caps_and_bad_specs, expect_malformed=len(BAD_ADDS))
    result = wr.run()
    assert (tmp_path / "run" / "result.json").is_file() and result["ticks"] == FLOOD_RAW["run"]["ticks"]
    for i in range(len(BAD_ADDS)):
        kind, data = wr.replies[f"bad{i}"]
        assert kind == "ok" and not unpack(data)["ok"], (BAD_ADDS[i], data)
    assert not unpack(wr.replies["add-too-many"][1])["ok"] and not unpack(wr.replies["add-over-total"][1])["ok"]
    assert wr.replies["join-3M"][0] == "err" and wr.replies["join-over-total"][0] == "err"
    assert len(result.robots) == HONEST
    assert result["world"]["dropped"]["malformed"] == len(BAD_ADDS)
    assert result["world"]["refused"] == {"request_cap": 2, "robot_cap": 2}
    refused = [ev["refused"] for rec in result.trace for ev in rec.get("ev", []) if "refused" in ev]
    assert sorted(refused) == ["request_cap", "request_cap", "robot_cap", "robot_cap"]
    assert _honest_deliveries(result) == _honest_deliveries(undisturbed)


def _deep_control(wr, z, status):
    deep = b"\x82\xa3cmd\xa3add\xa4args" + b"\x91" * 200_000 + b"\xc0"
    wr.replies["deep"] = _get(z, wr.keys.control, deep)


@pytest.mark.slow
def test_attack_a_control_command_nested_200000_levels_deep_is_answered_and_counted(tmp_path, undisturbed):
    wr = WireRun(FLOOD_RAW, tmp_path / "run", inject=_deep_control, expect_malformed=1)
    result = wr.run()
    kind, data = wr.replies["deep"]
    assert kind == "ok" and unpack(data) == {"ok": False, "error": "bad control command: nested too deeply"}
    assert result["world"]["dropped"]["malformed"] == 1
    assert _honest_deliveries(result) == _honest_deliveries(undisturbed)


# ------------------------------------------------------------------ 6. bounded samples of a flood
FLOOD = 300


def _flood(wr, z, status):
    (host,) = status["hosts"]
    for i in range(FLOOD):
        z.put(wr.keys.up(host), b"\xc1garbage" + bytes([i % 256]))


@pytest.mark.slow
def test_attack_malformed_flood_is_counted_exactly_and_sampled(tmp_path, undisturbed):
    wr = WireRun(FLOOD_RAW, tmp_path / "run", inject=_flood, expect_malformed=FLOOD)
    result = wr.run()
    assert (tmp_path / "run" / "result.json").is_file()
    assert result["world"]["dropped"]["malformed"] == FLOOD
    stored = [m for rec in result.trace for m in rec.get("mal", [])]
    more = [int(m.rsplit(" ", 1)[1]) for m in stored if m.startswith(MORE_MALFORMED)]
    assert all(len(rec.get("mal", [])) <= SAMPLES_PER_TICK + 1 for rec in result.trace)
    assert len(stored) - len(more) + sum(more) == FLOOD
    assert _honest_deliveries(result) == _honest_deliveries(undisturbed)


# ------------------------------------------------------------------ 4. joins during a run, stale and future steps
JOINERS = 25
TICKS = 150
JOINED_BY = TICKS // 2  # the world pauses here if a joiner has not joined yet (here they join by tick 30-60)


def _join_storm(wr, z, status):
    """Resume, then start many robot hosts in a tight loop; each joins while the world ticks.

    So that no join races the run's end on a slow machine (a host that joins after the world closed retries
    for a minute and never runs), the world runs only to ``JOINED_BY`` until every joiner has joined.
    """
    _get(z, wr.keys.control, pack({"cmd": "run_to", "tick": JOINED_BY}))
    endpoint = wr.hosts[0].endpoint
    for _ in range(JOINERS):
        wr.hosts.append(_HostThread(endpoint, wr.run_id, 1))
    joined = wr._wait(z, lambda s: len(s["hosts"]) == 1 + JOINERS, timeout=60.0)
    wr.notes["paused_for_joins"] = joined["paused"]
    assert len(joined["hosts"]) == 1 + JOINERS, f"only {len(joined['hosts'])} hosts joined in 60 s: {joined}"
    _get(z, wr.keys.control, pack({"cmd": "resume"}))


def _joins_at_the_barrier(wr, z, status):
    """While the world waits between two ticks (all steps in), many joins in a tight loop; none registers.

    The first joiner then sends stale and future steps, never the awaited one.
    """
    replies = [_get(z, wr.keys.join, encode(JoinRequest(1))) for _ in range(JOINERS)]
    wr.notes["joined"] = joined = [decode(d, JoinReply, what="join reply") for kind, d in replies if kind == "ok"]
    rogue = joined[0]
    for t in (0, PAUSE_AT - 2, 10**6):
        wr.replies[f"step{t}"] = _get(z, wr.keys.up(rogue.host), seal(rogue.key, encode(Uplink(rogue.host, t))))


@pytest.mark.slow
def test_hosts_joining_in_a_tight_loop_while_the_world_ticks(tmp_path):
    """Robot hosts start in a tight loop and join while the world ticks; each runs to the end."""
    raw = {**FLOOD_RAW, "run": {**FLOOD_RAW["run"], "ticks": TICKS}}
    clean = WireRun(raw, tmp_path / "clean").run()
    wr = WireRun(raw, tmp_path / "run", inject=_join_storm)
    result = wr.run()
    assert (tmp_path / "run" / "result.json").is_file() and result["ticks"] == TICKS
    stuck = [(i, h.ran_to_end, repr(h.error)) for i, h in enumerate(wr.hosts) if not h.ran_to_end or h.error]
    assert wr.hosts_ended_by_themselves and not stuck, f"hosts that did not run to their end: {stuck}"
    joined_at = sorted(r["joined_at"] for r in result.robots.values() if r["joined_at"] > 0)
    assert len(joined_at) == JOINERS and joined_at[-1] <= JOINED_BY  # all joined during the run
    assert len(result.robots) == HONEST + JOINERS and result["world"]["dropped"]["malformed"] == 0
    assert all(r["alive"] for r in result.robots.values())
    assert _honest_deliveries(result) == _honest_deliveries(clean)


@pytest.mark.slow
def test_attack_joins_at_the_barrier_stale_steps_and_silence(tmp_path, undisturbed):
    """Joins that land between two ticks (the held-step race), stale and future steps, hosts that never register.

    The barrier never waits for a host that has not registered, so the run does not stall; the stale and future
    steps are counted as malformed; the joiners' robots, which never ran, crash as ``unregistered`` when the run
    ends (or ``register_within_s`` after their join); the honest robots do not notice.
    """
    wr = WireRun(FLOOD_RAW, tmp_path / "run", inject=_joins_at_the_barrier, expect_malformed=3)
    result = wr.run()
    assert (tmp_path / "run" / "result.json").is_file() and result["ticks"] == FLOOD_RAW["run"]["ticks"]
    joined = wr.notes["joined"]
    assert len(joined) == JOINERS and len(result.robots) == HONEST + JOINERS
    assert all(wr.replies[k][0] == "err" for k in wr.replies if k.startswith("step"))
    assert result["world"]["dropped"]["malformed"] == 3
    mal = [m for rec in result.trace for m in rec.get("mal", [])]
    assert sum("stale step" in m for m in mal) == 2 and sum("future step" in m for m in mal) == 1
    assert {result.robots[rid]["host"] for rid in range(HONEST, HONEST + JOINERS)} == {j.host for j in joined}
    assert result["world"]["refused"] == {"unregistered": JOINERS}
    assert all(result.robots[rid]["failed"]["cause"] == "unregistered" for rid in range(HONEST, HONEST + JOINERS))
    # no tick waited for them: the run after the pause took far less than one host-loss bound (2 * 0.5 + 5 s)
    assert result["wall_s"] < host_loss_s(FLOOD_RAW["run"]["watchdog_s"]), result["wall_s"]
    assert _honest_deliveries(result) == _honest_deliveries(undisturbed)


# joiners are placed at random in the bounds: wide bounds keep 8,000 of them sparse (their physics is not the point)
NEVER_REGISTERS_RAW = {**FLOOD_RAW, "run": {**FLOOD_RAW["run"], "ticks": 60, "watchdog_s": 10.0},
                       "world": {"bounds": [[0.0, 0.0], [400.0, 400.0]]},
                       "robots": [{**FLOOD_RAW["robots"][0], "area": [[0.0, 0.0], [4.0, 4.0]]}]}


def _join_storm_never_registering(wr, z, status):
    """Resume, then 8 joins of 1000 robots and single joins every few ticks while the world runs; none registers."""
    _get(z, wr.keys.control, pack({"cmd": "resume"}))
    wr.notes["big"] = [_get(z, wr.keys.join, encode(JoinRequest(1000))) for _ in range(8)]
    wr.notes["small"] = []
    for _ in range(10):
        wr.notes["small"].append(_get(z, wr.keys.join, encode(JoinRequest(1))))
        time.sleep(0.02)


@pytest.mark.slow
def test_attack_joins_that_never_register_do_not_stall_a_lockstep_run(tmp_path):
    """Joins whose hosts never register (one every few ticks, and 8 of 1000 robots): the run goes on at once.

    Before, each such join stalled the barrier 2 * watchdog_s + 5 s (25 s here), so the run never finished.
    """
    wr = WireRun(NEVER_REGISTERS_RAW, tmp_path / "run", inject=_join_storm_never_registering)
    t0 = time.monotonic()
    result = wr.run()
    assert result["ticks"] == NEVER_REGISTERS_RAW["run"]["ticks"] and (tmp_path / "run" / "result.json").is_file()
    assert time.monotonic() - t0 < host_loss_s(10.0), "a join that never registers stalled the run"
    extra = range(HONEST, len(result.robots))
    assert len(extra) >= 8000  # (a small join's reply may time out on a busy machine after the world added it)
    hosts = {result.robots[rid]["host"] for rid in extra}
    assert result["world"]["refused"] == {"unregistered": len(hosts)}
    assert all(result.robots[rid]["failed"]["cause"] == "unregistered" for rid in extra)
    assert all(result.robots[rid]["alive"] for rid in range(HONEST))


# ------------------------------------------------------------------ 5. empty joins
def test_empty_join_is_refused_and_the_error_names_the_claimers():
    sc = resolve_typed({"run": {"name": "j", "ticks": 2, "join_timeout_s": 0.2},
                           "robots": [{"count": 3, "behaviors": [{"use": "beacon"}]}]}, "<t>")
    link = FakeLink()
    w = WorldSession(sc, link, Keys("j"))
    w.open()
    empty = link.query(w.keys.join, b"")
    assert empty.replies[0][0] == "err" and "empty join request" in empty.replies[0][1]
    assert w.status()["dropped"]["malformed"] == 1 and w.status()["unclaimed"] == 3
    ok = link.query(w.keys.join, encode(JoinRequest(2)))
    assert ok.replies[0][0] == "ok"
    with pytest.raises(RuntimeError, match=r"1 robot\(s\) were not claimed.*h0 \(2\).*never registered: h0"):
        asyncio.run(w.run())


# ------------------------------------------------------------------ 7. downlink authentication
def _beacons_raw(clock: str = "lockstep") -> dict:
    run = {"name": "auth", "seed": 5, "clock": clock, "ticks": 15, "dt": 0.05, "watchdog_s": 2.0, "join_timeout_s": 20}
    return {"run": run, "radio": {"range": 1.0, "latency": 1, "latency_s": 0.02},
            "robots": [{"positions": [[0.6 * i, 0.0] for i in range(6)], "behaviors": [{"use": "beacon"}]}]}


def _run_world(raw: dict, out, on_open=None):
    sc = resolve_scenario(raw, "<attack>")
    endpoints = Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"])
    return asyncio.run(run_world(sc, out, endpoints, new_run_id("auth"), processes=0, on_open=on_open))


def _forged_inputs(marker) -> Inputs:
    evil = RobotDescr(99, [0.0, 0.0, 0.0], [{"use": "os:system", "command": f"touch {marker}"}], "ground",
                      1.0, 1.0, 1.0)
    return Inputs(tick=2, new=[evil])


class _Rogue:
    """A local user's Zenoh session: answers ``world/join`` and every step query first, and publishes downlinks."""

    def __init__(self, endpoint: str, keys: Keys, marker):
        self.z = zenoh.open(make_config(Endpoints(mode="peer", connect=[endpoint])))
        self.keys, self.answered = keys, 0
        run = RunInfo("lockstep", 1.0, 0, 15, 2.0, 0)
        fake = JoinReply("h0", bytes(32), 2, [RobotDescr(0, [9.0, 9.0, 0.0], [{"use": "beacon"}], "ground",
                                                         1.0, 1.0, 1.0)], run)
        self.join_reply, self.down = encode(fake), encode(_forged_inputs(marker))
        self.q1 = self.z.declare_queryable(keys.join, self._answer(self.join_reply))
        self.q2 = self.z.declare_queryable(keys.up_all, self._answer(seal(bytes(32), self.down)))
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._publish, daemon=True)
        self.thread.start()

    def _answer(self, payload: bytes):
        def on_query(query) -> None:
            self.answered += 1
            query.reply(query.key_expr, payload)
        return on_query

    def _publish(self) -> None:
        while not self.stop.wait(0.01):
            self.z.put(self.keys.down("h0"), self.down)

    def close(self) -> None:
        self.stop.set()
        self.thread.join(5)
        self.z.close()


@pytest.mark.slow
@pytest.mark.parametrize("clock", ["lockstep", "realtime"])
def test_attack_rogue_join_reply_step_replies_and_downlinks_are_dropped(tmp_path, clock):
    """A rogue answers the join and every step first and publishes forged downlinks: the host uses none of it."""
    marker = tmp_path / "pwned"
    rogues = []

    def on_open(world, link):
        rogues.append(_Rogue(link.locators()[0], world.keys, marker))

    clean = _run_world(_beacons_raw(clock), tmp_path / "clean")
    try:
        result = _run_world(_beacons_raw(clock), tmp_path / "run", on_open=on_open)
    finally:
        for r in rogues:
            r.close()
    assert not marker.exists() and (tmp_path / "run" / "result.json").is_file()
    assert rogues[0].answered >= 1
    assert len(result.robots) == 6 and all(r["alive"] for r in result.robots.values())
    bad = result.robots[0].get("_bad_downlinks", 0)
    assert bad >= 1  # counted by the host, reported with its robots
    if clock == "lockstep":
        assert [rec.get("del") for rec in result.trace] == [rec.get("del") for rec in clean.trace]


@pytest.mark.slow
def test_a_host_whose_world_goes_silent_stops_within_the_host_loss_bound(monkeypatch):
    """A rogue answers the join and the registration, keeps a world liveliness token, and says nothing more."""
    monkeypatch.delenv("SWARMACTORS_RUN_SECRET", raising=False)
    keys = Keys(new_run_id("silent"))
    watchdog_s = 0.5
    run = RunInfo("lockstep", 1.0, 0, 15, watchdog_s, 0)
    key = bytes(32)
    join = encode(JoinReply("h0", key, PROTOCOL_VERSION, [RobotDescr(0, [0.0, 0.0, 0.0], [{"use": "beacon"}],
                                                                        "ground", 1.0, 1.0, 1.0)], run))
    ack = seal(key, encode(Ack(0.0)))

    async def serve() -> tuple[BaseException | None, float]:
        with Link(Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"])) as link:
            rogue = zenoh.open(make_config(Endpoints(mode="peer", connect=[link.locators()[0]])))
            try:
                rogue.declare_queryable(keys.join, lambda q: q.reply(q.key_expr, join))
                rogue.declare_queryable(keys.up("h0"), lambda q: q.reply(q.key_expr, ack))
                rogue.liveliness().declare_token(keys.world_alive)
                host = RobotHost(link, keys)
                await host.join(timeout=10)
                t0 = time.monotonic()
                try:
                    await asyncio.wait_for(host.run(), 60)
                except Exception as exc:
                    return exc, time.monotonic() - t0
                return None, time.monotonic() - t0
            finally:
                rogue.close()

    error, took = asyncio.run(serve())
    assert isinstance(error, WorldLost) and "sent nothing for" in str(error), error
    assert host_loss_s(watchdog_s) <= took < host_loss_s(watchdog_s) + 5


@pytest.mark.slow
def test_a_host_facing_only_rogue_join_replies_gives_up_within_its_wait_and_names_the_run(caplog):
    """With the run secret, a host drops every rogue join reply, logs a few of them naming the run, and gives up."""
    keys = Keys(new_run_id("rogue"))

    async def join() -> tuple[BaseException | None, float]:
        with Link(Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"])) as link:
            rogue = zenoh.open(make_config(Endpoints(mode="peer", connect=[link.locators()[0]])))
            try:
                rogue.declare_queryable(keys.join, lambda q: q.reply(q.key_expr, b"rogue"))
                host = RobotHost(link, keys, run_secret=bytes(range(32)))
                t0 = time.monotonic()
                try:
                    await host.join(timeout=3.0)
                except RuntimeError as exc:
                    return exc, time.monotonic() - t0
                return None, time.monotonic() - t0
            finally:
                rogue.close()

    with caplog.at_level("WARNING", logger="swarmactors"):
        error, took = asyncio.run(join())
    assert error is not None and "none authentic" in str(error) and took < 3.0 + 6.0
    dropped = [r.getMessage() for r in caplog.records if "fails authentication" in r.getMessage()]
    assert dropped and all(f"joining run {keys.run_id!r}" in m for m in dropped), dropped
    assert len(dropped) <= 8  # the 1st, 2nd, 4th, ... of them, not one line per reply


def _long_pause(wr, z, status):
    time.sleep(host_loss_s(FLOOD_RAW["run"]["watchdog_s"]) + 2)  # the world stays paused all along


@pytest.mark.slow
def test_hosts_stay_through_a_lockstep_pause_longer_than_the_host_loss_bound(tmp_path, undisturbed):
    """A paused world acks its hosts every watchdog_s: they do not take the pause for the world's silence."""
    wr = WireRun(FLOOD_RAW, tmp_path / "run", inject=_long_pause)
    result = wr.run()
    assert wr.hosts_ended_by_themselves and not any(h.error for h in wr.hosts)
    assert all(r["alive"] for r in result.robots.values())
    assert _honest_deliveries(result) == _honest_deliveries(undisturbed)


# ------------------------------------------------------------------ 8. run on a private Unix socket
def test_run_listens_on_a_unix_socket_in_a_private_directory():
    with private_endpoints() as endpoints:
        (where,) = endpoints.listen
        assert where.startswith("unixsock-stream/")
        folder = Path(where.removeprefix("unixsock-stream/")).parent
        assert folder.is_dir() and stat.S_IMODE(folder.stat().st_mode) == 0o700
    assert not folder.exists()
    with private_endpoints(tcp=True) as endpoints:
        assert endpoints.listen == ["tcp/127.0.0.1:0"]


@pytest.mark.slow
def test_run_with_host_processes_over_the_unix_socket(tmp_path):
    """``run --processes 2`` (the default transport): the spawned hosts reach the world through the socket."""
    raw = _beacons_raw()
    result = launcher_run(raw, out=tmp_path / "unix", processes=2)
    tcp = launcher_run(raw, out=tmp_path / "tcp", processes=2, tcp=True)
    assert {r["host"] for r in result.robots.values()} == {"h0", "h1"}
    assert result["trace_hash"] == tcp["trace_hash"]
    assert all(r["beacon"]["heard"] > 0 for r in result.robots.values())


# ------------------------------------------------------------------ 9. the viewer's HTTP API
def write_small_trace(path: Path, records: list[dict] | None = None, compress: bool = False) -> Path:
    """A valid trace by hand: header, ``records`` (default: three ticks of two robots) and a footer with the hash."""
    records = records if records is not None else [{"t": t, "pos": [[0, 0.0, 0.0], [1, 1.0, float(t)]]}
                                                   for t in range(3)]
    hasher = TraceHasher()
    for rec in records:
        hasher.update(rec)
    objs = [{"trace": "swarmactors", "version": 2, "run_id": "x", "clock": "lockstep", "seed": 1, "scenario": {}},
            *records, {"end": True, "ticks": len(records), "trace_hash": hasher.hexdigest()}]
    data = b"".join(pack(o) for o in objs)
    if compress:
        import zstandard

        data = zstandard.ZstdCompressor().compress(data)
    path.write_bytes(data)
    return path


class _Recorder(Source):
    """A viewer source that obeys every command and remembers it: what an attacker's request reached."""

    def __init__(self):
        self.scene = Scene(mode="live")
        self.obeyed: list[dict] = []

    async def command(self, msg: dict) -> dict:
        self.obeyed.append(msg)
        return {"ok": True}


async def _http(port: int, method: str, path: str, headers: dict, body: bytes = b"") -> tuple[int, str]:
    """One raw HTTP/1.1 request, as another local process would send it (no browser, headers as given)."""
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    lines = [f"{method} {path} HTTP/1.1", *(f"{k}: {v}" for k, v in headers.items()),
             f"Content-Length: {len(body)}", "Connection: close", "", ""]
    writer.write("\r\n".join(lines).encode() + body)
    await writer.drain()
    answer = (await asyncio.wait_for(reader.read(), 10)).decode()
    writer.close()
    status = int(answer.split(" ", 2)[1])
    return status, answer.split("\r\n\r\n", 1)[1]


async def test_viewer_commands_need_the_token_and_a_local_host_name():
    """Another local process (no Origin) and a DNS-rebound page (Host: evil.example) cannot command the viewer."""
    source = _Recorder()
    server = ViewerServer("127.0.0.1", 0, source)
    url = await server.start()
    port = int(server.base.rsplit(":", 1)[1].rstrip("/"))
    assert url == f"{server.base}?token={server.token}" and len(server.token) >= 32
    here = {"Host": f"127.0.0.1:{port}", "Content-Type": "application/json"}
    stop = json.dumps({"cmd": "stop", "args": True}).encode()
    try:
        for cmd in ({"cmd": "stop", "args": True}, {"cmd": "loss", "args": 0.9}, {"cmd": "kill", "id": 1}):
            status, body = await _http(port, "POST", "/api/command", here, json.dumps(cmd).encode())
            assert status == 403 and "token" in body
        wrong = server.token[:-1] + ("A" if server.token[-1] != "A" else "B")  # same length, one character off
        status, _ = await _http(port, "POST", "/api/command", {**here, "X-Swarmactors-Token": wrong}, stop)
        assert status == 403
        status, _ = await _http(port, "POST", f"/api/command?token={wrong}", here, stop)
        assert status == 403
        # DNS rebinding: the browser sends the attacker's name as Host and as Origin, and cannot know the token
        evil = {"Host": f"evil.example:{port}", "Origin": f"http://evil.example:{port}",
                "Content-Type": "application/json"}
        status, body = await _http(port, "POST", "/api/command", evil, stop)
        assert status == 403 and "evil.example" in body
        status, _ = await _http(port, "POST", "/api/command", {**evil, "X-Swarmactors-Token": server.token}, stop)
        assert status == 403  # even with the token: the Host is checked first
        status, _ = await _http(port, "GET", "/api/frame", {**evil, "X-Swarmactors-Token": server.token})
        assert status == 403  # and reading the run is refused too
        # read-only data needs the token as well; the page itself (no run data) does not
        for path in ("/api/frame", "/api/space", "/api/robot/0", "/api/events.toml", "/ws"):
            assert (await _http(port, "GET", path, here))[0] == 403, path
        assert (await _http(port, "GET", "/", here))[0] == 200
        assert (await _http(port, "GET", "/static/viewer.js", {"Host": f"localhost:{port}"}))[0] == 200
        assert source.obeyed == []
        # the owner, with the printed token (header, or ?token= as the page's WebSocket sends it)
        status, body = await _http(port, "POST", "/api/command", {**here, "X-Swarmactors-Token": server.token},
                                   stop)
        assert status == 200 and json.loads(body) == {"ok": True}
        status, _ = await _http(port, "GET", f"/api/frame?token={server.token}", {"Host": f"[::1]:{port}"})
        assert status == 200
        assert source.obeyed == [{"cmd": "stop", "args": True}]
    finally:
        await server.close()


@pytest.mark.parametrize("header", ["evil.example", "localhost.evil.example:80", "127.0.0.1:x", "[::1", "", "::1"])
def test_viewer_host_allowlist_refuses_other_names(header):
    server = ViewerServer("127.0.0.1", 0)
    assert not server.host_allowed(header)


@pytest.mark.parametrize("header", ["127.0.0.1:8050", "localhost:9000", "[::1]:8050", "LOCALHOST", "10.0.0.5:8050"])
def test_viewer_host_allowlist_admits_this_machine(header):
    server = ViewerServer("127.0.0.1", 0)
    assert server.host_allowed(header)


def test_replay_viewer_prints_its_token_and_refuses_commands_without_it(tmp_path):
    """``swarmactors replay TRACE --view`` in its own process: the address it prints carries the token."""
    trace = tmp_path / "trace.msgpack"
    write_small_trace(trace)
    log = tmp_path / "view.log"
    proc = subprocess.Popen([sys.executable, "-m", "swarmactors", "replay", str(trace), "--port", "0"],
                            stdout=subprocess.DEVNULL, stderr=open(log, "w"))
    try:
        deadline = time.monotonic() + 30
        while not (m := re.search(r"viewer: (http://127\.0\.0\.1:(\d+)/)\?token=([\w-]+)", log.read_text())):
            assert proc.poll() is None and time.monotonic() < deadline, log.read_text()
            time.sleep(0.05)
        base, port, token = m.group(1), int(m.group(2)), m.group(3)
        seek = json.dumps({"cmd": "seek", "t": 1}).encode()
        here = {"Host": f"127.0.0.1:{port}", "Content-Type": "application/json"}
        status, _ = asyncio.run(_http(port, "POST", "/api/command", here, seek))
        assert status == 403
        status, body = asyncio.run(_http(port, "POST", "/api/command", {**here, "X-Swarmactors-Token": token}, seek))
        assert status == 200 and json.loads(body) == {"ok": True, "t": 1}, base
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=30)


# ------------------------------------------------------------------ 10. trace bombs
_PEAK_RSS = """import resource, subprocess, sys, time
start = time.monotonic()
p = subprocess.run(sys.argv[1:], capture_output=True, text=True, timeout=120)
print(p.returncode, time.monotonic() - start, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024)
print(p.stderr, end="")
"""


def _measured(args: list[str], cwd: Path) -> tuple[int, float, int, str]:
    """Run ``swarmactors ARGS`` under a fresh parent: (exit code, seconds, peak resident bytes, stderr)."""
    out = subprocess.run([sys.executable, "-c", _PEAK_RSS, sys.executable, "-m", "swarmactors", *args],
                         capture_output=True, text=True, timeout=180, cwd=cwd).stdout
    first, _, stderr = out.partition("\n")
    code, seconds, rss = first.split()
    return int(code), float(seconds), int(rss), stderr


@functools.cache
def _zero_frame(n: int) -> bytes:
    import zstandard

    return zstandard.ZstdCompressor(level=19).compress(bytes(n))


def _zstd_frames(data_before: bytes, zeros: int) -> bytes:
    """``data_before`` then ``zeros`` NUL bytes, as concatenated zstd frames (64 MiB of zeros is ~2 kB)."""
    import zstandard

    whole, rest = divmod(zeros, 64 << 20)
    return (zstandard.ZstdCompressor().compress(data_before) + _zero_frame(64 << 20) * whole
            + (_zero_frame(rest) if rest else b""))


@pytest.fixture(scope="module")
def trace_bomb(tmp_path_factory) -> Path:
    """A ~100 kB zstd trace: a header, then three tick records of 1 GiB each (a status string of NUL bytes)."""
    path = tmp_path_factory.mktemp("bomb") / "trace.msgpack"
    head = pack({"trace": "swarmactors", "version": 2, "run_id": "x", "clock": "lockstep", "seed": 1,
                 "scenario": {}})
    parts = [b""]
    for t in range(3):
        prefix = pack({"t": t, "status": {0: {"s": "x"}}})[:-2]  # the map up to the string's value
        parts.append(_zstd_frames((head if t == 0 else b"") + prefix + b"\xdb" + (1 << 30).to_bytes(4, "big"),
                                  1 << 30))
    path.write_bytes(b"".join(parts))
    assert path.stat().st_size < 200_000
    return path


@pytest.mark.parametrize("command", ["events", "view", "export"])
def test_trace_bomb_is_refused_in_seconds_without_the_memory(trace_bomb, tmp_path, command):
    """``replay --events``, ``replay`` (the viewer) and ``export`` on 3 GiB in 100 kB: exit 2, the bound named."""
    args = {"events": ["replay", str(trace_bomb), "--events"], "view": ["replay", str(trace_bomb), "--port", "0"],
            "export": ["export", str(trace_bomb), "--out", str(tmp_path)]}[command]
    code, seconds, rss, stderr = _measured(args, tmp_path)
    assert code == 2, stderr
    assert str(trace_bomb) in stderr and "32 MiB, the bound on one record" in stderr, stderr
    assert len(stderr.strip().splitlines()) == 1, stderr
    assert seconds < 20, seconds
    assert rss < 400 << 20, rss / 2**20  # the bomb's records are never built
    assert not list(tmp_path.glob("*.csv"))


def test_trace_record_of_tiny_containers_is_refused_by_count(tmp_path):
    """30 MiB of empty maps fits the byte bound but would take ~2.4 GB as dicts: refused by the container bound."""
    from swarmactors.oracle.trace import MAX_RECORD_CONTAINERS, TraceError, iter_trace

    n = 30 << 20
    head = pack({"trace": "swarmactors", "version": 2, "run_id": "x", "clock": "lockstep", "seed": 1})
    rec = pack({"t": 0, "status": {0: {"s": "x"}}})[:-2] + b"\xdd" + n.to_bytes(4, "big") + b"\x80" * n
    path = tmp_path / "trace.msgpack"
    path.write_bytes(head + rec)
    started = time.monotonic()
    with pytest.raises(TraceError, match=f"{path}: the record at byte offset {len(head)} holds more than "
                                         f"{MAX_RECORD_CONTAINERS:,} lists and maps"):
        list(iter_trace(path))
    assert time.monotonic() - started < 10


def test_zstd_trace_beyond_the_decompression_ratio_is_refused(tmp_path):
    """Valid 8 MiB records, each ~300 bytes compressed: refused once the stream passes the ratio bound."""
    from swarmactors.oracle.trace import MAX_RATIO, RATIO_FLOOR, TraceError, iter_trace
    from swarmactors.tools.replay import Replay

    head = pack({"trace": "swarmactors", "version": 2, "run_id": "x", "clock": "lockstep", "seed": 1})
    frames = []
    for t in range(40):
        prefix = pack({"t": t, "status": {0: {"s": "x"}}})[:-2] + b"\xdb" + (8 << 20).to_bytes(4, "big")
        frames.append(_zstd_frames((head if t == 0 else b"") + prefix, 8 << 20))
    path = tmp_path / "trace.msgpack"
    path.write_bytes(b"".join(frames))
    assert (RATIO_FLOOR + MAX_RATIO * path.stat().st_size) < 40 * (8 << 20)  # the stream is beyond the bound
    started = time.monotonic()
    with pytest.raises(TraceError, match=f"{path}: decompresses to more than {MAX_RATIO} times its size"):
        list(iter_trace(path))
    with pytest.raises(TraceError, match="decompression bomb"):
        Replay(path)
    assert time.monotonic() - started < 20


@pytest.mark.parametrize("special", ["/dev/zero", "fifo"])
def test_trace_that_is_not_a_regular_file_is_refused(tmp_path, special):
    from swarmactors.oracle.trace import TraceError, iter_trace
    from swarmactors.tools.replay import Replay

    path = Path(special)
    if special == "fifo":
        path = tmp_path / "trace.msgpack"
        os.mkfifo(path)  # opening it for reading would wait for a writer
    for read in (lambda: list(iter_trace(path)), lambda: Replay(path)):
        with pytest.raises(TraceError, match=f"{path}: not a regular file"):
            read()


def test_a_real_zstd_trace_still_replays(tmp_path):
    """The bounds leave ordinary traces alone: a compressed trace replays, its copy written while it is checked."""
    from swarmactors.tools.replay import Replay

    path = write_small_trace(tmp_path / "trace.msgpack", compress=True)
    replay = Replay(path)
    assert replay.first == 0 and replay.last == 2 and replay.note is None
    assert replay.scene_at(1).t == 1
    replay.records.close()


# ------------------------------------------------------------------ 11. map bombs
_MAP_SCENARIO = """[run]
name = "map-bomb"
ticks = 3

[world]
map = {map}

[[robots]]
count = 2
placement = "line"
behaviors = [{{ use = "beacon" }}]
"""


def _map_scenario(folder: Path, map_value: str) -> Path:
    path = folder / "scenario.toml"
    path.write_text(_MAP_SCENARIO.format(map=map_value))
    return path


def _bad_run(args: list[str], capsys) -> tuple[int, str, float]:
    from swarmactors.cli import main

    started = time.monotonic()
    code = main(args)
    return code, capsys.readouterr().err, time.monotonic() - started


@pytest.mark.parametrize("case", ["dev-zero", "fifo", "huge-maze", "huge-file-header", "too-many-bytes",
                                  "map-symlink-loop"])
def test_map_bomb_is_refused_in_seconds_naming_file_and_key(tmp_path, capsys, case):
    """``run`` with a map that never ends, waits forever, or would not fit in memory: exit 2 within seconds."""
    from swarmactors.runs.maps import MAX_MAP_BYTES, MAX_MAP_CELLS

    key, value, names = "world.map.file", None, None
    if case == "dev-zero":
        value, names = '"/dev/zero"', ["/dev/zero", "not a regular file"]
    elif case == "fifo":
        os.mkfifo(tmp_path / "fifo.map")
        value, names = '"fifo.map"', ["fifo.map", "not a regular file"]
    elif case == "huge-maze":
        key, value = "world.map.maze", "{ maze = { cols = 100000, rows = 100000 } }"
        names = ["300001 x 300001", f"{MAX_MAP_CELLS:,}"]
    elif case == "huge-file-header":
        (tmp_path / "big.map").write_text("type octile\nheight 100000\nwidth 100000\nmap\n........\n")
        value, names = '"big.map"', ["big.map", "100000 x 100000", f"{MAX_MAP_CELLS:,}"]
    elif case == "too-many-bytes":
        with open(tmp_path / "long.map", "wb") as f:  # sparse: 17 MiB on paper, nothing on disk
            f.truncate(MAX_MAP_BYTES + (1 << 20))
        value, names = '"long.map"', ["long.map", f"{MAX_MAP_BYTES >> 20} MiB"]
    else:
        (tmp_path / "a.map").symlink_to(tmp_path / "b.map")
        (tmp_path / "b.map").symlink_to(tmp_path / "a.map")
        value, names = '"a.map"', ["a.map", "Too many levels of symbolic links"]
    scenario = _map_scenario(tmp_path, value)
    code, err, seconds = _bad_run(["run", str(scenario), "--out", str(tmp_path / "out"), "--quiet"], capsys)
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1, err
    assert f"{scenario}: {key}:" in err and all(n in err for n in names), err
    assert seconds < 10, seconds
    assert not (tmp_path / "out").exists()


def test_scenario_that_is_a_symlink_loop_is_refused_naming_it(tmp_path, capsys):
    (tmp_path / "a.toml").symlink_to(tmp_path / "b.toml")
    (tmp_path / "b.toml").symlink_to(tmp_path / "a.toml")
    code, err, _ = _bad_run(["run", str(tmp_path / "a.toml"), "--quiet"], capsys)
    assert code == 2, err
    assert err.startswith(f"error: {tmp_path / 'a.toml'}:") and "symbolic links" in err, err
    assert "RuntimeError" not in err


def test_map_limits_are_checked_before_reading_or_allocating():
    """Pure rules of swarmactors/runs/maps.py: cells before rows, and a maze's grid before it is built."""
    from swarmactors.runs.maps import MAX_MAP_CELLS, MapError, maze, parse_map

    side = int(MAX_MAP_CELLS ** 0.5)
    with pytest.raises(MapError, match="x 3 layers"):
        parse_map(["type octile3d", f"height {side}", f"width {side}", "layers 3"], "m")
    with pytest.raises(MapError, match=f"above the {MAX_MAP_CELLS:,}"):
        maze(10**6, 10**6)
    started = time.monotonic()
    with pytest.raises(MapError, match="unknown map character"):  # rows are checked a row at a time, not per cell
        parse_map(["type octile", "height 1000", "width 2000", "map", *(["." * 2000] * 999), "." * 1999 + "?"])
    assert time.monotonic() - started < 5
    rows = maze(20, 10, seed=1)
    assert len(rows) == 10 * 3 + 1 and len(rows[0]) == 20 * 3 + 1  # below the bound: as before


# ------------------------------------------------------------------ 12. swarmactors schedule
_TASKS_HEAD = '[arena]\nx = [0.0, 100.0]\ny = [0.0, 100.0]\n[swarm]\nstart = [1.0, 1.0]\n[[robots]]\ncount = {count}\n'


def _tasks_file(folder: Path, count: int = 20, chain: int = 1) -> Path:
    """A TASKS.toml: ``count`` robots and ``chain`` tasks, each after the one before (a priority chain)."""
    text = _TASKS_HEAD.format(count=count)
    for i in range(chain):
        text += (f'[[tasks]]\nid = "t{i}"\nposition = [{1 + (i * 7) % 98}.0, {1 + (i * 13) % 98}.0]\n'
                 + (f'after = ["t{i - 1}"]\n' if i else ""))
    path = folder / f"tasks-{count}-{chain}.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(("count", "chain", "key", "bound"), [
    (300_000_000, 1, "robots[0].count = 300000000",
     "brings the swarm to 300,000,000 robots, more than the 1000 a schedule may have"),
    (10**12, 1, "robots[0].count = 1000000000000",
     "brings the swarm to 1,000,000,000,000 robots, more than the 1000 a schedule may have"),
    (20, 3000, "tasks", "3,000 tasks, more than the 100 a schedule may have"),
], ids=["count-3e8", "count-1e12", "3000-chained-tasks"])
def test_schedule_instance_beyond_the_bounds_is_refused_before_the_model(tmp_path, capsys, count, chain, key, bound):
    """The campaign's instances (23 GB, 8.6 GB, MemoryError): exit 2 at once, naming the key and the bound."""
    path = _tasks_file(tmp_path, count, chain)
    code, err, seconds = _bad_run(["schedule", str(path), "--time-limit", "20", "--out", str(tmp_path / "o")], capsys)
    assert code == 2, err
    assert err == f"error: {path}: {key}: {bound}\n", err
    assert seconds < 5 and not (tmp_path / "o").exists()


def test_schedule_model_too_large_for_its_tasks_and_slots_is_refused():
    from protocols.tsc.schedule import MAX_VARIABLES, Instance, InstanceError, Task, check_instance

    caps = [frozenset({f"c{i}", f"d{j}"}) for i in range(30) for j in range(30)]  # 900 capability sets
    tasks = tuple(Task(f"t{i}", (1.0, 1.0), capabilities=frozenset({f"c{i % 30}"})) for i in range(100))
    inst = Instance(((0.0, 10.0), (0.0, 10.0)), (1.0, 1.0), tuple(caps), tasks)
    with pytest.raises(InstanceError, match=f"more than {MAX_VARIABLES:,}: give fewer tasks"):
        check_instance(inst)


def test_schedule_time_limit_covers_building_the_model():
    """A limit that runs out while the 100-task model is built: no solve, the message says what ran out."""
    from protocols.tsc import schedule as tsc
    from protocols.tsc.schedule_cli import load_instance

    inst, _ = load_instance(_chain_instance_file())
    started = time.monotonic()
    sched = tsc.solve_tctm(inst, 0.01)
    assert sched.status == "no_solution" and not sched.solved
    assert "ran out while the model was being built" in sched.message
    assert time.monotonic() - started < 2


@functools.cache
def _chain_instance_file() -> Path:
    import tempfile

    return _tasks_file(Path(tempfile.mkdtemp(prefix="tsc-chain-")), 20, 100)


def test_schedule_solver_that_overruns_its_limit_is_stopped(tmp_path, capsys):
    """HiGHS's presolve of a 100-task priority chain ignores a 2 s limit for tens of seconds: stopped, exit 3."""
    from protocols.tsc.schedule import OVERRUN_S, OVERRUN_SHARE

    limit = 2.0
    code, err, seconds = _bad_run(["schedule", str(_chain_instance_file()), "--time-limit", str(limit), "--model",
                                   "tctm", "--out", str(tmp_path / "o")], capsys)
    assert code == 3, err
    assert err.startswith(f"error: {_chain_instance_file()}: TCTM found no schedule within 2 s (no_solution: ")
    assert "raise --time-limit" in err
    assert seconds < limit + OVERRUN_S + OVERRUN_SHARE * limit + 3  # + loading the instance and the process


def test_within_kills_what_overruns_and_reports_what_fails():
    from protocols.tsc.schedule import _within

    started = time.monotonic()
    assert _within(lambda: time.sleep(30), 0.3) is None
    assert time.monotonic() - started < 3
    assert _within(lambda: {"x": [1, 2]}, 5) == {"x": [1, 2]}
    with pytest.raises(RuntimeError, match="ZeroDivisionError"):
        _within(lambda: 1 / 0, 5)


# ------------------------------------------------------------------ 13. certificate files under any umask
@pytest.mark.parametrize("umask", [0o000, 0o077], ids=["umask-000", "umask-077"])
def test_cluster_certs_modes_do_not_depend_on_the_umask(tmp_path, capsys, umask):
    """``cluster-certs`` (and ``world --secure``'s files): keys 0600, certificates 0644, a new directory 0700."""
    from swarmactors.cli import main

    folder = tmp_path / "deep" / "certs"
    old = os.umask(umask)
    try:
        assert main(["cluster-certs", str(folder)]) == 0, capsys.readouterr().err
    finally:
        os.umask(old)
    modes = {p.name: stat.S_IMODE(p.stat().st_mode) for p in folder.iterdir()}
    assert modes == {"ca.pem": 0o644, "world.pem": 0o644, "cluster.pem": 0o644, "ca.key": 0o600, "world.key": 0o600,
                     "cluster.key": 0o600, "users.txt": 0o600, "host.credential": 0o600}, modes
    assert stat.S_IMODE(folder.stat().st_mode) == 0o700
