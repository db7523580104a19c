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


def _realtime_host(robots: int):
    """A realtime RobotHost with ``robots`` beacon robots and no link; hand-overs recorded instead of run."""
    import asyncio
    import time

    from swarmactors.host import RobotHost
    from transport import Keys
    from transport.messages import RobotDescr, RunInfo

    host = RobotHost(None, Keys("rt"))
    host.name, host.key, host.tick = "h", b"k" * 32, 0
    host.run_info = RunInfo("realtime", 0.05, 1, 10, 5.0, 0)
    for i in range(robots):
        host._adopt(RobotDescr(i, [float(i), 0.0, 0.0], [{"use": "beacon"}], "ground", 1.0, 1.0, 0.5))
    host._stopped, host._epoch = asyncio.Event(), time.time()
    handed: list[tuple[int, list]] = []
    for robot in host.robots.values():
        robot.frame_calls = lambda frames, rid=robot.id: iter(handed.append((rid, frames)) or ())
    timer: list[tuple[float, object]] = []
    host._timer = type("Timer", (), {"add": staticmethod(lambda due, item: timer.append((due, item)))})()
    return host, handed, timer


def test_realtime_copies_due_are_handed_over_at_once_the_others_per_due_time():
    import time

    from transport.messages import Deliveries

    host, handed, timer = _realtime_host(3)
    now = time.time()
    frames = [FrameIn(5, "K", 1, pack([1]), 0.5), FrameIn(6, "K", 2, b"\xc1", 0.5), FrameIn(7, "K", 3, pack("x"), 0.5)]
    msg = Deliveries.of(frames, dst=[0, 1, 0, 2, 1, 0], refs=[0, 0, 2, 1, 2, 0],
                        due=[now - 1, now - 1, now + 60, now - 1, now + 60, now + 30],
                        rab=[[1.0, 0.5], None, None, None, [0.3, -0.2], None])
    host._take_deliveries(msg)
    # due already: robot 0 and 1 get frame 5 (each its own body); robot 2's copy does not decode: counted
    assert [(rid, [(f.src, f.body, f.rab) for f in fs]) for rid, fs in handed] == [
        (0, [(5, [1], (1.0, 0.5))]), (1, [(5, [1], None)])]
    assert handed[0][1][0].body is not handed[1][1][0].body
    assert host.robots[2].bad_bodies == 1
    # the rest wait on the timer, one item per due time, never handed over before it
    assert sorted(due for due, _ in timer) == [now + 30, now + 60]
    handed.clear()
    host._deliver([item for _, item in sorted(timer, key=lambda t: t[0])])
    assert [(rid, [(f.src, f.body, f.rab) for f in fs]) for rid, fs in handed] == [
        (0, [(5, [1], None), (7, "x", None)]), (1, [(7, "x", (0.3, -0.2))])]


def test_realtime_timers_due_together_leave_in_one_uplink():
    """Robots whose timers fire in one pass of the loop send their frames in one uplink (``_rt_flush_soon``)."""
    import asyncio

    async def run() -> list[list[int]]:
        host, _, _ = _realtime_host(3)
        host._loop, host._rt_later = asyncio.get_running_loop(), []
        sent: list[list[int]] = []
        host._uplink = lambda tick, rows: rows
        host.link = type("Link", (), {"publish": staticmethod(lambda key, rows: sent.append([r.id for r in rows]))})()
        for robot in host.robots.values():
            host._realtime_timers(robot)
        loop = asyncio.get_running_loop()
        when = loop.time() + 0.02
        for rid in (0, 2):  # two timers due at the same time: one loop pass fires both
            ctx = host.robots[rid].ctx
            loop.call_at(when, lambda ctx=ctx: ctx.after(0.0, lambda ctx=ctx: ctx.broadcast("K", [ctx.id])))
        host.robots[1].ctx.after(0.06, lambda: host.robots[1].ctx.broadcast("K", [1]))  # later: its own uplink
        await asyncio.sleep(0.12)
        return sent

    assert asyncio.run(run()) == [[0, 2], [1]]
