"""A robot that raises or blocks, a host that ends, and SIGINT lose nothing (issue 2, "Bad input" and "Faults").

* a behaviour that raises marks its robot failed as ``crashed``, with the
  exception's type and message in result.json, and the rest of the swarm goes on;
* a step that never ends trips the watchdog (``watchdog``), and the run goes on;
* a run whose robots live in host processes ends with no robot failed;
* SIGINT stops ``swarmactors run`` with exit 130, a partial result.json
  (``interrupted: true``) and a readable trace up to the interruption.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from swarmactors.oracle.trace import read_trace, verify

pytestmark = pytest.mark.slow  # every test runs a world over Zenoh

TICKS = 10
LINE = [[0.0, 0.0], [0.5, 0.0], [1.0, 0.0], [1.5, 0.0], [2.0, 0.0]]  # everyone hears everyone (range 2.5)
VICTIM = 2


def line_scenario(extra: dict, ticks: int = TICKS, **run) -> dict:
    return {
        "run": {"name": "robust", "ticks": ticks, **run},
        "radio": {"range": 2.5, "latency": 1},
        "robots": [{"positions": LINE, "behaviors": [{"use": "beacon"}, extra]}],
    }


def sent_by_tick(result, src: int) -> list[int]:
    return sorted(rec["t"] for rec in result.trace for row in rec.get("sent", ()) if row[0] == src)


def delivered_to(result, dst: int) -> list[int]:
    return sorted(rec["t"] for rec in result.trace for row in rec.get("del", ()) if row[2] == dst)


def assert_others_carried_on(result, victim: int, ticks: int = TICKS) -> None:
    assert result["ticks"] == ticks and not result["interrupted"]
    for rid, r in result.robots.items():
        if rid == victim:
            continue
        assert r["alive"] and r["failed"] is None, (rid, r["failed"])
        assert r["beacon"]["sent"] == ticks, (rid, r["beacon"])
        assert result.frames(rid)["sent"] == ticks, (rid, result.frames(rid))
        assert sent_by_tick(result, rid) == list(range(ticks))


# ---------------------------------------------------------------------------------------------
# 3. A behaviour that raises
# ---------------------------------------------------------------------------------------------

# hook -> the tick at which the robot fails (and so the number of beacons it sent before)
RAISE_AT = {"on_tick": 3, "async_on_tick": 3, "on_frame": 3, "on_start": 0}


@pytest.mark.parametrize("hook", list(RAISE_AT))
def test_behaviour_that_raises_crashes_only_its_robot(run, hook):
    result = run(line_scenario({"use": "behaviors_for_tests:Raiser", "who": VICTIM, "at": 3, "hook": hook}))
    crash_tick = RAISE_AT[hook]
    v = result.robots[VICTIM]
    assert not v["alive"]
    assert v["failed"]["cause"] == "crashed"
    assert v["failed"]["tick"] == crash_tick
    # the error text, with the exception's type and message, is in result.json
    assert "ValueError" in v["error"] and f"boom at tick {crash_tick}" in v["error"], v["error"]
    assert v["failed"]["error"] == v["error"]
    # the crashed robot's reports are kept ("loses nothing")
    assert "raiser" in v and "beacon" in v
    # it sent nothing from the crash on, and nothing was delivered to it after the crash
    assert sent_by_tick(result, VICTIM) == list(range(crash_tick))
    assert result.frames(VICTIM)["sent"] == crash_tick
    assert all(t <= crash_tick for t in delivered_to(result, VICTIM))
    if crash_tick < TICKS - 1:
        dead = [row for rec in result.trace for row in rec.get("drop", ()) if row[2] == VICTIM]
        assert dead and all(row[3] == "dead" for row in dead)
    # the event is in the trace
    evs = [ev for rec in result.trace for ev in rec.get("ev", ()) if ev.get("robot") == VICTIM]
    assert evs and evs[0]["failed"] == "crashed" and "boom" in evs[0]["error"]
    assert_others_carried_on(result, VICTIM)


def test_behaviour_that_raises_in_a_host_process(run):
    """The same with the robots in a spawned host process (K = 1)."""
    result = run(line_scenario({"use": "behaviors_for_tests:Raiser", "who": VICTIM, "at": 3}), processes=1)
    v = result.robots[VICTIM]
    assert v["failed"]["cause"] == "crashed" and v["failed"]["tick"] == 3
    assert "ValueError" in v["error"] and "boom at tick 3" in v["error"]
    assert sent_by_tick(result, VICTIM) == [0, 1, 2]
    assert [rid for rid, r in result.robots.items() if not r["alive"]] == [VICTIM]
    assert all(r["beacon"]["sent"] == TICKS for rid, r in result.robots.items() if rid != VICTIM)


def test_behaviour_that_raises_in_realtime(run):
    ticks = 15
    result = run(line_scenario({"use": "behaviors_for_tests:Raiser", "who": VICTIM, "at": 3}, ticks=ticks,
                               clock="realtime", dt=0.03))
    v = result.robots[VICTIM]
    assert not v["alive"] and v["failed"]["cause"] == "crashed"
    assert "ValueError" in v["error"] and "boom at tick 3" in v["error"]
    assert result.frames(VICTIM)["sent"] == 3  # ticks 0, 1, 2 (its tick-3 beacon went down with it)
    assert result["ticks"] == ticks
    for rid, r in result.robots.items():
        if rid != VICTIM:
            assert r["alive"], (rid, r["failed"])
            assert result.frames(rid)["sent"] >= ticks - 2, (rid, result.frames(rid))


def test_behaviour_whose_constructor_raises(run):
    """A robot whose behaviour cannot even be built is a crashed robot, not a crashed run."""
    raw = {
        "run": {"name": "robust", "ticks": TICKS, "join_timeout_s": 10},
        "radio": {"range": 2.5},
        "robots": [
            {"positions": LINE[:1], "behaviors": [{"use": "beacon"}, {"use": "behaviors_for_tests:RaiseInInit"}]},
            {"positions": LINE[1:], "behaviors": [{"use": "beacon"}]},
        ],
    }
    result = run(raw)
    v = result.robots[0]
    assert not v["alive"] and v["failed"]["cause"] == "crashed"
    assert "RuntimeError" in v["error"] and "cannot build this behaviour" in v["error"]
    assert sent_by_tick(result, 0) == []
    assert_others_carried_on(result, 0)


# ---------------------------------------------------------------------------------------------
# 4. A step that never ends: the watchdog
# ---------------------------------------------------------------------------------------------


def test_step_that_never_ends_trips_the_watchdog(run):
    t0 = time.monotonic()
    result = run(line_scenario({"use": "behaviors_for_tests:Hang", "who": VICTIM, "at": 3}, watchdog_s=0.5))
    wall = time.monotonic() - t0
    v = result.robots[VICTIM]
    assert not v["alive"]
    assert v["failed"]["cause"] == "watchdog" and v["failed"]["tick"] == 3
    assert "watchdog" in v["error"]
    assert v["hang"]["hung"] is True
    assert sent_by_tick(result, VICTIM) == [0, 1, 2]
    assert_others_carried_on(result, VICTIM)
    assert wall < 30, "the run waited far longer than the watchdog"


def test_step_that_never_ends_trips_the_watchdog_in_realtime(run):
    ticks = 20
    result = run(line_scenario({"use": "behaviors_for_tests:Hang", "who": VICTIM, "at": 3}, ticks=ticks,
                               clock="realtime", dt=0.05, watchdog_s=0.3))
    v = result.robots[VICTIM]
    assert not v["alive"]
    assert v["failed"]["cause"] == "watchdog", v["failed"]
    assert "watchdog" in v["error"]
    assert result["ticks"] == ticks
    assert all(r["alive"] for rid, r in result.robots.items() if rid != VICTIM)


# ---------------------------------------------------------------------------------------------
# Host processes that end normally
# ---------------------------------------------------------------------------------------------


def test_run_with_host_processes_ends_with_no_robot_failed(run):
    """Hosts leaving after the last tick end the run; they are not a crash.

    When hosts leave after the last tick (their liveliness tokens vanish), that is the end of the run,
    not a crash: no robot may be recorded as failed.
    """
    result = run(line_scenario({"use": "beacon", "size": 4}), processes=2)
    assert result["ticks"] == TICKS
    failed = {rid: r["failed"] for rid, r in result.robots.items() if r["failed"]}
    assert failed == {}, failed
    assert all(r["alive"] for r in result.robots.values())


# ---------------------------------------------------------------------------------------------
# 5. SIGINT
# ---------------------------------------------------------------------------------------------

LONG = """\
[run]
name = "long"
ticks = 1000000
[radio]
range = 0.75
[[robots]]
count = 30
placement = "grid"
spacing = 0.5
behaviors = [{ use = "beacon" }]
"""


def _interrupt(tmp_path: Path, processes: int) -> tuple[subprocess.CompletedProcess | None, Path, str]:
    """Interrupt ``swarmactors run`` on a long scenario as a terminal's Ctrl-C does.

    Start it, wait until it ticks, send SIGINT to its process group (what a terminal's Ctrl-C does),
    and wait for it to exit.
    """
    (tmp_path / "long.toml").write_text(LONG)
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "swarmactors", "-v", "run", "long.toml", "--out", str(out), "--quiet",
         "--processes", str(processes)],
        cwd=tmp_path, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True, start_new_session=True,
    )
    lines: list[str] = []
    joined = threading.Event()

    def drain() -> None:
        for line in proc.stderr:
            lines.append(line)
            if "joined" in line:
                joined.set()

    reader = threading.Thread(target=drain, daemon=True)
    reader.start()
    try:
        assert joined.wait(60), "the run never started: " + "".join(lines[-20:])
        time.sleep(1.0)  # let it tick for a while
        assert proc.poll() is None, "the long run ended by itself: " + "".join(lines[-20:])
        os.killpg(proc.pid, signal.SIGINT)
        proc.wait(timeout=40)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
        reader.join(5)
    return proc.returncode, out, "".join(lines)


@pytest.mark.parametrize("processes", [0, 1])
def test_sigint_stops_the_run_cleanly(tmp_path, processes):
    code, out, err = _interrupt(tmp_path, processes)
    assert code == 130, err[-3000:]
    # a partial result.json
    import json

    result = json.loads((out / "result.json").read_text())
    assert result["interrupted"] is True
    assert "interrupt" in (result["stop_reason"] or "")
    assert 0 < result["ticks"] < 1_000_000
    # the trace holds every tick up to the interruption, and its footer matches result.json
    header, records, footer = read_trace(out / result["trace"])
    assert header["run_id"] == result["run_id"]
    assert [r["t"] for r in records] == list(range(len(records)))
    assert footer is not None and footer["ticks"] == len(records)
    assert footer["trace_hash"] == result["trace_hash"] == verify(out / result["trace"])
    assert result["ticks"] == len(records), "result.json's tick count disagrees with the trace"
    # and no process (world or host) died with a traceback on the way
    assert "Traceback" not in err, err[-3000:]
