"""The control queryable, and the world/robots halves of the CLI across processes."""

from __future__ import annotations

import asyncio
import json
import socket
import subprocess
import sys
import textwrap

import pytest

from swarmactors.runs.launcher import new_run_id, run_world
from swarmactors.runs.scenario import resolve_scenario
from transport import Endpoints, pack, unpack

pytestmark = pytest.mark.slow  # every test runs a world over Zenoh (in process or as CLI processes)


def test_control_pause_step_kill_and_move_are_applied_and_recorded(tmp_path):
    raw = {
        "run": {"name": "ctl", "seed": 1, "ticks": 30},
        "world": {"objects": [{"name": "target", "pos": [1.0, 1.0]}]},
        "robots": [{"count": 6, "placement": "grid", "spacing": 0.5, "behaviors": [{"use": "beacon"}]}],
    }
    sc = resolve_scenario(raw, "<test>")
    seen = {}
    tasks = []

    def on_open(world, link):
        async def drive():
            async def ctl(cmd, **kw):
                return unpack(await link.query(world.keys.control, pack({"cmd": cmd, **kw}), timeout=10))

            while not world.started:  # noqa: ASYNC110 — World offers no event for its start to await
                await asyncio.sleep(0.01)
            seen["pause"] = await ctl("pause")
            await asyncio.sleep(0.3)
            t1 = (await ctl("status"))["tick"]
            await asyncio.sleep(0.3)
            t2 = (await ctl("status"))["tick"]
            seen["paused_ticks"] = (t1, t2)
            seen["kill"] = await ctl("kill", args=[2])
            seen["bad"] = await ctl("explode", args=1)
            seen["move"] = await ctl("move", args={"object": "target", "pos": [2.0, 0.5]})
            seen["step"] = await ctl("step")
            await asyncio.sleep(0.3)
            seen["after_step"] = (await ctl("status"))["tick"]
            seen["resume"] = await ctl("resume")

        tasks.append(asyncio.get_running_loop().create_task(drive()))

    async def main():
        return await run_world(sc, tmp_path, Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]), new_run_id("ctl"),
                               on_open=on_open)

    result = asyncio.run(main())
    t1, t2 = seen["paused_ticks"]
    assert t1 == t2  # paused: the clock does not advance
    assert seen["after_step"] == t2 + 1
    assert seen["kill"]["ok"] and not seen["bad"]["ok"] and "explode" in seen["bad"]["error"]
    assert result.robots[2]["failed"]["cause"] == "killed"
    events = [e for rec in result.trace for e in rec.get("ev", [])]
    assert any(e.get("kill") == [2] and e["source"] == "control" for e in events)
    assert any("move" in e and e["move"]["pos"] == [2.0, 0.5] for e in events)
    assert result["objects"]["target"] == [2.0, 0.5]
    assert result["ticks"] == 30


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_world_and_robots_commands_across_processes(tmp_path):
    scenario = tmp_path / "s.toml"
    scenario.write_text(textwrap.dedent("""
        [run]
        name = "split"
        seed = 5
        ticks = 10
        [[robots]]
        count = 8
        placement = "line"
        spacing = 0.8
        behaviors = [{ use = "flooding", origin = 0, at = 1, expiry = 9 }]
        [[checks]]
        use = "flooding.reach"
    """))
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    world = subprocess.Popen([sys.executable, "-m", "swarmactors", "world", str(scenario), "--listen", endpoint,
                              "--run-id", "split1", "--out", str(tmp_path / "out"), "--quiet"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    hosts = [subprocess.Popen([sys.executable, "-m", "swarmactors", "robots", "--connect", endpoint,
                               "--run-id", "split1", "--count", "4"], stderr=subprocess.PIPE, text=True)
             for _ in range(2)]
    out, err = world.communicate(timeout=120)
    for h in hosts:
        h.wait(timeout=60)
    assert world.returncode == 0, err
    result = json.loads((tmp_path / "out" / "result.json").read_text())
    assert {r["host"] for r in result["robots"].values()} == {"h0", "h1"}
    received = [r["flooding"]["received"] for r in result["robots"].values()]
    assert all(received)  # a line of 8 with expiry 9: everyone
    assert result["checks"][0]["passed"]
