"""Robot runtime rules below Zenoh, through ``RobotRuntime``'s public API (inputs in, rows out).

* robots share nothing: a frame body decoded once per host, a mutable one decoded again per receiver;
* the context's time and scenario values are read-only to behaviours; the runtime advances the time;
* a lockstep step applies the tick's membership first (dead robots stop, new ones are adopted and stepped),
  a crashed robot's error leaves once, and the same inputs give the same rows whether or not they were encoded;
* the default ``on_batch`` is not called;
* realtime: copies already due are handed over at once, the others at their due time through the timer, one
  batch per robot; timers that fire together leave in one uplink.
"""

from __future__ import annotations

import asyncio
import sys
import time
import types

import numpy as np
import pytest

from swarmactors.robot import FrameTable, RobotRuntime
from swarmactors.robot.behavior import Behavior, Context
from transport import pack
from transport.messages import Deliveries, Downlink, FrameIn, Inputs, RobotDescr, RobotIn, RunInfo, decode, encode

LOCKSTEP = RunInfo("lockstep", 1.0, 0, 10, 10.0, 0)
REALTIME = RunInfo("realtime", 0.05, 1, 10, 5.0, 0)
LOG: list[tuple] = []  # every Recorder's hook calls, in the order they happened


class Recorder(Behavior):
    """Records its robot's hook calls in LOG; broadcasts its id on each tick with ``every_tick``."""

    kinds = ("K",)

    def __init__(self, every_tick: bool = False):
        self.every_tick = every_tick
        self.frames = []

    def on_frame(self, ctx, frame):
        self.frames.append(frame)
        LOG.append(("frame", ctx.id, frame.src, frame.body, frame.rab))

    def on_batch(self, ctx):
        LOG.append(("batch", ctx.id))

    def on_tick(self, ctx, sensed):
        LOG.append(("tick", ctx.id, ctx.tick, ctx.now))
        if self.every_tick:
            ctx.broadcast("K", [ctx.id])


class Starter(Recorder):
    def on_start(self, ctx):
        LOG.append(("start", ctx.id))


class Crashes(Behavior):
    def on_tick(self, ctx, sensed):
        raise RuntimeError("boom")


class Plain(Behavior):
    pass


def _allow() -> set[str]:
    mod = types.ModuleType("host_rules_mod")
    mod.Recorder, mod.Crashes, mod.Plain, mod.Starter = Recorder, Crashes, Plain, Starter
    sys.modules["host_rules_mod"] = mod
    LOG.clear()
    return {"host_rules_mod"}


def _descr(rid: int, use: str = "Recorder", **params) -> RobotDescr:
    return RobotDescr(rid, [float(rid), 0.0, 0.0], [{"use": f"host_rules_mod:{use}", **params}], "ground", 1.0, 1.0,
                      0.5)


def _inputs(tick: int, ids: list[int], frames: list[FrameIn] = (), inbox: dict[int, list[int]] | None = None,
            **more) -> Inputs:
    rows = [RobotIn(i, [float(i), 0.0, 0.0], ([], []), (inbox or {}).get(i, [])) for i in ids]
    return Inputs.from_rows(tick, float(tick), rows, frames, **more)


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


def test_context_time_and_scenario_values_are_read_only_and_the_runtime_advances_time():
    ctx = Context(3, np.random.default_rng(0), "lockstep", dt=0.1, radio_range=2.0, sensing_range=1.5)
    assert (ctx.dt, ctx.range, ctx.sensing, ctx.clock) == (0.1, 2.0, 1.5, "lockstep")
    for attr in ("now", "tick", "dt", "range", "sensing", "clock"):
        with pytest.raises(AttributeError):
            setattr(ctx, attr, 1)
    rt = RobotRuntime(LOCKSTEP, _allow())
    rt.adopt([_descr(0)])
    asyncio.run(rt.step(_inputs(4, [0])))
    assert (rt.tick, rt.robots[0].ctx.tick, rt.robots[0].ctx.now) == (4, 4, 4.0)


def test_realtime_timers_go_to_the_runtime_scheduler():
    ctx = Context(0, np.random.default_rng(0), "realtime")
    scheduled = []
    ctx._schedule_with(lambda delay, fn: scheduled.append((delay, fn)))
    ctx.after(0.25, print)
    assert scheduled == [(0.25, print)] and list(ctx._due_timers()) == []


