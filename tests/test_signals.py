"""Failures and signals with real processes: the world dies, SIGTERM, SIGINT mid-run, a stalled host, a stop.

Every test starts real ``swarmactors`` processes over Zenoh and sends them real signals (issue 28).
"""

from __future__ import annotations

import asyncio
import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from swarmactors.runs.launcher import new_run_id, run_world
from swarmactors.runs.scenario import resolve_scenario
from transport import Endpoints
from transport.messages import Stop

pytestmark = pytest.mark.slow  # every test runs a world over Zenoh

CLI = [sys.executable, "-m", "swarmactors"]


def scenario(tmp_path: Path, clock: str, ticks: int, dt: float = 0.1, n: int = 4, **run) -> Path:
    lines = [f'[run]\nname = "sig"\nseed = 1\nticks = {ticks}\nclock = "{clock}"\ndt = {dt}\n'
             + "".join(f"{k} = {v}\n" for k, v in run.items()),
             "[radio]\nrange = 1.0\n",
             f'[[robots]]\ncount = {n}\nplacement = "grid"\nspacing = 0.5\nbehaviors = [{{ use = "beacon" }}]\n']
    path = tmp_path / f"{clock}.toml"
    path.write_text("\n".join(lines))
    return path


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start(args: list[str], **kw) -> subprocess.Popen:
    return subprocess.Popen([*CLI, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def wait_for(path: Path, seconds: float, size: int = 0) -> None:
    """Wait until ``path`` exists and holds more than ``size`` bytes (the trace is flushed every second)."""
    deadline = time.monotonic() + seconds
    while not path.exists() or path.stat().st_size <= size:
        assert time.monotonic() < deadline, f"{path} did not appear (or grow past {size} B) within {seconds} s"
        time.sleep(0.1)


def wait_running(out: Path, seconds: float = 40) -> None:
    """Wait until the run is under way: its trace holds tick records beyond the header."""
    trace = out / "trace.msgpack"
    wait_for(trace, seconds)
    wait_for(trace, seconds, trace.stat().st_size + 3000)


@pytest.mark.parametrize("clock", ["realtime", "lockstep"])
def test_hosts_exit_3_with_one_line_when_the_world_is_killed(tmp_path, clock):
    """A world killed with SIGKILL: its host exits with code 3 and one line, within the lease (here at once)."""
    port = free_port()
    sc = scenario(tmp_path, clock, ticks=100_000, dt=0.1)
    world = start(["world", str(sc), "--listen", f"tcp/127.0.0.1:{port}", "--mode", "peer", "--run-id", "w1",
                   "--quiet", "--no-plots", "--out", str(tmp_path / "out")])
    host = start(["robots", "--connect", f"tcp/127.0.0.1:{port}", "--run-id", "w1", "--mode", "peer"],
                 env={**os.environ, "PYTHONWARNINGS": "ignore"})
    try:
        wait_running(tmp_path / "out")
        world.kill()
        killed = time.monotonic()
        _, err = host.communicate(timeout=30)
        took = time.monotonic() - killed
    finally:
        for p in (world, host):
            if p.poll() is None:
                p.kill()
            p.wait(5)
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith(("warning:", "joined", "host "))]
    assert host.returncode == 3, err
    assert len(lines) == 1 and lines[0].startswith("error:") and "Traceback" not in err, err
    assert took < 25.0  # within the lease (2·watchdog_s + 5 = 25 s); a killed world's socket closes at once


def test_sigterm_is_handled_as_sigint(tmp_path):
    """SIGTERM (docker stop) mid-run: exit 130, result.json written (interrupted), the trace has its footer."""
    sc = scenario(tmp_path, "realtime", ticks=100_000, dt=0.05)
    out = tmp_path / "out"
    run = start(["run", str(sc), "--processes", "1", "--quiet", "--no-plots", "--out", str(out)])
    try:
        wait_running(out)
        run.send_signal(signal.SIGTERM)
        sent = time.monotonic()
        _, err = run.communicate(timeout=30)
        took = time.monotonic() - sent
    finally:
        if run.poll() is None:
            run.kill()
    assert run.returncode == 130, err
    result = json.loads((out / "result.json").read_text())
    assert result["interrupted"] is True and result["stop_reason"] == "interrupted (SIGTERM)"
    assert all("beacon" in r for r in result["robots"].values())  # every robot's report came back
    from swarmactors.oracle.trace import read_trace

    _, records, footer = read_trace(out / "trace.msgpack")
    assert footer is not None and records
    assert took < 10.0


def test_sigint_mid_run_with_host_processes_keeps_every_report(tmp_path):
    """SIGINT to the whole process group (Ctrl-C) mid-tick with 2 host processes: every report kept, quickly."""
    sc = scenario(tmp_path, "lockstep", ticks=1_000_000, dt=0.1, n=6)
    out = tmp_path / "out"
    run = start(["run", str(sc), "--processes", "2", "--quiet", "--no-plots", "--out", str(out)],
                start_new_session=True)
    try:
        wait_running(out)
        os.killpg(run.pid, signal.SIGINT)  # as a terminal's Ctrl-C: the world and its hosts
        sent = time.monotonic()
        _, err = run.communicate(timeout=40)
        took = time.monotonic() - sent
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
    assert run.returncode == 130, err
    result = json.loads((out / "result.json").read_text())
    assert result["interrupted"] is True
    missing = [rid for rid, r in result["robots"].items() if "beacon" not in r]
    assert not missing, f"robots without a report: {missing}"
    assert took < 10.0  # reports within INTERRUPT_REPORTS_S (5 s), hosts exit within HOSTS_EXIT_S (5 s)


def test_sigint_during_join_exits_promptly(tmp_path):
    """SIGINT before the hosts have joined: exit 130 within a few seconds, result.json written."""
    sc = scenario(tmp_path, "lockstep", ticks=100, dt=0.1, n=4)
    out = tmp_path / "out"
    run = start(["run", str(sc), "--processes", "2", "--quiet", "--no-plots", "--out", str(out)],
                start_new_session=True)
    try:
        wait_for(out / "trace.msgpack", 30)  # the world is open; its host processes are still starting
        os.killpg(run.pid, signal.SIGINT)
        sent = time.monotonic()
        _, err = run.communicate(timeout=40)
        took = time.monotonic() - sent
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
    assert run.returncode == 130, err
    assert json.loads((out / "result.json").read_text())["interrupted"] is True
    assert took < 12.0


def test_a_host_stalled_longer_than_zenohs_default_lease_is_kept(tmp_path):
    """SIGSTOP for 11 s (> Zenoh's default 10 s lease, < 2·watchdog_s + 5 = 15 s): the host carries on."""
    sc = scenario(tmp_path, "realtime", ticks=150, dt=0.1, n=4, watchdog_s=5)
    out = tmp_path / "out"
    run = start(["run", str(sc), "--processes", "1", "--quiet", "--no-plots", "--out", str(out)])
    try:
        wait_running(out)
        hosts = child_pids(run.pid)
        assert hosts, "no host process found"
        for pid in hosts:
            os.kill(pid, signal.SIGSTOP)
        time.sleep(11.0)
        for pid in hosts:
            os.kill(pid, signal.SIGCONT)
        _, err = run.communicate(timeout=60)
    finally:
        if run.poll() is None:
            run.kill()
    result = json.loads((out / "result.json").read_text())
    assert not [r["failed"] for r in result["robots"].values() if r["failed"]], err
    assert all("beacon" in r for r in result["robots"].values())


def child_pids(pid: int) -> list[int]:
    """The processes started by ``pid`` that run a host (multiprocessing's spawn children)."""
    out = subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True).stdout.split()
    hosts = []
    for child in map(int, out):
        cmd = Path(f"/proc/{child}/cmdline").read_bytes().replace(b"\0", b" ")
        if b"multiprocessing.spawn" in cmd and b"spawn_main" in cmd:
            hosts.append(child)
    return hosts


