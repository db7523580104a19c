"""A robot's own clock (swarmactors/robot/robot_clock.py) and what runs on it, without Zenoh.

Rules tested:

* local = (1 + drift * 1e-6) * now + offset, the offset in seconds (offset / dt ticks in lockstep);
* ``ctx.now`` reads the local clock while ``ctx.tick`` stays the world's; no offset and no drift: no clock;
* lockstep timers fire at the first tick whose local time reaches the due time (local now + delay);
* realtime: a delay of d local seconds is scheduled as d / (1 + drift * 1e-6) true seconds;
* the host builds each robot's clock from its RobotDescr, and refuses a behaviour that does not support the
  robot's sensing frame (the robot fails, naming the behaviour); under local sensing ``sensed`` items carry
  range and bearing, and ``pos`` is the same vector in Cartesian form.
"""

from __future__ import annotations

import asyncio
import math
import sys
import types

import numpy as np
import pytest

from swarmactors.robot import Robot, RobotRuntime, SensedView
from swarmactors.robot.behavior import Behavior, Context
from swarmactors.robot.robot_clock import RobotClock, robot_clock
from transport.messages import Inputs, RobotDescr, RobotIn, RunInfo


def test_local_time_under_offset_and_drift():
    c = RobotClock(offset_s=0.5, drift_ppm=2000.0, clock="realtime", dt=0.1)
    for now in (0.0, 1.0, 123.4):
        assert c.local(now) == pytest.approx(1.002 * now + 0.5)
    assert c.true_delay(1.002) == pytest.approx(1.0)
    lock = RobotClock(offset_s=0.5, drift_ppm=-1e5, clock="lockstep", dt=0.1)  # 0.5 s = 5 ticks
    assert lock.local(10) == pytest.approx(0.9 * 10 + 5)
    assert robot_clock(0.0, 0.0, "lockstep", 1.0) is None


class TimerAt5(Behavior):
    """At its start, a timer 5 clock units later; records the world's tick at which it fires."""

    def __init__(self):
        self.fired = []
        self.now = []

    def on_start(self, ctx):
        ctx.after(5.0, lambda: self.fired.append(ctx.tick))

    def on_tick(self, ctx, sensed):
        self.now.append(ctx.now)


def test_ctx_now_and_lockstep_timers_run_on_the_robots_clock():
    mod = types.ModuleType("clock_timer_mod")
    mod.TimerAt5 = TimerAt5
    sys.modules["clock_timer_mod"] = mod
    runtime = RobotRuntime(RunInfo("lockstep", 1.0, 0, 10, 10.0, 0), allow={"clock_timer_mod"})
    runtime.adopt([RobotDescr(0, [0.0, 0.0, 0.0], [{"use": "clock_timer_mod:TimerAt5"}], "ground", 1.0, 1.0, 1.0,
                              clock_offset=2.0, clock_drift=1e5)])  # local = 1.1 t + 2
    for tick in range(8):  # due at local 7.0: true tick 5/1.1 = 4.55 -> tick 5
        asyncio.run(runtime.step(Inputs.from_rows(tick, float(tick), [RobotIn(0, [0.0, 0.0, 0.0], ([], []), [])])))
    b = runtime.robots[0].behaviors[0]
    assert b.fired == [5] and runtime.robots[0].ctx.tick == 7
    assert b.now == [pytest.approx(1.1 * t + 2.0) for t in range(8)]


def test_realtime_delays_are_turned_into_true_seconds():
    ctx = Context(0, np.random.default_rng(0), "realtime", own_clock=RobotClock(0.0, -5e4, "realtime", 0.1))
    scheduled = []
    ctx._schedule_with(lambda delay, fn: scheduled.append(delay))
    ctx.after(0.95, print)
    assert scheduled == [pytest.approx(1.0)]


class GlobalOnly(Behavior):
    pass


class Both(Behavior):
    frames = ("global", "local")


def _robot(use: str, **descr) -> Robot:
    mod = types.ModuleType("clock_mod")
    mod.GlobalOnly, mod.Both = GlobalOnly, Both
    sys.modules["clock_mod"] = mod
    run = RunInfo("lockstep", 0.5, 0, 10, 10.0, 0)
    return Robot(RobotDescr(0, [0.0, 0.0, 0.0], [{"use": f"clock_mod:{use}"}], "ground", 1.0, 1.0, 1.0, **descr),
                 run, allow={"clock_mod"})


def _now_at_tick_3(robot: Robot) -> float:
    runtime = RobotRuntime(RunInfo("lockstep", 0.5, 0, 10, 10.0, 0))
    runtime.robots[robot.id] = robot
    asyncio.run(runtime.step(Inputs.from_rows(3, 3.0, [RobotIn(robot.id, [0.0, 0.0, 0.0], ([], []), [])])))
    return robot.ctx.now


def test_the_host_builds_the_clock_and_checks_the_frame():
    robot = _robot("Both", sensing_frame="local", clock_offset=1.0, clock_drift=100.0)
    assert robot.error is None and robot.local and robot.ctx.sensing_frame == "local"
    assert _now_at_tick_3(robot) == pytest.approx(3 * 1.0001 + 2.0)  # 1 s = 2 ticks of 0.5 s
    plain = _robot("GlobalOnly")
    assert plain.error is None and _now_at_tick_3(plain) == 3  # no offset, no drift: the world's time
    refused = _robot("GlobalOnly", sensing_frame="local")
    assert refused.error and "clock_mod:GlobalOnly" in refused.error and "local" in refused.error


def test_local_sensed_items_carry_range_and_bearing():
    view = SensedView([4, 9], [2.0, math.pi / 2, 1.0, -math.pi], 2, local=True)
    a, b = view[0], view[1]
    assert (a.id, a.range, a.bearing) == (4, 2.0, math.pi / 2)
    np.testing.assert_allclose(a.pos, [0.0, 2.0], atol=1e-12)
    np.testing.assert_allclose(view.positions(), [[0.0, 2.0], [-1.0, 0.0]], atol=1e-12)
    assert b.range == 1.0
    plain = SensedView([4], [2.0, 3.0], 2)
    assert plain[0].range is None and plain[0].pos.tolist() == [2.0, 3.0]