def test_a_step_applies_membership_first_and_sends_a_crash_once():
    rt = RobotRuntime(LOCKSTEP, _allow())
    rt.adopt([_descr(0, every_tick=True), _descr(1, "Crashes")])

    async def steps():
        first = await rt.step(_inputs(0, [0, 1]))
        second = await rt.step(_inputs(1, [0, 1, 2], new=[_descr(2, every_tick=True)]))
        third = await rt.step(_inputs(2, [0, 1, 2], dead=[0]))
        return first, second, third

    first, second, third = asyncio.run(steps())
    assert [(r.id, len(r.frames), r.error is not None) for r in first] == [(0, 1, False), (1, 0, True)]
    assert "RuntimeError: boom" in first[1].error
    assert [(r.id, len(r.frames), r.error) for r in second] == [(0, 1, None), (2, 1, None)]  # the crash: once
    assert [r.id for r in third] == [2] and not rt.robots[0].alive
    assert [e[1:3] for e in LOG if e[0] == "tick"] == [(0, 0), (0, 1), (2, 1), (2, 2)]
    assert "_error" in rt.reports()[1] and sorted(rt.reports()) == [0, 1, 2]


def test_the_same_inputs_give_the_same_rows_whether_encoded_or_not():
    frames = [FrameIn(7, "K", 1, pack({"a": [1, 2]}), 0.0), FrameIn(8, "K", 1, pack(3), 0.0)]
    msg = _inputs(1, [0, 1], frames, {0: [0, 1], 1: [1]}, objects={"o": [1.0, 2.0]})
    rows = []
    for given in (msg, decode(encode(msg), Downlink, what="downlink")):
        rt = RobotRuntime(LOCKSTEP, _allow())
        rt.adopt([_descr(0, every_tick=True), _descr(1, every_tick=True)])
        rows.append(asyncio.run(rt.step(given)))
        assert rt.robots[0].ctx.objects == {"o": [1.0, 2.0]}
    assert rows[0] == rows[1] and [r.id for r in rows[0]] == [0, 1]
    assert [e for e in LOG if e[0] == "frame"][:3] == [("frame", 0, 7, {"a": [1, 2]}, None),
                                                      ("frame", 0, 8, 3, None), ("frame", 1, 8, 3, None)]


def test_on_batch_default_is_not_called(monkeypatch):
    called = []
    monkeypatch.setattr(Behavior, "on_batch", lambda self, ctx: called.append(ctx.id))
    rt = RobotRuntime(LOCKSTEP, _allow())
    rt.adopt([_descr(0), _descr(1, "Plain")])  # Recorder overrides on_batch, Plain does not
    frames = [FrameIn(5, "K", 1, pack(1), 0.0)]
    asyncio.run(rt.step(_inputs(0, [0, 1], frames, {0: [0], 1: [0]})))
    assert ("batch", 0) in LOG and called == []


class _Timer:
    """A DueTimer that records what it is given instead of waiting."""

    def __init__(self):
        self.items: list[tuple[float, object]] = []

    def add(self, due, item):
        self.items.append((due, item))


def test_realtime_copies_due_are_handed_over_at_once_the_others_per_due_time():
    async def main():
        rt = RobotRuntime(REALTIME, _allow())
        rt.adopt([_descr(i) for i in range(3)])
        timer, sent = _Timer(), []
        rt.start_realtime(sent.append, timer)
        now = time.time()
        frames = [FrameIn(5, "K", 1, pack([1]), 0.5), FrameIn(6, "K", 2, b"\xc1", 0.5),
                  FrameIn(7, "K", 3, pack("x"), 0.5)]
        msg = Deliveries.of(frames, dst=[0, 1, 0, 2, 1, 0], refs=[0, 0, 2, 1, 2, 0],
                            due=[now - 1, now - 1, now + 60, now - 1, now + 60, now + 30],
                            rab=[[1.0, 0.5], None, None, None, [0.3, -0.2], None])
        rt.take_deliveries(msg)
        # due already: robot 0 and 1 get frame 5 (each its own body), each in its own batch; robot 2's copy
        # does not decode: counted, no hook called
        assert LOG == [("frame", 0, 5, [1], (1.0, 0.5)), ("batch", 0), ("frame", 1, 5, [1], None), ("batch", 1)]
        assert rt.robots[0].behaviors[0].frames[0].body is not rt.robots[1].behaviors[0].frames[0].body
        assert rt.robots[2].bad_bodies == 1 and rt.reports()[2]["_bad_bodies"] == 1
        # the rest wait on the timer, one item per due time, never handed over before it
        assert sorted(due for due, _ in timer.items) == [now + 30, now + 60]
        LOG.clear()
        rt.deliver([item for _, item in sorted(timer.items, key=lambda t: t[0])])
        assert LOG == [("frame", 0, 5, [1], None), ("frame", 0, 7, "x", None), ("batch", 0),
                       ("frame", 1, 7, "x", (0.3, -0.2)), ("batch", 1)]
        rt.stop()
        LOG.clear()
        rt.deliver([item for _, item in timer.items])  # stopped: nothing more is handed over
        assert LOG == [] and sent == []  # Recorder sends nothing on frames
        await rt.close()

    asyncio.run(main())


