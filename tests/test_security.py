"""--secure: who may join, what a joined host may do, and impersonation between hosts.

Each denial is paired with its positive control: the same rogue actions
against a world without --secure do take effect.
"""

from __future__ import annotations

import asyncio
import json
import socket
import subprocess
import sys
import textwrap
import time

import pytest
import zenoh

from swarmactors.robot.host import RobotHost
from transport import Endpoints, Keys, Link, QueryError, Security, ensure_files, make_config, pack, seal

pytestmark = pytest.mark.slow  # every test runs a secure world and hosts over Zenoh

TICKS = 50


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def scenario(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(textwrap.dedent(f"""
        [run]
        name = "sec"
        clock = "realtime"
        ticks = {TICKS}
        dt = 0.05
        join_timeout_s = 30
        [radio]
        latency_s = 0.005
        [[robots]]
        count = 6
        placement = "grid"
        spacing = 0.5
        behaviors = [{{ use = "beacon" }}]
    """))
    return path


def start_world(scenario, out, endpoint, run_id, secure=None):
    cmd = [sys.executable, "-m", "swarmactors", "world", str(scenario), "--listen", endpoint, "--run-id", run_id,
           "--out", str(out), "--quiet"]
    if secure is not None:
        cmd += ["--secure", str(secure)]
    return subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True)


def start_host(endpoint, run_id, count, secure=None):
    cmd = [sys.executable, "-m", "swarmactors", "robots", "--connect", endpoint, "--run-id", run_id,
           "--count", str(count), "--wait", "30"]  # a host that misses the run gives up within the test's wait
    if secure is not None:
        cmd += ["--secure", str(secure)]
    return subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True)


def host_endpoints(endpoint, run_id, secure) -> Endpoints:
    extra = Security("host", secure).zenoh_settings(run_id) if secure else {}
    return Endpoints(mode="client", connect=[endpoint], extra=extra)


async def rogue(endpoint, run_id, secure) -> dict:
    """A joined host (with the credential, if any) that misbehaves; returns what it tried and saw."""
    keys = Keys(run_id)
    seen = {"injected": 0}
    with Link(host_endpoints(endpoint, run_id, secure)) as link:
        host = RobotHost(link, keys, count=1)
        await host.join()
        task = asyncio.ensure_future(host.run())
        await asyncio.sleep(0.8)
        victim = "h0" if host.name != "h0" else "h1"
        own_robot = next(iter(host.robots))
        other_robot = next(r for r in range(6) if r != own_robot)
        for _ in range(3):
            # impersonation: a message on the victim's key, sealed with the rogue's own key
            link.publish(keys.up(victim),
                         seal(host.key, pack({"h": victim, "t": 3, "r": [[other_robot, [5.0, 0.0], [], None, None]]})))
            # forged src: the rogue's own key and channel, but a robot it does not run
            link.publish(keys.up(host.name), seal(host.key, pack({"h": host.name, "t": 3, "r": [
                [other_robot, [5.0, 0.0], [[None, "BEACON", 10**6, pack([0.0, b""]), []]], None, None]]})))
            seen["injected"] += 2
        # access control: publish on the victim's downlink, and stop the run through control
        link.publish(keys.down(victim), pack({"stop": True}))
        try:
            seen["control"] = await link.query(keys.control, pack({"cmd": "stop"}), timeout=2.0)
        except QueryError as exc:
            seen["control_error"] = str(exc)
        seen["name"], seen["victim"], seen["own_robot"] = host.name, victim, own_robot
        await task
    return seen


def run_with_rogue(tmp_path, scenario, secure):
    port = free_port()
    scheme = "tls" if secure else "tcp"
    endpoint = f"{scheme}/127.0.0.1:{port}"
    run_id = f"sec{port}"
    out = tmp_path / ("secure" if secure else "open")
    world = start_world(scenario, out, endpoint, run_id, secure)
    time.sleep(1.5)
    honest = start_host(endpoint, run_id, 5, secure)
    time.sleep(1.0)  # usually the honest host joins first, but the test does not depend on it
    seen = asyncio.run(rogue(endpoint, run_id, secure))
    _, err = world.communicate(timeout=120)
    honest.wait(timeout=60)
    assert world.returncode == 0, err
    return json.loads((out / "result.json").read_text()), seen, err


def test_secure_world_denies_and_drops_what_a_joined_host_may_not_do(tmp_path, scenario):
    secure = ensure_files(tmp_path / "certs")
    result, seen, _ = run_with_rogue(tmp_path, scenario, secure)
    assert seen["victim"] != seen["name"]
    assert "control_error" in seen  # access control: the control query reaches nobody
    assert result["ticks"] == TICKS and result["stop_reason"] is None  # ... so the run was not stopped
    honest = [r for r in result["robots"].values() if r["host"] == seen["victim"]]
    assert len(honest) == 5 and all(r["alive"] for r in honest)
    assert all(r["beacon"]["sent"] >= TICKS - 2 for r in honest)  # the forged stop never reached the victim
    assert result["world"]["dropped"]["malformed"] == seen["injected"]  # impersonation: dropped and counted
    examples = result["world"]["malformed_examples"]
    assert sum("fails authentication" in e for e in examples) == 3  # on the victim's key
    assert sum("which it does not run" in e for e in examples) == 3  # forged src on its own key
    own = result["robots"][str(seen["own_robot"])]
    assert own["host"] == seen["name"] and own["beacon"]["sent"] > 0  # its own valid traffic went through
    assert sum(r["beacon"]["heard"] for r in honest) > 0


def test_without_secure_the_same_rogue_succeeds_and_a_warning_is_printed(tmp_path, scenario):
    result, seen, err = run_with_rogue(tmp_path, scenario, None)
    assert "running without --secure" in err
    assert "control_error" not in seen  # positive control: nothing stops the control query ...
    assert result["stop_reason"] == "stopped by control" and result["ticks"] < TICKS  # ... and it stops the run
    assert result["world"]["dropped"]["malformed"] == seen["injected"]  # the per-host key still applies


def test_only_the_credential_connects(tmp_path, scenario):
    secure = ensure_files(tmp_path / "certs")
    port = free_port()
    endpoint = f"tls/127.0.0.1:{port}"
    world = start_world(scenario, tmp_path / "out", endpoint, "cred", secure)
    try:
        time.sleep(1.5)

        def open_with(extra):
            cfg = make_config(Endpoints(mode="client", connect=[endpoint], extra=extra))
            cfg.insert_json5("connect/timeout_ms", "2000")
            return zenoh.open(cfg)

        ca_only = {"transport/link/tls/root_ca_certificate": str(secure / "ca.pem")}
        with pytest.raises(zenoh.ZError):
            open_with(ca_only)  # TLS but no credential
        with pytest.raises(zenoh.ZError):
            open_with({**ca_only, "transport/auth/usrpwd/user": "robot-host",
                       "transport/auth/usrpwd/password": "guess"})
        session = open_with(Security("host", secure).zenoh_settings("cred"))  # control: the credential connects
        assert session.info.routers_zid()
        session.close()
    finally:
        world.kill()
        world.wait()
