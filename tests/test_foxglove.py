"""Runs in Foxglove: ``export --format mcap`` read back with the mcap reader, and the live WebSocket feed.

The MCAP file is read back with the ``mcap`` library and its protobuf decoder (``mcap-protobuf-support``): the
messages per topic equal what the trace holds (one pose message per tick record, one log message per event,
...), the poses equal ``export --format csv``'s, times are the run's clock. The live feed is checked with a plain
WebSocket client (aiohttp) speaking the Foxglove WebSocket protocol: it subscribes and decodes the robots' poses.
"""

from __future__ import annotations

import asyncio
import csv
import json
import math
import os
import re
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path

import aiohttp
import pytest

from swarmactors.cli import main
from swarmactors.oracle.trace import TraceWriter, iter_offsets, iter_trace

pytest.importorskip("foxglove")
mcap_reader = pytest.importorskip("mcap.reader")
from mcap.records import Schema  # noqa: E402
from mcap_protobuf.decoder import DecoderFactory  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SUBPROTOCOLS = ("foxglove.websocket.v1", "foxglove.sdk.v1")  # the spec's name, and foxglove-sdk's own
URL = re.compile(r"foxglove: (ws://\S+)")
DT = 0.5
SCENARIO = {
    "run": {"name": "fx", "dt": DT, "clock": "lockstep"},
    "radio": {"range": 1.5, "latency": 1},
    "world": {"bounds": [[0.0, 0.0], [4.0, 4.0]], "objects": [{"name": "goal", "pos": [1.0, 1.0]}],
              "obstacles": [{"xy": [[2.0, 2.0], [3.0, 2.0], [3.0, 3.0]], "z": None}], "map": None},
    "robots": [{"positions": [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]], "heading": 0.5, "body_radius": 0.2,
                "behaviors": [{"use": "beacon", "as": "beacon"}]}],
}
RECORDS = [
    {"t": 0, "pos": [[0, 0.0, 0.0], [1, 1.0, 0.0], [2, 2.0, 0.0]], "status": {0: {"role": "a"}},
     "sent": [[0, 1, "HI", None, 3]]},
    {"t": 1, "pos": [[0, 0.0, 0.5], [1, 1.0, 0.0], [2, 2.0, 0.25]], "del": [[0, 1, 1, 0]], "ovh": [[0, 1, 2, 0]],
     "drop": [[0, 1, 2, "loss"]], "ev": [{"t": 1, "cut": [[0, 1]], "source": "scenario"}], "mal": ["bad frame"]},
    {"t": 2, "pos": [[0, 0.5, 0.5], [1, 1.0, 1.0]], "status": {1: {"role": "b", "n": 2}},
     "ev": [{"t": 2, "kill": [2], "source": "control"}, {"t": 2, "robot": 2, "failed": "killed"}]},
    {"t": 3, "pos": [[0, 0.5, 1.5], [1, 1.0, 1.0]], "ev": [{"t": 3, "move": {"object": "goal", "pos": [3.0, 3.0]},
                                                          "source": "control"}]},
    {"t": 4, "pos": [[0, 0.5, 2.0]], "ev": [{"t": 3, "robot": 1, "failed": "crashed", "error": "ZeroDivisionError"}],
     "sent": [[0, 2, "HI", None, 3]], "drop": [[0, 2, 1, "dead"]]},
]


def _write_run(folder: Path, records=RECORDS, result: bool = True) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    w = TraceWriter(folder / "trace.msgpack", {"run_id": "fx-1", "clock": "lockstep", "seed": 0, "pos_digits": 6,
                                               "scenario": SCENARIO})
    for rec in records:
        w.record(rec)
    w.close()
    if result:
        robots = {str(i): {"range": 1.5, "alive": i == 0, "log": [f"[{i + 1}] hello from {i}"], "beacon": {"n": i}}
                  for i in range(3)}
        (folder / "result.json").write_text(json.dumps({"run_id": "fx-1", "robots": robots,
                                                        "world": {"deliveries": 1}, "checks": []}))
    return folder


