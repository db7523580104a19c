"""The live viewer: the page in a real browser, a remote viewer over Zenoh, pages that stall or leave."""

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
import tomllib
import urllib.request
from pathlib import Path

import aiohttp
import pytest

from needs import require_browser
from swarmactors.oracle.result import Result
from swarmactors.oracle.trace import read_trace
from swarmactors.runs.launcher import new_run_id
from swarmactors.runs.scenario import resolve_scenario
from swarmactors.tools.viewer import ViewerServer, run_with_viewer
from transport import Endpoints

pytestmark = pytest.mark.slow  # every test runs a world over Zenoh, some a browser

TESTS = Path(__file__).resolve().parent
URL = re.compile(r"viewer: (http://127\.0\.0\.1:\d+/\?token=[\w-]+)")

SCENARIO = """
[run]
name = "viewer"
seed = 4
ticks = 40

[world]
bounds = [[0.0, 0.0], [3.0, 3.0]]
objects = [{ name = "target", pos = [2.5, 2.5] }]

[[robots]]
count = 12
placement = "grid"
spacing = 0.7
area = [[0.3, 0.3], [3.0, 3.0]]
speed = 0.1
behaviors = [{ use = "tests_support:RandomWalk" }, { use = "viewer_support:Chain" }]
"""


def _env() -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(TESTS), env.get("PYTHONPATH", "")])
    return env


def _start(args: list[str], log: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "swarmactors", *args], stdout=subprocess.PIPE,
                            stderr=open(log, "w"), text=True, env=_env())


def _wait_url(proc: subprocess.Popen, log: Path, timeout: float = 60) -> str:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        m = URL.search(log.read_text())
        if m:
            return m.group(1)
        assert proc.poll() is None, log.read_text()
        time.sleep(0.05)
    raise AssertionError(f"no viewer URL within {timeout} s: {log.read_text()}")


def _request(url: str, path: str, data: bytes | None = None) -> urllib.request.Request:
    """A request for ``path`` of the viewer printed as ``url`` (…/?token=T), with the token as a header."""
    base, token = url.split("?token=")
    headers = {"X-Swarmactors-Token": token, "Content-Type": "application/json"}
    return urllib.request.Request(base + path, data=data, headers=headers)


def _get(url: str, path: str):
    with urllib.request.urlopen(_request(url, path), timeout=10) as r:
        body = r.read().decode()
    return json.loads(body) if r.headers.get_content_type() == "application/json" else body


def _post(url: str, cmd: dict) -> dict:
    with urllib.request.urlopen(_request(url, "api/command", json.dumps(cmd).encode()), timeout=10) as r:
        return json.loads(r.read())


def _until(fn, timeout: float = 20, what: str = "condition"):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = fn()
        if value:
            return value
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}")


PIXEL = """(id) => {
  const [sx, sy] = window.swarm.screenOf(id);
  const c = document.getElementById('canvas'), r = c.getBoundingClientRect(), d = window.devicePixelRatio || 1;
  const x = Math.round((sx - r.left) * d), y = Math.round((sy - r.top) * d);
  return Array.from(c.getContext('2d').getImageData(x, y, 1, 1).data);
}"""


