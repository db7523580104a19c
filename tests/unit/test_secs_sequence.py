"""The TSC's sequence (``swarmactors schedule --secs``) as a SECS scenario: units, who knows what, bad input."""

from __future__ import annotations

import pytest

from protocols.secs.scenarios import SequenceError, main, sequence_scenario

SEQ = {"start": [2.0, 2.0], "robots": 4, "gamma": 1.0,
       "slots": [{"deployment": [3.0, 2.0], "duration": 2.0, "master": 1,
                  "tasks": [{"id": "a", "position": [4.0, 2.0], "arm": [2], "arm_size": 1}]}]}


def test_only_the_master_gets_the_schedule_in_metres_and_seconds():
    sc = sequence_scenario(SEQ, time_unit=30.0)
    master, backbone = sc["robots"]
    sch = master["behaviors"][0]["schedule"]
    assert sch == {"robots": 4, "slots": [{"deployment": [3.0, 0.0], "duration": 60.0,
                                           "tasks": [{"id": "a", "position": [6.0, 0.0]}]}]}  # 3 m per Γ
    assert "schedule" not in backbone["behaviors"][0] and len(backbone["positions"]) == 3
    assert sc["world"]["objects"] == [{"name": "task_a", "pos": [6.0, 0.0], "known_by": []}]
    assert sc["run"]["ticks"] == int(round((3.0 / 0.05 + 60.0 + 60.0) / 0.1))


def test_bad_sequence_is_refused_with_file_and_key(tmp_path, capsys):
    bad = tmp_path / "seq.toml"
    bad.write_text('start = [0.0, 0.0]\nrobots = 4\n[[slots]]\ndeployment = [1.0]\nduration = 1.0\n')
    with pytest.raises(SequenceError, match=r"seq.toml: slots\[0\].deployment = \[1.0\]"):
        sequence_scenario(bad)
    assert main([str(bad), "--out", str(tmp_path / "sc.toml")]) == 2
    assert "slots[0].deployment" in capsys.readouterr().err
    far = tmp_path / "far.toml"
    far.write_text('start = [0.0, 0.0]\nrobots = 4\n[[slots]]\ndeployment = [20.0, 0.0]\nduration = 1.0\n'
                   '[[slots.tasks]]\nid = "x"\nposition = [1.0, 1.0]\n')
    with pytest.raises(SequenceError, match="outside the 30 m arena"):
        sequence_scenario(far)
    assert main([str(far), "--out", str(tmp_path / "sc.toml"), "--scale", "nan"]) == 2
    assert not (tmp_path / "sc.toml").exists()