def _decoders():
    factory, cache = DecoderFactory(), {}

    def decode(schema_name: str, encoding: str, schema: bytes, data: bytes):
        if encoding == "json":
            return json.loads(data)
        if schema_name not in cache:
            record = Schema(id=len(cache) + 1, name=schema_name, encoding="protobuf", data=schema)  # the factory
            cache[schema_name] = factory.decoder_for("protobuf", record)  # keeps one decoder per schema id
        return cache[schema_name](data)

    return decode


def read_mcap(path: Path) -> dict[str, list]:
    """Topic -> [(log time, decoded message)] in log-time order, read with the mcap library."""
    decode, out = _decoders(), {}
    with path.open("rb") as f:
        reader = mcap_reader.make_reader(f)
        for schema, channel, message in reader.iter_messages(log_time_order=True):
            out.setdefault(channel.topic, []).append(
                (message.log_time, decode(schema.name, channel.message_encoding, schema.data, message.data)))
    return out


def _yaw(q) -> float:
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


def _poses_equal_the_csv(got: dict, csv_path: Path, dt: float) -> int:
    """Every /tf transform equals the row of the poses table (x, y, heading); returns the rows compared."""
    rows = list(csv.DictReader(csv_path.open()))
    table = {(int(r["tick"]), int(r["id"])): r for r in rows}
    seen = 0
    for (ns, tf), (ns2, poses) in zip(got["/tf"], got["/robots/poses"], strict=True):
        assert ns == ns2
        assert len(tf.transforms) == len(poses.poses)
        for t, pose in zip(tf.transforms, poses.poses, strict=True):
            tick, rid = round(ns / 1e9 / dt), int(t.child_frame_id.removeprefix("robot/"))
            row = table[tick, rid]
            assert t.parent_frame_id == "world"
            assert (t.translation.x, t.translation.y) == (float(row["x"]), float(row["y"]))
            assert (pose.position.x, pose.position.y) == (float(row["x"]), float(row["y"]))
            if row["heading"]:
                assert _yaw(t.rotation) == pytest.approx(float(row["heading"]), abs=1e-12)
                assert _yaw(pose.orientation) == pytest.approx(float(row["heading"]), abs=1e-12)
            else:
                assert (t.rotation.z, t.rotation.w) == (0.0, 1.0)  # unknown heading: identity
            seen += 1
    assert seen == len(rows)
    return seen


def _trace_counts(trace: Path) -> dict:
    ticks = events = status = deliveries = 0
    for obj in iter_trace(trace):
        if "t" in obj and not obj.get("end"):
            ticks += 1
            events += len(obj.get("ev", [])) + len(obj.get("mal", []))
            status += bool(obj.get("status"))
            deliveries += len(obj.get("del", []))
    return {"ticks": ticks, "events": events, "status": status, "deliveries": deliveries}


