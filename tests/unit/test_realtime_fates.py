"""The world's realtime bookkeeping below Zenoh: a copy's fate is decided by its own due time.

Rule (``World._rt_deliver``): a copy whose receiver died before the copy's due time is dropped as ``dead``;
one whose receiver died after it is delivered, however late the bookkeeping timer fires (under load it fires
milliseconds late, and it records a whole ``BOOKKEEPING_S`` of due times at once).
"""

from __future__ import annotations

import numpy as np

from swarmactors.scenario import resolve
from tests_support import FakeLink, FakeQuery
from transport import Keys
from transport.messages import JoinRequest, encode
from world import World


def _realtime_world() -> World:
    sc = resolve({"run": {"name": "s", "ticks": 5, "clock": "realtime"},
                           "robots": [{"count": 3, "behaviors": [{"use": "beacon"}]}]}, "<t>")
    w = World(sc, FakeLink(), Keys("s"))
    w._on_join(FakeQuery(w.keys.join, encode(JoinRequest())))
    return w


def test_a_copy_is_dead_only_when_its_receiver_died_before_its_own_due_time():
    w = _realtime_world()
    assert w.robots.kill(1, 0, "killed")
    died = float(w.robots.died_at[1])
    assert np.isinf(w.robots.died_at[[0, 2]]).all()
    # copies from robot 2: to 0, to 1 due before its death, to 1 due after it; recorded together, after both
    dst = np.array([0, 1, 1])
    src, seq, heard = np.full(3, 2), np.array([7, 8, 9]), np.zeros(3, dtype=bool)
    due = np.array([died + 1.0, died - 0.001, died + 0.001])
    w._rt_deliver((dst, src, seq, heard, 0, due))
    rec = w.record.take()
    assert [row[:3] for row in rec["del"]] == [[2, 7, 0], [2, 8, 1]]
    assert [row[:4] for row in rec["drop"]] == [[2, 9, 1, "dead"]]
