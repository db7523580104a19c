"""Replays (page API, animations, [[events]] export), per-run charts, and bad trace files."""

from __future__ import annotations

import asyncio
import shutil
import tomllib
from pathlib import Path

import aiohttp
import msgpack
import pytest
from PIL import Image

from swarmactors import Behavior
from swarmactors.cli import main
from swarmactors.runs.launcher import new_run_id, run_world
from swarmactors.runs.scenario import resolve_scenario
from swarmactors.tools.replay import Replay
from swarmactors.tools.viewer import ReplaySource, ViewerServer
from transport import Endpoints, unpack

pytestmark = pytest.mark.slow  # every test runs a world over Zenoh (or replays the trace of one)

WALK = {
    "run": {"name": "walk", "seed": 9, "ticks": 30},
    "world": {"bounds": [[0.0, 0.0], [4.0, 4.0]]},
    "robots": [{"count": 10, "placement": "grid", "spacing": 0.8, "area": [[0.5, 0.5], [4.0, 4.0]], "speed": 0.2,
                "behaviors": [{"use": "tests_support:RandomWalk"}]}],
}


class Roles(Behavior):
    """Robots take turns: leader, then relay, then free (a role timeline to chart)."""

    name = "roles"
    plot_field = "role"

    def on_tick(self, ctx, sensed) -> None:
        ctx.set_status(role=("leader", "relay", "free")[(ctx.tick + ctx.id) // 4 % 3])


async def test_replay_shows_the_live_positions_at_intermediate_ticks(tmp_path):
    """Positions seen live on the world's state stream equal the replay's, at ticks in any seek order.

    A robot killed through control is drawn alive before and failed after, and its kill exports as [[events]].
    """
    sc = resolve_scenario(WALK, "<test>")
    live: dict[int, dict[int, list[float]]] = {}
    killed_at: dict = {}

    def on_open(world, link) -> None:
        def on_state(_key, payload) -> None:
            msg = unpack(payload)
            live[msg["t"]] = {row[0]: row[1:3] for row in msg["pos"]}

        link.subscribe(world.keys.state, on_state)

        async def control(cmd: str, **fields):
            return unpack(await link.query(world.keys.control, msgpack.packb({"cmd": cmd, **fields})))

        async def kill_later() -> None:  # pause, kill, resume: the kill lands mid-run whatever the speed
            assert (await control("run_to", tick=12))["ok"]
            while world.tick < 11:  # noqa: ASYNC110 — World offers no event per tick to await
                await asyncio.sleep(0.001)
            killed_at["reply"] = await control("kill", args=[4])
            assert (await control("resume"))["ok"]

        asyncio.get_running_loop().create_task(kill_later())

    result = await run_world(sc, tmp_path, Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]), new_run_id("walk"),
                             on_open=on_open)
    assert killed_at["reply"]["ok"]
    death = result.robots[4]["failed"]["tick"]
    assert result.robots[4]["failed"]["cause"] == "killed" and death == 12
    ticks = [t for t in (17, 3, 26, 11, 22, 6) if t in live]
    assert len(ticks) >= 5, sorted(live)  # the local state stream lost (almost) nothing
    server = ViewerServer("127.0.0.1", 0, ReplaySource(Replay(result.trace_path)))
    await server.start()
    url = server.base
    try:
        async with aiohttp.ClientSession(headers={"X-Swarmactors-Token": server.token}) as http:
            for t in ticks:  # forwards and backwards: checkpoints must not leak state between seeks
                async with http.post(url + "api/command", json={"cmd": "seek", "t": t}) as r:
                    assert (await r.json())["ok"]
                async with http.get(url + "api/frame") as r:
                    frame = await r.json()
                assert frame["mode"] == "replay" and frame["t"] == t
                assert {row[0]: row[1:3] for row in frame["robots"]} == live[t], t
                assert all(row[3] == 1.0 for row in frame["robots"])  # ranges from result.json
            before, after = [await (await http.get(f"{url}api/frame?t={t}")).json() for t in (death - 1, death)]
            assert 4 in [r[0] for r in before["robots"]] and not before["dead"]
            assert after["dead"] == [[4, *live[death - 1][4], "killed", death]]
            async with http.get(url + "api/robot/4") as r:
                detail = await r.json()
            assert detail["status"]["moved"] is not None and detail["frames_available"]
            async with http.get(url + "api/events.toml") as r:
                assert {"at": death, "kill": [4]} in tomllib.loads(await r.text())["events"]
    finally:
        await server.close()