def test_mcap_holds_what_the_trace_holds(tmp_path, capsys):
    run = _write_run(tmp_path / "run")
    assert main(["export", str(run), "--format", "mcap"]) == 0
    assert capsys.readouterr().out.strip() == str(run / "run.mcap")
    assert main(["export", str(run), "--format", "csv", "--out", str(tmp_path / "csv")]) == 0
    got = read_mcap(run / "run.mcap")
    n = _trace_counts(run / "trace.msgpack")
    for topic in ("/tf", "/robots/poses", "/radio/links", "/radio/frames", "/radio/counts"):
        assert len(got[topic]) == n["ticks"] == 5, topic
    assert [ns for ns, _ in got["/tf"]] == [round(t * DT * 1e9) for t in range(5)]  # the run's clock
    assert len(got["/robots/status"]) == n["status"] == 2
    assert got["/robots/status"][1][1] == {"tick": 2, "robots": [{"id": 1, "role": "b", "n": 2}]}
    assert _poses_equal_the_csv(got, tmp_path / "csv" / "poses.csv", DT) == 3 + 3 + 2 + 2 + 1

    logs = [(ns, m.level, m.name, m.message) for ns, m in got["/events"]]
    assert len(logs) == n["events"] == 6
    by_text = {text: (ns, level, name) for ns, level, name, text in logs}
    assert by_text["robot 2 killed"] == (round(2 * DT * 1e9), 3, "robot/2")  # level 3: warning
    assert by_text["robot 1 crashed: ZeroDivisionError"] == (round(3 * DT * 1e9), 4, "robot/1")  # its own tick
    assert by_text["malformed input: bad frame"][1] == 3
    assert 'cut [[0, 1]] (scenario)' in by_text and 'kill [2] (control)' in by_text

    counts = [m for _, m in got["/radio/counts"]]
    assert [c["delivered"] for c in counts] == [0, 1, 0, 0, 0]
    assert counts[-1]["total"] == {"sent": 2, "delivered": 1, "overheard": 1, "malformed": 1,
                                   "dropped": {"range": 0, "loss": 1, "cut": 0, "occluded": 0, "bandwidth": 0,
                                               "dead": 1, "deferred_too_long": 0, "below_sensitivity": 0,
                                               "collision": 0}}
    frames = got["/radio/frames"][1][1].entities[0].lines
    assert [list(line.indices) for line in frames] == [[0, 1], [0, 2], [0, 2]]  # delivered, overheard, lost
    assert [p.x for p in frames[0].points] == [0.0, 1.0, 2.0]  # the robots' points, which the indices name

    world = got["/world"]
    assert [round(ns / 1e9 / DT) for ns, _ in world] == [0, 3]  # at the start, and when the goal moved
    ids = {e.id: e for e in world[-1][1].entities}
    assert set(ids) == {"bounds", "obstacles", "objects"}
    assert (ids["objects"].cubes[0].pose.position.x, ids["objects"].texts[0].text) == (3.0, "goal")
    assert len(ids["obstacles"].triangles[0].points) == 3 * (2 + 2 * 3)  # a triangle, extruded: 8 triangles

    last_bodies = {e.id for e in got["/robots/bodies"][-1][1].entities}
    assert last_bodies == {"robot/0", "failed/1", "failed/2"}
    assert got["/robots/bodies"][0][1].entities[0].spheres[0].size.x == pytest.approx(0.4)  # body_radius 0.2

    (ns, result), = got["/run/result"]
    assert ns == round(4 * DT * 1e9) and [r["beacon"] for r in result["robots"]] == [{"n": 0}, {"n": 1}, {"n": 2}]
    assert sorted((round(ns / 1e9 / DT), m.message) for ns, m in got["/robots/log"]) == [
        (1, "[1] hello from 0"), (2, "[2] hello from 1"), (3, "[3] hello from 2")]


def test_mcap_metadata_names_the_run(tmp_path):
    run = _write_run(tmp_path / "run", result=False)
    assert main(["export", str(run / "trace.msgpack"), "--format", "mcap", "--out", str(tmp_path / "o")]) == 0
    with (tmp_path / "o" / "run.mcap").open("rb") as f:
        reader = mcap_reader.make_reader(f)
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
        assert reader.get_summary().statistics.message_count > 0
    assert meta["run"]["run_id"] == "fx-1" and json.loads(meta["run"]["scenario"])["run"]["dt"] == DT
    assert "/run/result" not in read_mcap(tmp_path / "o" / "run.mcap")  # no result.json: no result topic


@pytest.mark.parametrize("cut", ["truncated", "corrupt"])
def test_a_bad_trace_is_exit_2_naming_the_file_and_leaves_no_file(tmp_path, capsys, cut):
    run = _write_run(tmp_path / "run", result=False)
    trace = run / "trace.msgpack"
    data = trace.read_bytes()
    at = [offset for offset, _ in iter_offsets(trace)][3]  # the third tick record
    trace.write_bytes(data[:-40] if cut == "truncated" else data[:at] + b"\xc1" + data[at + 1:])
    assert main(["export", str(run), "--format", "mcap"]) == 2
    err = capsys.readouterr().err
    assert str(trace) in err and "byte offset" in err and len(err.strip().splitlines()) == 1
    assert sorted(p.name for p in run.iterdir()) == ["trace.msgpack"]  # neither run.mcap nor a partial one


