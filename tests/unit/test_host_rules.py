"""Host rules below Zenoh: robots share nothing (frame tables), the context's read-only time, hook order."""

from __future__ import annotations

import numpy as np
import pytest

from swarmactors.behavior import Behavior, Context
from swarmactors.host import FrameTable
from transport import pack
from transport.messages import FrameIn


def test_each_receiver_gets_its_own_mutable_body():
    body = {"list": [0, [1]], "map": {"a": {"b": 1}}}
    table = FrameTable([FrameIn(0, "K", 1, pack(body), 0.0), FrameIn(0, "N", 2, pack(7), 0.0)])
    first, second = table.frame(0), table.frame(0)
    first.body["list"][1].append(9)
    first.body["map"]["a"]["b"] = 5
    assert second.body == body and table.frame(0).body == body
    assert first.body is not second.body
    assert table.frame(1).body == 7 and table.frame(1) is table.frame(1)  # immutable: shared


def test_undecodable_body_is_none_for_every_receiver():
    table = FrameTable([FrameIn(0, "K", 1, b"\xc1", 0.0)])
    assert table.frame(0) is None and table.frame(0) is None


def test_context_time_and_scenario_values_are_read_only():
    ctx = Context(3, np.random.default_rng(0), "lockstep", dt=0.1, radio_range=2.0, sensing_range=1.5)
    assert (ctx.dt, ctx.range, ctx.sensing, ctx.clock) == (0.1, 2.0, 1.5, "lockstep")
    for attr in ("now", "tick", "dt", "range", "sensing", "clock"):
        with pytest.raises(AttributeError):
            setattr(ctx, attr, 1)
    ctx._set_time(4, 4.0)
    assert (ctx.tick, ctx.now) == (4, 4.0)


def test_realtime_timers_go_to_the_host_scheduler():
    ctx = Context(0, np.random.default_rng(0), "realtime")
    scheduled = []
    ctx._on_timer = lambda delay, fn: scheduled.append((delay, fn))
    ctx.after(0.25, print)
    assert scheduled == [(0.25, print)] and ctx._timers == []


def test_on_batch_default_is_not_called():
    from swarmactors.host import Robot
    from transport.messages import RobotDescr, RunInfo

    class WithBatch(Behavior):
        def on_batch(self, ctx):
            return None

    class Plain(Behavior):
        pass

    import sys
    import types

    mod = types.ModuleType("batch_mod")
    mod.WithBatch, mod.Plain = WithBatch, Plain
    sys.modules["batch_mod"] = mod
    run = RunInfo("lockstep", 1.0, 0, 10, 10.0, 0)
    robot = Robot(RobotDescr(0, [0.0, 0.0, 0.0], [{"use": "batch_mod:WithBatch"}, {"use": "batch_mod:Plain"}],
                             "ground", 1.0, 1.0, 1.0), run, allow={"batch_mod"})
    assert robot.error is None, robot.error
    assert len(robot._batch_hooks) == 1