def test_replay_events_prints_the_control_actions(tmp_path, capsys):
    from swarmactors.oracle.trace import TraceHasher

    hasher = TraceHasher()
    trace = tmp_path / "trace.msgpack"
    with open(trace, "wb") as f:
        for obj in ({"trace": "swarmactors", "version": 1, "run_id": "x", "clock": "lockstep", "seed": 1,
                     "scenario": {}},
                    {"t": 0, "pos": [[0, 0.0, 0.0], [1, 1.0, 0.0]]},
                    {"t": 1, "pos": [[0, 0.0, 0.0]], "ev": [{"t": 1, "kill": [1], "source": "control"},
                                                          {"t": 1, "robot": 1, "failed": "killed"}]},
                    {"t": 2, "pos": [[0, 0.0, 0.0]], "ev": [{"t": 2, "loss": 0.25, "source": "control"},
                                                          {"t": 2, "cut": [[0, 1]], "source": "scenario"}]},
                    {"end": True, "ticks": 3, "trace_hash": None}):
            if obj.get("end"):  # the real hash of the records above: the replay verifies it
                obj["trace_hash"] = hasher.hexdigest()
            elif "t" in obj:
                hasher.update(obj)
            f.write(msgpack.packb(obj))
    assert main(["replay", str(trace), "--events"]) == 0
    out = capsys.readouterr().out
    assert tomllib.loads(out)["events"] == [{"at": 1, "kill": [1]}, {"at": 2, "loss": 0.25}]  # tomli_w wrote it
    assert "cut" not in out  # scenario events are in the scenario already


@pytest.fixture(scope="module")
def walk_trace(tmp_path_factory):
    from conftest import run_scenario

    out = tmp_path_factory.mktemp("walk")
    raw = {**WALK, "run": {**WALK["run"], "ticks": 10}}
    return run_scenario(raw, out).trace_path


@pytest.mark.parametrize("every,frames", [(1, 10), (4, 4)])  # ticks 0-9; every 4: 0, 4, 8 and the last, 9
def test_gif_has_one_frame_per_rendered_tick(walk_trace, tmp_path, capsys, every, frames):
    gif = tmp_path / "walk.gif"
    assert main(["replay", str(walk_trace), "--gif", str(gif), "--every", str(every)]) == 0
    assert f"({frames} frames)" in capsys.readouterr().err
    with Image.open(gif) as img:
        assert img.n_frames == frames
        assert img.size[0] > 200 and img.size[1] > 200


@pytest.mark.skipif(shutil.which("ffmpeg") is not None, reason="ffmpeg is installed: MP4 output works")
def test_mp4_without_ffmpeg_says_what_is_missing(walk_trace, tmp_path, capsys):
    assert main(["replay", str(walk_trace), "--mp4", str(tmp_path / "a.mp4")]) == 2
    assert "ffmpeg" in capsys.readouterr().err
    assert not (tmp_path / "a.mp4").exists()


def _record_offsets(path) -> list[int]:
    with open(path, "rb") as f:
        unpacker = msgpack.Unpacker(f, raw=False, strict_map_key=False)
        offsets = []
        while True:
            offsets.append(unpacker.tell())
            try:
                unpacker.unpack()
            except msgpack.OutOfData:
                return offsets[:-1]


@pytest.mark.parametrize("damage", ["truncated", "corrupt"])
def test_a_damaged_trace_is_named_with_its_offset(walk_trace, tmp_path, capsys, damage):
    data = walk_trace.read_bytes()
    start = _record_offsets(walk_trace)[6]  # header, then tick records 0-4: damage tick 5's record
    bad = tmp_path / "trace.msgpack"
    if damage == "truncated":
        bad.write_bytes(data[: start + 7])
        expected = f"{bad}: truncated record at byte offset {start}"
    else:
        bad.write_bytes(data[:start] + b"\xc1" + data[start + 1:])  # 0xc1: never used by msgpack
        expected = f"{bad}: corrupt data at byte offset {start}"
    for args in (["--gif", str(tmp_path / "x.gif")], ["--view", "--port", "0"], ["--events"]):
        assert main(["replay", str(bad), *args]) == 2, args
        err = capsys.readouterr().err
        assert expected in err, (args, err)
    assert not (tmp_path / "x.gif").exists()


