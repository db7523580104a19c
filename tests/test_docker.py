"""Docker: the image built without a registry, compose runs with several robot containers."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
import threading
import time
import uuid
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
COMPOSE_FILE = REPO / "docker" / "compose.yaml"
pytestmark = [pytest.mark.docker, pytest.mark.slow]  # builds images and runs worlds in containers


def compose_up(compose, scenario: Path, out: Path, replicas: int, per_host: int, clock="lockstep",
               on_running=None, secure=False, uid: int | None = None) -> tuple[int, str]:
    """``docker-compose up``; the containers run as the image's user (1000), or as ``uid`` when given.

    ``out`` is made writable by any user, as docs/deploy.md says OUT must be writable by the containers' user.
    """
    project = f"sa{uuid.uuid4().hex[:8]}"
    out.chmod(0o777)
    env = {**os.environ, "SCENARIO": str(scenario), "OUT": str(out), "ROBOTS_PER_HOST": str(per_host),
           "CLOCK": clock, "RUN_ID": project}
    for name in ("SWARMACTORS_UID", "SWARMACTORS_GID"):
        env.pop(name, None)
        if uid is not None:
            env[name] = str(uid)
    base = [*compose, "-p", project, "-f", str(COMPOSE_FILE)]
    try:
        world, robots = ("world-secure", "robots-secure") if secure else ("world", "robots")
        profile = ["--profile", "secure"] if secure else []
        if on_running:  # a container will be killed: compose must not stop the others when it exits
            up = subprocess.run([*base, *profile, "up", "-d", "--scale", f"{robots}={replicas}", world, robots],
                                env=env, capture_output=True, text=True, timeout=300)
            assert up.returncode == 0, up.stderr
            threading.Thread(target=on_running, args=(base, env), daemon=True).start()
            world_id = subprocess.run([*base, "ps", "-q", world], env=env, capture_output=True, text=True,
                                      timeout=60).stdout.strip()
            waited = subprocess.run(["docker", "wait", world_id], capture_output=True, text=True, timeout=300)
            logs = subprocess.run([*base, "logs", "--no-color"], env=env, capture_output=True, text=True,
                                  timeout=60).stdout
            return int(waited.stdout.strip() or -1), logs
        proc = subprocess.Popen([*base, *profile, "up", "--scale", f"{robots}={replicas}",
                                 "--abort-on-container-exit", "--exit-code-from", world, world, robots], env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        logs, _ = proc.communicate(timeout=300)
        return proc.returncode, logs
    finally:
        subprocess.run([*base, "--profile", "secure", "down", "--volumes", "--remove-orphans", "-t", "2"], env=env,
                       capture_output=True, timeout=120)


def single_process(scenario: Path, out: Path, *extra: str) -> dict:
    subprocess.run([sys.executable, "-m", "swarmactors", "run", str(scenario), "--out", str(out), "--quiet", *extra],
                   check=True, timeout=300)
    return json.loads((out / "result.json").read_text())


@pytest.fixture(scope="module")
def flood_reference(tmp_path_factory) -> dict:
    """scenarios/flooding.toml in one process (the CLI), the result.json both compose runs are compared with."""
    return single_process(REPO / "scenarios" / "flooding.toml", tmp_path_factory.mktemp("flood") / "single")


def test_compose_run_equals_the_single_process_run(image, flood_reference, tmp_path):
    scenario = REPO / "scenarios" / "flooding.toml"
    out = tmp_path / "compose"
    out.mkdir()
    code, logs = compose_up(image, scenario, out, replicas=3, per_host=10)
    assert code == 0, logs[-3000:]
    got = json.loads((out / "result.json").read_text())
    # --abort-on-container-exit stopped the world after its hosts exited: it still judged, drew and summed up
    assert not got["interrupted"] and got["checks"], logs[-3000:]
    assert "every check passed (exit 0)" in logs and (out / "swarm.png").exists(), logs[-3000:]
    assert (out / "result.json").stat().st_uid == 1000  # written by the image's user, not root
    ref = flood_reference
    assert {r["host"] for r in got["robots"].values()} == {"h0", "h1", "h2"}  # three containers ran robots
    assert got["trace_hash"] == ref["trace_hash"]  # lockstep: identical history
    assert {k: r["flooding"]["received"] for k, r in got["robots"].items()} == \
        {k: r["flooding"]["received"] for k, r in ref["robots"].items()}
    assert all(c["passed"] for c in got["checks"])


def test_killing_a_robot_container_fails_its_robots_and_the_run_goes_on(image, tmp_path):
    scenario = tmp_path / "rt.toml"
    scenario.write_text(textwrap.dedent("""
        [run]
        name = "rt"
        seed = 3
        clock = "realtime"
        ticks = 80
        dt = 0.1
        [radio]
        latency_s = 0.01
        [[robots]]
        count = 9
        placement = "grid"
        spacing = 0.6
        behaviors = [{ use = "beacon" }]
    """))
    out = tmp_path / "out"
    out.mkdir()
    killed = {}

    def kill_one(base, env):
        deadline = time.monotonic() + 120
        header = None  # the trace's size when only its header is written (at open, before the hosts joined)
        while time.monotonic() < deadline:
            ids = subprocess.run([*base, "ps", "-q", "robots"], env=env, capture_output=True, text=True).stdout.split()
            size = (out / "trace.msgpack").stat().st_size if (out / "trace.msgpack").exists() else None
            header = header if header is not None or size is None else size
            if len(ids) == 3 and size is not None and size > header:  # ticks recorded: every host has joined
                time.sleep(1.0)  # let the run tick for a while
                subprocess.run(["docker", "kill", ids[0]], capture_output=True)
                killed["at"] = time.monotonic()
                return
            time.sleep(0.3)

    code, logs = compose_up(image, scenario, out, replicas=3, per_host=3, clock="realtime", on_running=kill_one)
    assert code == 1, logs[-3000:]  # robots whose host was lost crashed: the run goes on, and says so
    assert "3 robots crashed" in logs, logs[-3000:]
    assert killed, "no robot container was killed"
    result = json.loads((out / "result.json").read_text())
    failed = [r for r in result["robots"].values() if r["failed"]]
    assert len(failed) == 3 and all(r["failed"]["cause"] == "host-lost" for r in failed)
    assert 0 < min(r["failed"]["tick"] for r in failed) < 80
    assert result["ticks"] == 80
    survivors = [r for r in result["robots"].values() if r["alive"]]
    assert len(survivors) == 6 and all(r["beacon"]["heard"] > 0 for r in survivors)


def test_compose_secure_profile_runs_over_tls_with_the_credential(image, flood_reference, tmp_path):
    scenario = REPO / "scenarios" / "flooding.toml"
    out = tmp_path / "secure"
    out.mkdir()
    code, logs = compose_up(image, scenario, out, replicas=3, per_host=10, secure=True, uid=4321)
    assert code == 0, logs[-3000:]
    got = json.loads((out / "result.json").read_text())
    # SWARMACTORS_UID: every container ran as that user (the credential it shares is readable by it), and
    # what the world wrote in OUT belongs to it
    assert {p.stat().st_uid for p in out.iterdir()} == {4321}
    ref = flood_reference
    assert {r["host"] for r in got["robots"].values()} == {"h0", "h1", "h2"}
    assert got["trace_hash"] == ref["trace_hash"]
    assert "running without --secure" not in logs


def test_the_image_runs_as_a_user_and_holds_no_installer_or_wheels(image):
    def sh(cmd: str) -> str:
        out = subprocess.run(["docker", "run", "--rm", "--entrypoint", "sh", "swarmactors:latest", "-c", cmd],
                             capture_output=True, text=True, timeout=120)
        assert out.returncode == 0, out.stderr
        return out.stdout.strip()

    assert sh("id -u; id -g") == "1000\n1000"
    assert sh("ls /tmp/wheels 2>/dev/null | wc -l; command -v pip gcc cc | wc -l") == "0\n0"
    assert sh("find /opt/swarmactors -type d -name tests -path '*/site-packages/*' | wc -l") == "0"
    assert sh("swarmactors --version").startswith("swarmactors ")
