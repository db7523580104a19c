"""Attacks on a run, tried as an attacker would (issue 27): no code from the wire, no crash from one message.

Each attack test drives a real world over Zenoh on 127.0.0.1 with a raw Zenoh client (the WireRun harness of
test_bad_input) and asserts: no code ran (a marker file is absent), the world finished with result.json, the
attack is counted under a named cause, and in lockstep the honest robots' deliveries are those of the
undisturbed run.
"""

from __future__ import annotations

import asyncio
import math
import stat
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import zenoh

from swarmactors.behavior import Behavior
from swarmactors.host import Robot
from swarmactors.launcher import new_run_id, private_endpoints, run_world
from swarmactors.launcher import run as launcher_run
from swarmactors.plugins import BEHAVIORS, RefusedBehavior, allowed, available, resolve_behavior
from swarmactors.scenario import resolve, resolve_scenario
from test_bad_input import FLOOD_RAW, PAUSE_AT, FakeLink, FakeQuery, WireRun, _get, _HostThread
from transport import Endpoints, Keys, make_config, pack, seal, unpack
from transport.messages import (
    MAX_PER_REQUEST,
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
from world.counters import MORE_MALFORMED, SAMPLES_PER_TICK
from world.kinematics import MAX_SPEED, bad_positions, velocity_problem
from world.world import World

HONEST = 30  # FLOOD_RAW's robots


def _honest_deliveries(result) -> list:
    return [(rec["t"], sorted(tuple(d) for d in rec.get("del", []) if d[0] < HONEST and d[2] < HONEST))
            for rec in result.trace]


@pytest.fixture(scope="module")
def undisturbed(tmp_path_factory):
    """The reference run, through the same harness (pause and resume included)."""
    return WireRun(FLOOD_RAW, tmp_path_factory.mktemp("undisturbed") / "run").run()


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


def _join_storm(wr, z, status):
    """Resume, then start many robot hosts in a tight loop; each joins while the world ticks."""
    _get(z, wr.keys.control, pack({"cmd": "resume"}))
    endpoint = wr.hosts[0].endpoint
    for _ in range(JOINERS):
        wr.hosts.append(_HostThread(endpoint, wr.run_id, 1))


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
    assert wr.hosts_ended_by_themselves and not any(h.error for h in wr.hosts)
    joined_at = sorted(r["joined_at"] for r in result.robots.values() if r["joined_at"] > 0)
    assert len(joined_at) == JOINERS and joined_at[-1] < TICKS - 1  # all joined during the run
    assert len(result.robots) == HONEST + JOINERS and result["world"]["dropped"]["malformed"] == 0
    assert all(r["alive"] for r in result.robots.values())
    assert _honest_deliveries(result) == _honest_deliveries(clean)


@pytest.mark.slow
def test_attack_joins_at_the_barrier_stale_steps_and_silence(tmp_path, undisturbed):
    """Joins that land between two ticks (the held-step race), stale and future steps, hosts that never step.

    The world serves each joiner from its registration on, counts the stale and future steps as malformed, and
    declares the silent hosts lost within the watchdog; the honest robots do not notice.
    """
    wr = WireRun(FLOOD_RAW, tmp_path / "run", inject=_joins_at_the_barrier, expect_malformed=3)
    t0 = time.monotonic()
    result = wr.run()
    assert (tmp_path / "run" / "result.json").is_file() and result["ticks"] == FLOOD_RAW["run"]["ticks"]
    joined = wr.notes["joined"]
    assert len(joined) == JOINERS and len(result.robots) == HONEST + JOINERS
    assert all(wr.replies[k][0] == "err" for k in wr.replies if k.startswith("step"))
    assert result["world"]["dropped"]["malformed"] == 3
    mal = [m for rec in result.trace for m in rec.get("mal", [])]
    assert sum("stale step" in m for m in mal) == 2 and sum("future step" in m for m in mal) == 1
    lost = [ev for rec in result.trace for ev in rec.get("ev", []) if "host_lost" in ev]
    assert {ev["host_lost"] for ev in lost} == {j.host for j in joined}
    assert all(ev["cause"] == "watchdog" and ev["t"] == PAUSE_AT for ev in lost)
    limit = 2 * FLOOD_RAW["run"]["watchdog_s"] + 5.0
    assert time.monotonic() - t0 < limit + 10
    assert _honest_deliveries(result) == _honest_deliveries(undisturbed)


# ------------------------------------------------------------------ 5. empty joins
def test_empty_join_is_refused_and_the_error_names_the_claimers():
    sc = resolve({"run": {"name": "j", "ticks": 2, "join_timeout_s": 0.2},
                           "robots": [{"count": 3, "behaviors": [{"use": "beacon"}]}]}, "<t>")
    w = World(sc, FakeLink(), Keys("j"))
    empty = FakeQuery(w.keys.join, b"")
    w._on_join(empty)
    assert empty.replies[0][0] == "err" and "empty join request" in empty.replies[0][1]
    assert w.counters.dropped["malformed"] == 1 and len(w.unclaimed) == 3
    ok = FakeQuery(w.keys.join, encode(JoinRequest(2)))
    w._on_join(ok)
    assert ok.replies[0][0] == "ok"
    with pytest.raises(RuntimeError, match=r"1 robot\(s\) were not claimed.*h0 \(2\).*never registered: h0"):
        asyncio.run(w._wait_ready())


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
