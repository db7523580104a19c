"""A copy's fate is decided by its own due time, in both clocks (world/sim.py ``Simulation.deliver``).

Rule: a copy whose receiver died at or before the copy's due time is dropped as ``dead``; one whose receiver died
after it is delivered, however late the copy leaves the air (realtime bookkeeping fires milliseconds late under
load and records a whole ``BOOKKEEPING_S`` slot at once).
"""

from __future__ import annotations

import numpy as np

from swarmactors.runs.scenario import resolve
from world import Simulation
from world.air import Copies
from world.radio import Outgoing


def _sim(clock: str, now: list[float]) -> Simulation:
    sc = resolve({"run": {"name": "s", "ticks": 5, "clock": clock},
                  "robots": [{"count": 3, "behaviors": [{"use": "beacon"}]}]}, "<t>")
    return Simulation(sc, time=lambda: now[0])


def _copies(dst, seq, due) -> Copies:
    n = len(dst)
    frame = Outgoing(2, None, "B", 0, b"")
    return Copies(np.array(dst), np.zeros(n, dtype=np.int64), np.full(n, 2), np.array(seq), np.zeros(n, dtype=np.int64),
                  np.array(due, dtype=float), np.zeros(n, dtype=bool), [(frame, 0)])


def test_a_realtime_copy_is_dead_only_when_its_receiver_died_before_its_own_due_time():
    now = [1000.0]
    sim = _sim("realtime", now)
    assert sim.robots.kill(1, 0, "killed")
    died = float(sim.robots.died_at[1])
    assert died == 1000.0 and np.isinf(sim.robots.died_at[[0, 2]]).all()
    # copies from robot 2: to 0, to 1 due before its death, to 1 due after it; recorded together, after both
    sim.air.put(_copies([0, 1, 1], [7, 8, 9], [died + 1.0, died - 0.001, died + 0.001]))
    delivered = sim.deliver(died + 2.0)
    rec = sim.record.take()
    assert [row[:3] for row in rec["del"]] == [[2, 7, 0], [2, 8, 1]]
    assert [row[:4] for row in rec["drop"]] == [[2, 9, 1, "dead"]]
    assert delivered.dst.tolist() == [0, 1] and len(sim.air) == 0


def test_the_air_never_hands_a_copy_over_before_its_slot_ends():
    sim = _sim("realtime", [0.0])
    w = sim.air.width
    sim.air.put(_copies([0, 1], [1, 2], [10 * w - w / 2, 10 * w + w / 2]))
    assert sim.deliver(10 * w - w / 4) is None  # the first copy's slot ends at 10 w
    assert sim.deliver(10 * w).dst.tolist() == [0]
    assert sim.deliver(11 * w).dst.tolist() == [1]


def test_a_lockstep_copy_is_dead_when_its_receiver_died_at_or_before_its_due_tick():
    sim = _sim("lockstep", [0.0])
    sim.begin(3, 3.0)
    assert sim.robots.kill(1, 3, "killed") and sim.robots.died_at[1] == 3.0  # a lockstep death is at its tick
    sim.air.put(_copies([0, 1, 1], [1, 2, 3], [3.0, 3.0, 4.0]))
    assert sim.deliver(3).dst.tolist() == [0]
    assert sim.deliver(4) is None
    assert [row[2:4] for row in sim.record.take()["drop"]] == [[1, "dead"], [1, "dead"]]