def test_a_host_that_goes_quiet_after_a_stop_is_lost(tmp_path):
    """A host that goes quiet after a ``stop`` on its downlink mid-run is lost all the same.

    The stop is real (sealed with the host's key): the host reports and leaves; the world counts it lost
    (its robots fail as host-lost, ``alive: false``), whatever it sent before.
    """
    sc = resolve_scenario({
        "run": {"name": "stop", "seed": 1, "ticks": 60, "clock": "realtime", "dt": 0.05},
        "radio": {"range": 1.0},
        "robots": [{"count": 4, "placement": "grid", "spacing": 0.5, "behaviors": [{"use": "beacon"}]}],
    }, "<test>")
    run_id = new_run_id("stop")
    sent = {}

    def on_tick(world):
        if world.tick == 10 and not sent:
            host = next(iter(world.peers))
            world.link.publish(world.keys.down(host), world.peers.seal(host, Stop(world.tick)))
            sent["tick"] = world.tick

    async def main():
        return await run_world(sc, tmp_path, Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]), run_id,
                               processes=1, on_tick=on_tick)

    result = asyncio.run(main())
    assert result["ticks"] == 60
    failed = {rid: r["failed"] for rid, r in result.robots.items()}
    assert all(f is not None and f["cause"] == "host-lost" for f in failed.values()), failed
    assert not any(r["alive"] for r in result.robots.values())


def test_a_lockstep_host_stalled_past_the_watchdog_is_lost_and_exits_with_one_line(tmp_path):
    """SIGSTOP past 2·watchdog_s + 5 (here 6 s): the world loses the host; resumed, it exits 3 with one line."""
    port = free_port()
    sc = scenario(tmp_path, "lockstep", ticks=1_000_000, dt=0.1, watchdog_s=0.5)
    world = start(["world", str(sc), "--listen", f"tcp/127.0.0.1:{port}", "--mode", "peer", "--run-id", "w2",
                   "--quiet", "--no-plots", "--out", str(tmp_path / "out")])
    hosts = [start(["robots", "--connect", f"tcp/127.0.0.1:{port}", "--run-id", "w2", "--mode", "peer",
                    "--count", "2", "--quiet"]) for _ in range(2)]
    try:
        wait_running(tmp_path / "out")
        os.kill(hosts[0].pid, signal.SIGSTOP)
        time.sleep(8.0)
        os.kill(hosts[0].pid, signal.SIGCONT)
        _, err = hosts[0].communicate(timeout=20)
        assert hosts[1].poll() is None  # the other host carries on
    finally:
        for p in (world, *hosts):
            if p.poll() is None:
                p.kill()
            p.wait(5)
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("warning:")]
    assert hosts[0].returncode == 3, err
    assert len(lines) == 1 and lines[0].startswith("error:") and "Traceback" not in err, err


def test_check_runs_a_user_behaviour_in_a_host_process(tmp_path):
    """``swarmactors check --behavior module:Class`` runs the user's behaviour with K = 1 (the world survives it)."""
    from swarmactors.runs.conformance import case_by_name, is_user_behavior, run_case

    assert is_user_behavior("mutants:FloodBackToSender")
    assert not is_user_behavior(None) and not is_user_behavior("flooding")
    fam, case = case_by_name("flooding", "flooding/ring-8")
    run_case(fam, case, "mutants:FloodBackToSender", tmp_path, determinism=False)
    result = json.loads((tmp_path / "flooding-ring-8" / "k1" / "result.json").read_text())
    assert result["processes"] == 1
    assert {r["host"] for r in result["robots"].values()} == {"h0"}
