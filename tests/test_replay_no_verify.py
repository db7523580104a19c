"""``swarmactors replay --no-verify``: a trace whose hash does not match is refused (exit 2) unless told."""

from __future__ import annotations

from pathlib import Path

import msgpack
import pytest

from swarmactors.cli import main

pytestmark = pytest.mark.slow  # runs a world over Zenoh for its trace


def _edited_trace(tmp_path: Path) -> Path:
    """A real run's trace with one robot moved in its first tick record (so its hash no longer matches)."""
    from swarmactors.runs.launcher import run

    result = run({"run": {"name": "noverify", "ticks": 4},
                  "robots": [{"count": 3, "placement": "line", "behaviors": [{"use": "beacon"}]}]},
                 out=tmp_path / "run", processes=0)
    with open(result.trace_path, "rb") as f:
        objs = list(msgpack.Unpacker(f, raw=False, strict_map_key=False))
    objs[2]["pos"][0][1] += 0.5
    edited = tmp_path / "edited.msgpack"
    edited.write_bytes(b"".join(msgpack.packb(o) for o in objs))
    return edited


def test_replay_refuses_an_edited_trace_unless_no_verify(tmp_path, capsys):
    edited = _edited_trace(tmp_path)
    assert main(["replay", str(edited), "--events"]) == 2
    err = capsys.readouterr().err
    assert "hash mismatch" in err and "--no-verify" in err
    assert main(["replay", str(edited), "--events", "--no-verify"]) == 0
    out, err = capsys.readouterr()
    assert "warning:" in out + err and "hash mismatch" in out + err
    gif = tmp_path / "walk.gif"
    assert main(["replay", str(edited), "--gif", str(gif), "--quiet"]) == 2  # the animation verifies too
    assert not gif.exists()