def test_without_the_extra_export_and_foxglove_say_what_to_install(tmp_path, capsys, monkeypatch):
    run = _write_run(tmp_path / "run", result=False)
    monkeypatch.setitem(sys.modules, "foxglove", None)  # import foxglove fails
    assert main(["export", str(run), "--format", "mcap"]) == 2
    assert "pip install 'swarmactors[foxglove]'" in capsys.readouterr().err
    assert main(["replay", str(run), "--foxglove", "0"]) == 2
    assert "pip install 'swarmactors[foxglove]'" in capsys.readouterr().err
    assert main(["run", str(ROOT / "scenarios" / "flooding.toml"), "--foxglove"]) == 2
    assert "pip install 'swarmactors[foxglove]'" in capsys.readouterr().err


def test_bad_foxglove_options_are_exit_2(tmp_path, capsys):
    run = _write_run(tmp_path / "run", result=False)
    assert main(["replay", str(run), "--foxglove", "70000"]) == 2
    assert "--foxglove 70000" in capsys.readouterr().err
    assert main(["replay", str(run), "--foxglove", "0", "--rate", "0"]) == 2
    assert "--rate 0" in capsys.readouterr().err
    assert main(["run", str(ROOT / "scenarios" / "flooding.toml"), "--foxglove", "--view"]) == 2
    assert "choose one" in capsys.readouterr().err


# ---------------------------------------------------------------- the live feed
class FoxgloveClient:
    """A minimal Foxglove WebSocket protocol client: channels from ``advertise``, binary ``messageData``."""

    def __init__(self, ws):
        self.ws, self.channels, self.subs = ws, {}, {}
        self.decode = _decoders()

    async def advertised(self, topic: str) -> dict:
        while topic not in self.channels:
            msg = await asyncio.wait_for(self.ws.receive(), 10)
            if msg.type == aiohttp.WSMsgType.TEXT and json.loads(msg.data)["op"] == "advertise":
                self.channels.update({c["topic"]: c for c in json.loads(msg.data)["channels"]})
        return self.channels[topic]

    async def subscribe(self, *topics: str) -> None:
        subs = []
        for topic in topics:
            channel = await self.advertised(topic)
            self.subs[len(self.subs) + 1] = channel
            subs.append({"id": len(self.subs), "channelId": channel["id"]})
        await self.ws.send_str(json.dumps({"op": "subscribe", "subscriptions": subs}))

    async def message(self) -> tuple[str, int, object]:
        """The next message on a subscribed channel: (topic, log time in ns, decoded), within 30 s."""
        while True:
            msg = await asyncio.wait_for(self.ws.receive(), 30)
            assert msg.type in (aiohttp.WSMsgType.TEXT, aiohttp.WSMsgType.BINARY), msg
            if msg.type == aiohttp.WSMsgType.BINARY and msg.data[0] == 1:  # messageData
                sub, ns = struct.unpack_from("<IQ", msg.data, 1)
                c = self.subs[sub]
                return c["topic"], ns, self.decode(c["schemaName"], c["encoding"], _schema_bytes(c), msg.data[13:])


def _schema_bytes(channel: dict) -> bytes:
    import base64

    return base64.b64decode(channel["schema"]) if channel.get("schemaEncoding") == "protobuf" else b""


async def test_a_replay_played_live_sends_every_tick_as_the_mcap_holds_it(tmp_path):
    from swarmactors.tools.foxglove_live import FoxgloveFeed

    run = _write_run(tmp_path / "run")
    assert main(["export", str(run), "--format", "mcap"]) == 0
    want = read_mcap(run / "run.mcap")
    feed = FoxgloveFeed("127.0.0.1", 0)
    url = feed.start()
    try:
        feed.play(run / "trace.msgpack", rate=50.0)
        async with aiohttp.ClientSession() as session, session.ws_connect(url, protocols=SUBPROTOCOLS) as ws:
            client = FoxgloveClient(ws)
            await client.subscribe("/tf", "/events", "/radio/counts")
            got: dict[str, list] = {}
            while len(got.get("/radio/counts", [])) < 5:
                topic, ns, msg = await client.message()
                got.setdefault(topic, []).append((ns, msg))
    finally:
        await feed.close()
    assert [ns for ns, _ in got["/tf"]] == [ns for ns, _ in want["/tf"]]
    assert [str(m) for _, m in got["/tf"]] == [str(m) for _, m in want["/tf"]]  # two decoders: compare as text
    assert [m.message for _, m in got["/events"]] == [m.message for _, m in want["/events"]]
    assert [m for _, m in got["/radio/counts"]] == [m for _, m in want["/radio/counts"]]