def test_realtime_batches_call_on_start_once_before_the_first_frame_and_on_batch_after_each():
    async def main():
        rt = RobotRuntime(REALTIME, _allow())
        rt.adopt([_descr(0, "Starter"), _descr(1, "Plain")])
        rt.start_realtime(lambda rows: None, _Timer())
        now = time.time()
        frames = [FrameIn(5, "K", 1, pack(1), 0.5), FrameIn(6, "N", 1, pack(2), 0.5)]
        for _ in range(2):
            rt.take_deliveries(Deliveries.of(frames, dst=[0, 0, 1], refs=[0, 1, 0], due=[now - 1] * 3))
        assert LOG == [("start", 0), ("frame", 0, 5, 1, None), ("batch", 0), ("frame", 0, 5, 1, None), ("batch", 0)]
        assert rt.robots[1].started and rt.robots[0].bad_bodies == 0  # a kind nobody owns: no hook, not bad
        await rt.close()

    asyncio.run(main())


def test_realtime_inputs_step_every_robot_once_a_slice_at_a_time():
    async def main():
        rt = RobotRuntime(REALTIME, _allow())
        rt.adopt([_descr(i, every_tick=True) for i in range(5)])
        sent: list[list[int]] = []
        rt.start_realtime(lambda rows: sent.append([r.id for r in rows]), _Timer(), slice_size=2)
        epoch = time.time() - 3.0
        rt.take_inputs(_inputs(3, list(range(5)), epoch=epoch))
        assert sent == [[0, 1]] and rt.epoch == epoch and rt.tick == 3
        await asyncio.sleep(0)
        assert sent == [[0, 1], [2, 3]]
        rt.take_inputs(_inputs(4, [0]))  # the next tick's inputs first finish this one's robots
        assert sent == [[0, 1], [2, 3], [4], [0]]
        ticks = [e for e in LOG if e[0] == "tick"]
        assert [e[1:3] for e in ticks] == [(i, 3) for i in range(5)] + [(0, 4)]
        assert all(3.0 <= e[3] < 4.0 for e in ticks)  # ctx.now: seconds since the epoch
        await rt.close()

    asyncio.run(main())


def test_realtime_timers_due_together_leave_in_one_uplink():
    """Robots whose timers fire in one pass of the loop send their frames in one uplink."""

    async def run() -> list[list[int]]:
        rt = RobotRuntime(REALTIME, _allow())
        rt.adopt([_descr(i) for i in range(3)])
        sent: list[list[int]] = []
        rt.start_realtime(lambda rows: sent.append([r.id for r in rows]), _Timer())
        loop = asyncio.get_running_loop()
        when = loop.time() + 0.02
        for rid in (0, 2):  # two timers due at the same time: one loop pass fires both
            ctx = rt.robots[rid].ctx
            loop.call_at(when, lambda ctx=ctx: ctx.after(0.0, lambda ctx=ctx: ctx.broadcast("K", [ctx.id])))
        rt.robots[1].ctx.after(0.06, lambda: rt.robots[1].ctx.broadcast("K", [1]))  # later: its own uplink
        await asyncio.sleep(0.12)
        await rt.close()
        return sent

    assert asyncio.run(run()) == [[0, 2], [1]]