def test_viewer_page_in_a_real_browser(tmp_path, run):
    """Two pages on a paused lockstep run, driven through one of them.

    Robots where the world has them, steps, kill by click, drag a target, inspect a robot, run to the end,
    replay with the slider, export the actions; the export reproduces the run.
    """
    chromium = require_browser()
    from playwright.sync_api import sync_playwright

    scenario = tmp_path / "viewer.toml"
    scenario.write_text(SCENARIO)
    out = tmp_path / "out"
    log = tmp_path / "cli.log"
    proc = _start(["run", str(scenario), "--out", str(out), "--view", "--view-port", "0", "--quiet"], log)
    seen: dict[int, dict[int, list[float]]] = {}  # tick -> robot -> [x, y] as the page had them
    try:
        url = _wait_url(proc, log)
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
            a = browser.new_page(viewport={"width": 1280, "height": 760})
            b = browser.new_page(viewport={"width": 900, "height": 700})
            errors: list[str] = []
            for page in (a, b):
                page.on("pageerror", lambda e: errors.append(str(e)))
                page.goto(url)
            for page in (a, b):  # the run waits after tick 0
                page.wait_for_function("window.swarm && window.swarm.drawn.t === 0")
            assert a.evaluate("window.swarm.drawn.robots") == 12
            assert a.evaluate("window.swarm.structureEdges") == 11  # the chain the robots report: parent = id - 1
            assert "0 / 39" in a.inner_text("#tick")

            def capture(page) -> None:
                f = page.evaluate("window.swarm.frame")
                seen[f["t"]] = {r[0]: r[1:3] for r in f["robots"]}

            capture(a)
            for rid in (0, 5, 11):  # the canvas really has a robot there
                r, g, bl, alpha = a.evaluate(PIXEL, rid)
                assert alpha == 255 and (r, g, bl) != (255, 255, 255), (rid, r, g, bl)
            for t in (1, 2, 3):
                a.click("#step")
                for page in (a, b):  # both pages follow
                    page.wait_for_function(f"window.swarm.drawn.t === {t}")
                capture(b)
            # kill by clicking, in the kill tool; the world applies it at the next tick
            a.check("#tool-kill")
            a.mouse.click(*a.evaluate("window.swarm.screenOf(5)"))
            a.wait_for_function("document.getElementById('robot').innerText.includes('robot 5')")
            a.click("#step")
            a.wait_for_function("window.swarm.frame.dead.some(d => d[0] === 5)")
            b.wait_for_function("window.swarm.frame.dead.some(d => d[0] === 5 && d[3] === 'killed')")
            assert a.evaluate("window.swarm.drawn.robots") == 11
            assert a.evaluate("window.swarm.structureEdges") == 9  # 5's edge and 6's edge to 5 are gone
            # drag the target to a new place
            ox, oy = a.evaluate("window.swarm.screenOfObject('target')")
            a.mouse.move(ox, oy)
            a.mouse.down()
            a.mouse.move(ox - 120, oy + 90, steps=6)
            a.mouse.up()
            a.click("#step")
            a.wait_for_function("window.swarm.frame.objects.target[0] < 2.3")
            moved_to = a.evaluate("window.swarm.frame.objects.target")
            # inspect another robot: its status fields
            a.check("#tool-inspect")
            a.mouse.click(*a.evaluate("window.swarm.screenOf(2)"))
            a.wait_for_function("(t => t.includes('robot 2') && t.includes('moved'))"
                                "(document.getElementById('robot').innerText)")
            assert "robot 2" in a.inner_text("#robot") and "alive" in a.inner_text("#robot")
            # run to the end at full speed: the page turns into a replay of the trace
            a.select_option("#speed", "")
            a.click("#play")
            a.wait_for_function("window.swarm.frame && window.swarm.frame.mode === 'replay'", timeout=60_000)
            assert a.evaluate("window.swarm.frame.t") == 39
            a.evaluate("() => { const s = document.getElementById('slider'); s.value = 2;"
                       " s.dispatchEvent(new Event('input')); }")
            a.wait_for_function("window.swarm.drawn.t === 2")
            replayed = {r[0]: r[1:3] for r in a.evaluate("window.swarm.frame.robots")}
            assert replayed == seen[2]
            a.click("#export")
            a.wait_for_function("document.getElementById('export-text').value.includes('[[events]]')")
            exported = a.input_value("#export-text")
            assert [e["kill"] for e in tomllib.loads(exported)["events"] if "kill" in e] == [[5]], exported
            if os.environ.get("SWARMACTORS_VIEWER_SCREENSHOT"):
                a.screenshot(path=os.environ["SWARMACTORS_VIEWER_SCREENSHOT"])
            assert not errors, errors
            browser.close()
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=30)
    assert proc.returncode == 0, log.read_text()
    result = Result.load(out)
    assert result.robots[5]["failed"]["cause"] == "killed"
    assert result["objects"]["target"] == moved_to
    _, records, _ = read_trace(out / "trace.msgpack")
    for t, where in seen.items():  # the page showed the world's positions at every tick it showed
        assert {row[0]: row[1:3] for row in records[t]["pos"]} == where, t
    events = [e for rec in records for e in rec.get("ev", [])]
    kill = next(e for e in events if e.get("kill") == [5])
    assert kill["source"] == "control" and kill["t"] == 4
    assert any(e.get("move", {}).get("object") == "target" and e["source"] == "control" for e in events)
    # the exported [[events]] make the interactive run reproducible without the viewer
    raw = tomllib.loads(SCENARIO + "\n" + exported)
    assert [e for e in raw["events"] if "kill" in e] == [{"at": 4, "kill": [5]}]
    again = run(raw, name="again")

    def same_but_source(recs):  # the trace hash covers each event's source: "control" live, "scenario" now
        return [{**r, "ev": [{k: v for k, v in e.items() if k != "source"} for e in r.get("ev", [])]} for r in recs]

    assert len(again.trace) == len(records)
    assert same_but_source(again.trace) == same_but_source(records)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_remote_viewer_follows_and_controls_a_world_and_names_missing_runs(tmp_path):
    scenario = tmp_path / "far.toml"
    scenario.write_text(SCENARIO.replace("ticks = 40", "ticks = 200000").replace('"viewer"', '"far"'))
    endpoint = f"tcp/127.0.0.1:{_free_port()}"
    out = tmp_path / "out"
    world = _start(["world", str(scenario), "--listen", endpoint, "--run-id", "far1", "--out", str(out), "--quiet",
                    "--no-plots"], tmp_path / "world.log")
    # the host builds the scenario's test behaviours only because its operator allows their modules (docs/security.md)
    host = _start(["robots", "--connect", endpoint, "--run-id", "far1", "--allow", "tests_support",
                   "--allow", "viewer_support"], tmp_path / "host.log")
    view = None
    try:
        view = _start(["view", "--connect", endpoint, "--run", "far1", "--port", "0"], tmp_path / "view.log")
        url = _wait_url(view, tmp_path / "view.log")
        frame = _until(lambda: (f := _get(url, "api/frame"))["t"] is not None and f, what="a state")
        assert frame["run_id"] == "far1" and len(frame["robots"]) == 12
        # meanwhile, a viewer pointed at a run that does not exist says so, naming the runs that do
        missing = subprocess.Popen([sys.executable, "-m", "swarmactors", "view", "--connect", endpoint, "--run", "nope",
                                    "--port", "0"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                   env=_env())
        assert _post(url, {"cmd": "pause"})["ok"]
        paused_at = _until(lambda: (s := _get(url, "api/frame"))["paused"] and s["t"], what="paused")
        time.sleep(0.3)
        assert _get(url, "api/frame")["t"] == paused_at
        _, missing_err = missing.communicate(timeout=60)
        assert missing.returncode == 3
        assert "no run 'nope' answers at" in missing_err and "far1" in missing_err
        assert _post(url, {"cmd": "kill", "id": 2})["ok"]
        assert _post(url, {"cmd": "step"})["ok"]
        frame = _until(lambda: (f := _get(url, "api/frame"))["t"] == paused_at + 1 and f, what="the step")
        assert [d[0] for d in frame["dead"]] == [2] and 2 not in [r[0] for r in frame["robots"]]
        assert tomllib.loads(_get(url, "api/events.toml"))["events"][0]["kill"] == [2]
        assert not _get(url, "api/robot/3")["frames_available"]
        assert _post(url, {"cmd": "stop"})["ok"]
        world.wait(timeout=60)
        assert world.returncode == 0, (tmp_path / "world.log").read_text()
        _until(lambda: _get(url, "api/frame")["gone"], what="the viewer to notice the world is gone")
    finally:
        for p in (view, host, world):
            if p is not None and p.poll() is None:
                p.send_signal(signal.SIGINT)
                try:
                    p.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    p.kill()
    assert view.returncode == 0, (tmp_path / "view.log").read_text()
    result = Result.load(out)
    assert result.robots[2]["failed"]["cause"] == "killed"
    assert result["stop_reason"] == "stopped by control"
    events = [e for rec in result.trace for e in rec.get("ev", [])]
    assert any(e.get("kill") == [2] and e["source"] == "control" for e in events)


def test_viewer_of_an_unreachable_endpoint_says_so():
    endpoint = f"tcp/127.0.0.1:{_free_port()}"
    started = time.monotonic()
    proc = subprocess.run([sys.executable, "-m", "swarmactors", "view", "--connect", endpoint, "--port", "0"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 3
    assert f"cannot reach a Zenoh router or peer at {endpoint}" in proc.stderr
    assert time.monotonic() - started < 30


async def _raw_websocket(url: str):
    """A WebSocket opened by hand: the handshake, then nothing (the caller decides whether to read or vanish)."""
    base, token = url.split("?token=")
    host, port = base.split("//")[1].rstrip("/").split(":")
    reader, writer = await asyncio.open_connection(host, int(port))
    writer.write(f"GET /ws?token={token} HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\n"
                 "Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                 "Sec-WebSocket-Version: 13\r\n\r\n".encode())
    await writer.drain()
    status = await reader.readline()
    assert b" 101 " in status, status
    return reader, writer


async def test_pages_that_stall_or_leave_do_not_hold_the_run(tmp_path):
    """Three pages on an in-process run at full speed: one reads, one never reads, one leaves at once."""
    raw = tomllib.loads(SCENARIO.replace("ticks = 40", "ticks = 1500"))
    sc = resolve_scenario(raw, "<test>")
    server = ViewerServer("127.0.0.1", 0)
    frames: list[int] = []

    async def pages() -> None:
        while not server.url:  # noqa: ASYNC110 — ViewerServer offers no event for its start to await
            await asyncio.sleep(0.01)
        async with aiohttp.ClientSession() as http:
            stalled = await _raw_websocket(server.url)  # never reads a byte
            leaving = await _raw_websocket(server.url)
            leaving[1].transport.abort()  # vanishes without a goodbye
            async with http.ws_connect(f"{server.base}ws?token={server.token}") as ws:
                first = json.loads((await ws.receive()).data)
                assert first["type"] == "frame"
                await ws.send_json({"cmd": "speed", "rate": None, "id": 1})
                await ws.send_json({"cmd": "play", "id": 2})
                async for msg in ws:
                    doc = json.loads(msg.data)
                    if doc["type"] == "frame" and doc["t"] is not None:
                        frames.append(doc["t"])
                        if doc["mode"] == "replay":
                            break
            stalled[1].close()

    reader = asyncio.get_running_loop().create_task(pages())
    result = await run_with_viewer(server, sc, tmp_path, Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]),
                                   new_run_id("stall"), announce=lambda _: None)
    await asyncio.wait_for(reader, 30)
    await server.close()
    assert result["ticks"] == 1500
    assert frames[-1] == 1499  # the replay that follows the run starts at its end
    assert len(frames) < 1500  # frames the page had no time for were skipped, not queued
    assert frames == sorted(frames)


POINT_PIXEL = """([x, y]) => {
  const [sx, sy] = window.swarm.screenOfPoint(x, y);
  const c = document.getElementById('canvas'), r = c.getBoundingClientRect(), d = window.devicePixelRatio || 1;
  return Array.from(c.getContext('2d').getImageData(Math.round((sx - r.left) * d), Math.round((sy - r.top) * d),
                                                    1, 1).data);
}"""


def test_viewer_draws_the_maze_walls_where_the_world_has_them(tmp_path):
    """The maze flood in a real browser (issue 14).

    The grid map is fetched once and drawn: wall cells are grey on the page, corridor cells are not.
    """
    chromium = require_browser()
    from playwright.sync_api import sync_playwright

    scenario = Path(__file__).resolve().parent.parent / "scenarios" / "maze-flood.toml"
    log = tmp_path / "cli.log"
    proc = _start(["run", str(scenario), "--out", str(tmp_path / "out"), "--view", "--view-port", "0", "--quiet"],
                  log)
    sc = resolve_scenario(tomllib.loads(scenario.read_text()), str(scenario))
    rows = sc["world"]["map"]["layers"][0]["rows"]
    h = len(rows)
    wall = next((c + 0.5, h - r - 0.5) for r, row in enumerate(rows) for c, ch in enumerate(row) if ch == "@")
    robots = [tuple(p[:2]) for p in sc["robots"][0]["positions"]]
    free = next((c + 0.5, h - r - 0.5) for r, row in enumerate(rows) for c, ch in enumerate(row)
                if ch == "." and all(abs(c + 0.5 - x) > 1.0 or abs(h - r - 0.5 - y) > 1.0 for x, y in robots))
    try:
        url = _wait_url(proc, log)
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
            page = browser.new_page(viewport={"width": 1000, "height": 760})
            errors: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(url)
            page.wait_for_function("window.swarm && window.swarm.space && window.swarm.drawn.count > 1")
            assert page.evaluate("window.swarm.space.map.rows.length") == h
            r, g, b, alpha = page.evaluate(POINT_PIXEL, list(wall))
            assert alpha > 150 and max(r, g, b) < 140 and abs(r - g) < 10, (r, g, b, alpha)  # grey wall
            r, g, b, alpha = page.evaluate(POINT_PIXEL, list(free))
            assert alpha < 20 or min(r, g, b) > 200, (r, g, b, alpha)  # an empty corridor cell: nothing drawn
            assert not errors, errors
            # the address without its token: the page loads, says why it shows nothing, and draws nothing
            bare = browser.new_page()
            bare.goto(url.split("?")[0])
            bare.wait_for_function("document.getElementById('banner').textContent.includes('needs its token')")
            assert bare.evaluate("window.swarm.frame") is None
            browser.close()
    finally:
        proc.terminate()
        proc.wait(timeout=30)