LIVE = """
[run]
name = "fxlive"
seed = 3
ticks = 300
clock = "realtime"
dt = 0.05

[radio]
range = 2.0

[world]
bounds = [[0.0, 0.0], [6.0, 6.0]]

[[robots]]
count = 6
placement = "uniform"
behaviors = [{ use = "random_walk", area = [[0.0, 0.0], [6.0, 6.0]], speed = 0.5 }, { use = "beacon" }]
"""


@pytest.mark.slow
def test_a_running_swarm_is_served_live_to_a_websocket_client(tmp_path):
    """``run --foxglove 0``: a client subscribes to /tf and receives the moving robots' poses while it runs."""
    scenario = tmp_path / "live.toml"
    scenario.write_text(LIVE)
    log = tmp_path / "stderr.txt"
    proc = subprocess.Popen([sys.executable, "-m", "swarmactors", "run", str(scenario), "--foxglove", "0",
                             "--out", str(tmp_path / "out"), "--quiet", "--no-plots"],
                            stdout=subprocess.DEVNULL, stderr=log.open("w"), env=dict(os.environ))
    try:
        deadline = time.monotonic() + 60
        while not URL.search(log.read_text()):
            assert proc.poll() is None and time.monotonic() < deadline, log.read_text()
            time.sleep(0.05)
        url = URL.search(log.read_text()).group(1)
        assert url.startswith("ws://127.0.0.1:")  # loopback unless told otherwise

        async def watch() -> list:
            async with aiohttp.ClientSession() as session, session.ws_connect(url, protocols=SUBPROTOCOLS) as ws:
                client = FoxgloveClient(ws)
                await client.subscribe("/tf")
                return [await client.message() for _ in range(10)]

        got = asyncio.run(watch())
        assert proc.poll() is None  # received while the swarm runs
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=30)
    times = [ns for _, ns, _ in got]
    assert times == sorted(times) and times[-1] > times[0]  # the run's clock goes on
    positions = []
    for topic, _, msg in got:
        assert topic == "/tf"
        frames = {t.child_frame_id: (t.translation.x, t.translation.y) for t in msg.transforms}
        assert set(frames) == {f"robot/{i}" for i in range(6)}
        assert all(0.0 <= x <= 6.0 and 0.0 <= y <= 6.0 for x, y in frames.values())
        positions.append(frames)
    assert positions[0] != positions[-1]  # the robots moved between the first and the last message


@pytest.mark.slow
def test_a_real_run_exported_to_mcap_matches_its_trace_and_csv(tmp_path):
    out = tmp_path / "flood"
    code = main(["run", str(ROOT / "scenarios" / "flooding.toml"), "--out", str(out), "--quiet", "--no-plots",
                 "--set", "radio.loss=0.2", "--set", "run.ticks=10"])
    assert code in (0, 1)
    assert main(["export", str(out), "--format", "mcap"]) == 0
    assert main(["export", str(out), "--format", "csv"]) == 0
    got = read_mcap(out / "run.mcap")
    n = _trace_counts(out / "trace.msgpack")
    assert {len(got[t]) for t in ("/tf", "/robots/poses", "/radio/links", "/radio/counts")} == {n["ticks"]}
    assert len(got.get("/robots/status", [])) == n["status"]
    assert len(got.get("/events", [])) == n["events"]
    result = json.loads((out / "result.json").read_text())
    total = got["/radio/counts"][-1][1]["total"]
    assert total["delivered"] == n["deliveries"] == result["world"]["deliveries"]
    assert total["sent"] == result["world"]["frames_sent"]
    assert _poses_equal_the_csv(got, out / "poses.csv", 1.0) > 0
