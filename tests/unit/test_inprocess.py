"""The in-process driver (swarmactors/runs/inprocess.py) below Zenoh: the same trace hashes as the pinned Zenoh runs.

A Simulation and its robots' runtimes stepped in one loop with nothing in between must give, for a pinned
lockstep scenario, the hash that tests/test_pins.py pins for the Zenoh path, with one runtime or two: the sessions
add transport and nothing else. (tests/test_pins.py runs every pinned scenario this way too.)
"""

from __future__ import annotations

import pytest

from swarmactors.runs.inprocess import InProcessRun
from swarmactors.runs.scenario import resolve
from test_pins import SCENARIO_PINS


@pytest.mark.parametrize("name,hosts", [("flooding.toml", 1), ("biconnectivity-check.toml", 2)])
def test_a_whole_scenario_in_process_has_its_pinned_hash(name, hosts, shipped_inprocess):
    """The run (tests/conftest.py's ``shipped_inprocess``) is the one tests/test_pins.py pins at two runtimes."""
    result = shipped_inprocess(name, hosts)
    assert result["trace_hash"] == SCENARIO_PINS[name]
    assert result["checks"] and all(c["passed"] for c in result["checks"]), result["checks"]
    assert (result.path.parent / "trace.msgpack").is_file()


def test_stepping_by_hand_gives_one_record_a_tick_and_stops_at_the_end():
    spec = resolve({"run": {"name": "s", "ticks": 4}, "radio": {"range": 2.0},
                    "robots": [{"positions": [[0, 0], [1, 0], [2, 0]], "behaviors": [{"use": "beacon"}]}]}, "<t>")
    run = InProcessRun(spec, hosts=2)
    records = []
    while not run.done:
        records.append(run.sync_step())
    assert [r["t"] for r in records] == [0, 1, 2, 3]
    assert sum(len(r.get("del", [])) for r in records) == run.sim.counters.delivered > 0


def test_a_realtime_scenario_is_refused():
    spec = resolve({"run": {"name": "s", "ticks": 4, "clock": "realtime"},
                    "robots": [{"count": 2, "behaviors": [{"use": "beacon"}]}]}, "<t>")
    with pytest.raises(ValueError, match="lockstep only"):
        InProcessRun(spec)
