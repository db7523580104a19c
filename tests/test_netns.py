"""Multi-host without Docker: the world and a robot host in two network namespaces joined by a veth pair."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
import uuid

import pytest

from needs import require_netns

pytestmark = pytest.mark.slow  # starts a world and a host in network namespaces

WORLD_ADDR = "10.231.0.1"
HOST_ADDR = "10.231.0.2"


def sh(*cmd: str) -> None:
    subprocess.run(cmd, check=True, capture_output=True, timeout=30)


@pytest.fixture
def two_hosts():
    require_netns()
    tag = uuid.uuid4().hex[:6]
    a, b = f"saw{tag}", f"sar{tag}"
    try:
        sh("ip", "netns", "add", a)
        sh("ip", "netns", "add", b)
        sh("ip", "link", "add", f"va{tag}", "type", "veth", "peer", "name", f"vb{tag}")
        sh("ip", "link", "set", f"va{tag}", "netns", a)
        sh("ip", "link", "set", f"vb{tag}", "netns", b)
        for ns, dev, addr in ((a, f"va{tag}", WORLD_ADDR), (b, f"vb{tag}", HOST_ADDR)):
            sh("ip", "-n", ns, "addr", "add", f"{addr}/30", "dev", dev)
            sh("ip", "-n", ns, "link", "set", dev, "up")
            sh("ip", "-n", ns, "link", "set", "lo", "up")
        yield a, b
    finally:
        subprocess.run(["ip", "netns", "del", a], capture_output=True)
        subprocess.run(["ip", "netns", "del", b], capture_output=True)


def test_world_and_robots_in_separate_network_namespaces(two_hosts, tmp_path):
    ns_world, ns_robots = two_hosts
    scenario = tmp_path / "s.toml"
    scenario.write_text(textwrap.dedent("""
        [run]
        name = "netns"
        ticks = 10
        [[robots]]
        count = 6
        placement = "line"
        spacing = 0.9
        behaviors = [{ use = "flooding", origin = 0, at = 1, expiry = 8 }]
        [[checks]]
        use = "flooding.reach"
    """))
    endpoint = f"tcp/{WORLD_ADDR}:7447"
    world = subprocess.Popen(["ip", "netns", "exec", ns_world, sys.executable, "-m", "swarmactors", "world",
                              str(scenario), "--listen", endpoint, "--run-id", "nx", "--out", str(tmp_path / "out"),
                              "--quiet"], stderr=subprocess.PIPE, text=True)
    robots = subprocess.Popen(["ip", "netns", "exec", ns_robots, sys.executable, "-m", "swarmactors", "robots",
                               "--connect", endpoint, "--run-id", "nx"], stderr=subprocess.PIPE, text=True)
    _, err = world.communicate(timeout=120)
    robots.wait(timeout=60)
    assert world.returncode == 0, err
    result = json.loads((tmp_path / "out" / "result.json").read_text())
    assert all(r["host"] == "h0" for r in result["robots"].values())
    assert all(r["flooding"]["received"] for r in result["robots"].values())
    assert result["checks"][0]["passed"]
