"""A radio rule from outside the project: one file plus one entry-point line (docs/radio-rules.md).

The example rule of docs/examples/long_frames (drop a frame longer than ``max_bytes`` to a receiver farther
than ``beyond``) is registered here the way pip registers a package's entry points: a ``.dist-info`` directory
with an ``entry_points.txt`` on ``sys.path``. Nothing in world/ or transport/ names it. Checked: the rule's
drops against a brute-force reading of the trace (every long frame beyond the distance dropped as
``long-frame``, no other pair), in process and over Zenoh with the same trace hash; ``before`` puts it ahead
of a built-in rule; bad ``[[radio.rules]]`` tables are refused naming file and key.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np
import pytest

import swarmactors
from swarmactors.runs.inprocess import run_inprocess
from swarmactors.runs.scenario import ScenarioError, resolve
from transport.scenario import Radio
from world import Medium, Outgoing
from world.linkrules import registered
from world.sensing import within

EXAMPLE = Path(__file__).resolve().parents[1] / "docs" / "examples" / "long_frames"
MAX_BYTES, BEYOND = 32, 0.6


@pytest.fixture
def long_frames(tmp_path, monkeypatch):
    """The example rule installed as a package would be: its module on the path, its entry point registered."""
    dist = tmp_path / "site" / "long_frames_example-1.0.dist-info"
    dist.mkdir(parents=True)
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: long-frames-example\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text('[swarmactors.radio_rules]\nlong-frames = long_frames:LongFrames\n')
    monkeypatch.syspath_prepend(str(EXAMPLE))
    monkeypatch.syspath_prepend(str(tmp_path / "site"))
    registered.cache_clear()
    yield
    registered.cache_clear()


def scenario(**rule) -> dict:
    """Two groups of beacons: short (8-byte payload) and long (64-byte) bodies, the rule added before loss."""
    return {
        "run": {"name": "long-frames", "seed": 3, "ticks": 12},
        "radio": {"range": 1.2, "loss": 0.1, "rules": [{"use": "long-frames", "max_bytes": MAX_BYTES,
                                                        "beyond": BEYOND, "before": "loss", **rule}]},
        "robots": [
            {"count": 6, "placement": "grid", "spacing": 0.4, "behaviors": [{"use": "beacon", "size": 8}]},
            {"positions": [[0.2 + 0.4 * (i % 3), 0.2 + 0.4 * (i // 3)] for i in range(6)],
             "behaviors": [{"use": "beacon", "size": 64}]},
        ],
        "checks": [],
    }


def outcomes(trace: list[dict]) -> tuple[dict, dict]:
    """Per (src, seq, dst): the drop cause or "del"; and per (src, seq): (body size, send tick, sender position)."""
    fate, sent = {}, {}
    for rec in trace:
        pos = {row[0]: row[1:] for row in rec.get("pos", [])}
        for src, seq, _kind, _dst, size in rec.get("sent", []):
            sent[src, seq] = (size, rec["t"], pos)
        for src, seq, dst, cause in rec.get("drop", []):
            fate[src, seq, dst] = cause
        for src, seq, dst, _t in rec.get("del", []):
            fate[src, seq, dst] = "del"
    return fate, sent


def check_rule_drops(trace: list[dict]) -> int:
    """Every long frame to a receiver beyond BEYOND is dropped as long-frame, and nothing else is; the count."""
    fate, sent = outcomes(trace)
    n = 0
    for (src, seq, dst), what in fate.items():
        size, _t, pos = sent[src, seq]
        should = size > MAX_BYTES and math.dist(pos[src], pos[dst]) > BEYOND
        assert (what == "long-frame") == should, (src, seq, dst, what, size)
        n += should
    return n


def test_the_example_rule_drops_exactly_the_long_frames_beyond_its_distance(long_frames, tmp_path):
    result = run_inprocess(scenario(), out=tmp_path / "inproc")
    dropped = check_rule_drops(result.trace)
    assert dropped > 0 and result["world"]["dropped"]["long-frame"] == dropped
    assert result["world"]["dropped"]["loss"] > 0  # the built-in rules still run


@pytest.mark.slow
def test_the_rule_runs_the_same_over_zenoh(long_frames, tmp_path, monkeypatch):
    monkeypatch.setenv("PYTHONPATH", f"{EXAMPLE}:{tmp_path / 'site'}")
    zenoh = swarmactors.run(scenario(), out=tmp_path / "zenoh", processes=2)
    inproc = run_inprocess(scenario(), out=tmp_path / "inproc", hosts=2)
    assert zenoh["trace_hash"] == inproc["trace_hash"]
    assert check_rule_drops(zenoh.trace) == zenoh["world"]["dropped"]["long-frame"] > 0


def test_before_puts_the_rule_ahead_of_a_built_in_one(long_frames):
    """With loss = 1 every pair is lost; the rule placed before ``loss`` claims the long frames beyond first."""
    pos = np.array([[0.0, 0.0], [0.3, 0.0], [1.0, 0.0]])
    alive = np.ones(3, dtype=bool)
    ranges = np.full(3, 1.2)
    reach = within(pos, np.arange(3), ranges)
    frames = [Outgoing(0, None, "B", 1, b"x" * 64), Outgoing(0, None, "B", 2, b"x" * 8)]
    causes = {}
    for before in (None, "loss"):
        rule = {"use": "long-frames", "max_bytes": MAX_BYTES, "beyond": BEYOND}
        radio = Radio.from_dict({"range": 1.2, "loss": 1.0, "rules": [rule if before is None else
                                                                      {**rule, "before": before}]})
        _, drops, _ = Medium(radio, 1).decide(0, frames, reach, alive, pos, ranges)
        causes[before] = {(seq, dst): cause for _src, seq, dst, _kind, cause in drops}
    assert set(causes[None].values()) == {"loss"}
    assert causes["loss"] == {(1, 1): "loss", (1, 2): "long-frame", (2, 1): "loss", (2, 2): "loss"}


@pytest.mark.parametrize(("rule", "key", "words"), [
    ({"use": "long-frame"}, "radio.rules[0].use", "unknown radio rule 'long-frame' (known: long-frames)"),
    ({"use": "long-frames", "max_bytes": 3}, "radio.rules[0]", "missing required field `beyond`"),
    ({"use": "long-frames", "max_bytes": "3", "beyond": 1}, "radio.rules[0].max_bytes", "Expected `int`"),
    ({"use": "long-frames", "max_bytes": 3, "beyond": 1, "colour": 2}, "radio.rules[0]", "unknown field `colour`"),
    ({"use": "long-frames", "max_bytes": 3, "beyond": 1, "before": "never"}, "radio.rules[0].before",
     "'never' is no built-in rule"),
    ({"use": "world.radio:Medium"}, "radio.rules[0].use", "unknown radio rule 'world.radio:Medium'"),
])
def test_a_bad_rule_table_is_refused_naming_file_and_key(long_frames, rule, key, words):
    raw = scenario()
    raw["radio"]["rules"] = [rule]
    with pytest.raises(ScenarioError) as err:
        resolve(raw, "bad.toml")
    assert f"bad.toml: {key}" in str(err.value) and words in str(err.value), str(err.value)


def test_the_docs_show_the_rule_that_the_tests_run():
    page = (Path(__file__).resolve().parents[1] / "docs" / "radio-rules.md").read_text()
    source = (EXAMPLE / "long_frames.py").read_text()
    body = source[source.index("class LongFrames"):]
    assert textwrap.indent(body.strip(), "") in page