def test_run_writes_charts_beside_result(tmp_path, run):
    from swarmactors.tools.charts import write_charts

    flood = run({"run": {"name": "f", "seed": 2, "ticks": 9},
                 "robots": [{"count": 8, "placement": "line", "spacing": 0.9,
                             "behaviors": [{"use": "flooding", "origin": 0, "at": 1, "expiry": 6}]}]}, name="f")
    paths = write_charts(flood, flood.path.parent, "hop")
    assert sorted(p.name for p in paths) == ["connectivity.png", "convergence.png", "messages.png"]
    roles = run({"run": {"name": "r", "seed": 2, "ticks": 12},
                 "robots": [{"count": 6, "placement": "line", "behaviors": [{"use": "test_replay:Roles"}]}]},
                name="r")
    paths = write_charts(roles, roles.path.parent, "role")
    assert sorted(p.name for p in paths) == ["connectivity.png", "convergence.png", "messages.png", "roles.png"]
    for p in paths:
        with Image.open(p) as img:
            assert img.format == "PNG" and img.size[0] > 400


# ------------------------------------------------------------------------------------------------ verification
def _small_trace(tmp_path: Path) -> Path:
    from swarmactors.runs.launcher import run

    result = run({"run": {"name": "verify", "ticks": 4},
                  "robots": [{"count": 3, "placement": "line", "behaviors": [{"use": "beacon"}]}]},
                 out=tmp_path / "run", processes=0)
    return result.trace_path


def _rewrite(path: Path, edit) -> Path:
    """A copy of the trace with ``edit(objects)`` applied to its list of maps."""
    with open(path, "rb") as f:
        objs = list(msgpack.Unpacker(f, raw=False, strict_map_key=False))
    edit(objs)
    out = path.with_name("edited.msgpack")
    out.write_bytes(b"".join(msgpack.packb(o) for o in objs))
    return out


@pytest.mark.slow
def test_an_edited_record_or_header_is_refused_on_replay_unless_told_to_proceed(tmp_path):
    from swarmactors.oracle.trace import TraceError, verify
    from swarmactors.tools.replay import Replay

    trace = _small_trace(tmp_path)
    assert verify(trace) and Replay(trace).note is None

    def move_robot(objs):
        objs[2]["pos"][0][1] += 0.5

    def rename_run(objs):
        objs[0]["scenario"]["run"]["name"] = "other"

    for edit, words in ((move_robot, "hash mismatch"), (rename_run, "header does not match")):
        edited = _rewrite(trace, edit)
        with pytest.raises(TraceError, match=words):
            verify(edited)
        with pytest.raises(TraceError, match="--no-verify"):
            Replay(edited)
        assert words in Replay(edited, verify=False).note


@pytest.mark.parametrize("record,words", [
    ({"t": 1, "pos": "nowhere"}, "'pos' is a str"),
    ({"t": 1, "pos": [[0, "x", 1.0]]}, "not a number"),
    ({"t": 1, "sent": [[0, 1]]}, "'sent' holds"),
    ({"t": 1, "status": [1, 2]}, "'status'"),
    ({"t": 1, "ev": {"kill": 1}}, "'ev' is not a list"),
])
def test_a_record_of_the_wrong_shape_is_an_error_with_its_offset(tmp_path, record, words):
    from swarmactors.cli import main
    from swarmactors.oracle.trace import TraceError, read_trace

    path = tmp_path / "trace.msgpack"
    head = msgpack.packb({"trace": "swarmactors", "version": 1, "run_id": "x", "scenario": {}})
    first = msgpack.packb({"t": 0, "pos": [[0, 0.0, 0.0]]})
    path.write_bytes(head + first + msgpack.packb(record))
    with pytest.raises(TraceError) as err:
        read_trace(path)
    assert f"byte offset {len(head) + len(first)}" in str(err.value) and words in str(err.value)
    assert main(["replay", str(path), "--events"]) == 2


@pytest.mark.slow
def test_an_edited_result_json_is_an_error_naming_the_file_not_a_traceback(tmp_path, capsys):
    import json

    from swarmactors.oracle.result import Result, ResultError
    from swarmactors.tools.replay import Replay

    trace = _small_trace(tmp_path)
    result_path = trace.parent / "result.json"
    data = json.loads(result_path.read_text())
    data["robots"] = ["not", "a", "map"]
    result_path.write_text(json.dumps(data))
    with pytest.raises(ResultError, match="'robots' is a list"):
        Result.load(result_path)
    assert main(["export", str(result_path), "--format", "csv", "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert "result.json" in err and "Traceback" not in err
    assert Replay(trace).result is None  # the replay shows the trace alone
