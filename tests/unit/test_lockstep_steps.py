"""The lockstep step path below Zenoh (issue 28): steps are puts, inputs are puts on ``down/{host}``.

A world session is driven by hand through a fake link that records what it publishes; a host session's downlink filter
is checked against a fake link that plays its world, and a robot's hook order without a session. Rules:

* a registration (tick -1) is a query answered at once; a step is a put, held until the barrier;
* a step sent as a query, a stale or future step, and a second step while one is held are refused and counted
  as malformed; the held step stands;
* at the barrier each waiting host's inputs are put on its downlink, sealed with its key;
* a host lost to the watchdog is told ``Stop(gone)`` on its downlink, and so is a step it sends later;
* a host drops (and counts) sealed inputs of a tick it has stepped and stops older than its tick (replays);
* ``Robot.calls`` runs hooks in order and hands over only what an ``async def`` hook returns.
"""

from __future__ import annotations

import asyncio
import sys
import types

import numpy as np

from swarmactors.robot import HostSession as RobotHost
from swarmactors.robot import Robot, run_calls
from swarmactors.robot.behavior import Behavior
from swarmactors.runs.scenario import resolve
from tests_support import FakeLink
from transport import Keys, seal, unseal
from transport.messages import (
    PROTOCOL_VERSION,
    Ack,
    Downlink,
    Inputs,
    JoinReply,
    JoinRequest,
    RobotDescr,
    RunInfo,
    Stop,
    Uplink,
    decode,
    encode,
)
from world import WorldSession


class Records(list):
    def record(self, rec: dict) -> None:
        self.append(rec)


def _world(records: list | None = None, watchdog_s: float = 10.0) -> tuple[WorldSession, FakeLink, JoinReply]:
    sc = resolve({"run": {"name": "s", "ticks": 5, "watchdog_s": watchdog_s},
                  "robots": [{"count": 2, "behaviors": [{"use": "beacon"}]}]}, "<t>")
    link = FakeLink()
    w = WorldSession(sc, link, Keys("s"), sinks=[records] if records is not None else [])
    w.open()
    q = link.query(w.keys.join, encode(JoinRequest()))
    return w, link, decode(q.replies[0][1], JoinReply, what="join reply")


def _up(w: WorldSession, j: JoinReply, tick: int) -> bytes:
    return seal(j.key, encode(Uplink(j.host, tick)))


def _down(j: JoinReply, data: bytes):
    return decode(unseal(j.key, data, what="downlink"), Downlink, what="downlink")


def test_registration_is_a_query_answered_at_once_and_steps_are_puts():
    records = Records()
    w, link, j = _world(records)
    reg = link.query(w.keys.up(j.host), _up(w, j, -1))
    assert reg.replies[0][0] == "ok" and isinstance(_down(j, reg.replies[0][1]), Ack)

    async def tick0():
        w.started = True
        w.begin()
        task = asyncio.ensure_future(w.exchange())
        await asyncio.sleep(0)
        (key, data), = link.published
        assert key == w.keys.down(j.host)
        inputs = _down(j, data)
        assert isinstance(inputs, Inputs) and inputs.tick == 0 and [r.id for r in inputs.robots] == [0, 1]
        as_query = link.query(w.keys.up(j.host), _up(w, j, 0))  # the awaited tick, but as a query: refused
        assert as_query.replies[0][0] == "err" and "steps are puts" in as_query.replies[0][1]
        link.put(w.keys.up(j.host), _up(w, j, 1))  # future
        assert not task.done()
        link.put(w.keys.up(j.host), _up(w, j, 0))  # the awaited step: the barrier opens
        link.put(w.keys.up(j.host), _up(w, j, 0))  # a replay while it is held
        await asyncio.wait_for(task, 1.0)
        w.end()

    asyncio.run(tick0())
    mal = records[0].get("mal", [])
    assert w.status()["dropped"]["malformed"] == 3, mal
    assert any("as a query" in m for m in mal) and any("future step" in m for m in mal)
    assert any("second step" in m for m in mal)


def test_a_host_lost_to_the_watchdog_is_told_gone_and_so_is_its_late_step(monkeypatch):
    import world.session as ws

    monkeypatch.setattr(ws, "host_loss_s", lambda _watchdog_s: 0.05)  # not 2·watchdog_s + 5 s in a unit test
    w, link, j = _world()
    link.query(w.keys.up(j.host), _up(w, j, -1))

    async def silent_tick():
        w.started = True
        w.begin()
        await w.exchange()  # the host never steps

    asyncio.run(silent_tick())
    assert j.host not in w.status()["hosts"]
    gone = [_down(j, d) for k, d in link.published if k == w.keys.down(j.host)]
    assert isinstance(gone[-1], Stop) and gone[-1].gone
    link.published.clear()
    link.put(w.keys.up(j.host), _up(w, j, 0))  # it wakes up and steps: told again, nothing counted
    (key, data), = link.published
    assert _down(j, data).gone and w.status()["dropped"]["malformed"] == 0


class _World:
    """Enough of a Link for one HostSession below Zenoh, playing its world.

    It answers the join and the registration, keeps the host's ``down/h0`` handler, and records the ticks of
    the steps the host puts on ``up/h0``.
    """

    def __init__(self):
        self.key = b"k" * 32
        self.down = None
        self.subscribed = asyncio.Event()
        self.steps: list[int] = []

    async def query(self, key, data, **_options):
        if key.endswith("/world/join"):
            return encode(JoinReply("h0", self.key, PROTOCOL_VERSION, [], RunInfo("lockstep", 1.0, 0, 10, 10.0, 0)))
        return seal(self.key, encode(Ack(0.0)))  # the registration, the final reports

    def subscribe(self, key, handler):
        self.down = handler
        self.subscribed.set()

    def publish(self, key, data, *, reliable=True):
        self.steps.append(decode(unseal(self.key, data, what="uplink"), Uplink, what="uplink").tick)

    def declare_token(self, key):
        pass

    def watch_liveliness(self, key, handler):
        pass

    def send(self, msg, key: bytes | None = None) -> None:
        self.down("down/h0", seal(key or self.key, encode(msg)))


def test_a_host_drops_stale_inputs_and_old_stops():
    async def main():
        world = _World()
        host = RobotHost(world, Keys("s"), run_secret=b"")
        run = asyncio.ensure_future(host.run())
        await world.subscribed.wait()
        world.send(Inputs(4))
        for _ in range(3):
            await asyncio.sleep(0)
        assert world.steps == [4] and host.tick == 4
        for msg in (Inputs(4), Inputs(3), Stop(3), Ack(0.0)):  # replays; an Ack is no step's business
            world.send(msg)
        world.send(Inputs(5), key=b"x" * 32)  # not sealed with this host's key
        for _ in range(3):
            await asyncio.sleep(0)
        assert world.steps == [4] and host.bad_downlinks == 4
        world.send(Inputs(5))
        world.send(Stop(5, gone=True))
        await asyncio.wait_for(run, 5.0)
        assert world.steps == [4, 5] and host.gone

    asyncio.run(main())


class _Order(Behavior):
    kinds = ("K",)

    def __init__(self):
        self.seen = []

    def on_start(self, ctx):
        self.seen.append("start")

    def on_frame(self, ctx, frame):
        self.seen.append(f"frame{frame.seq}")
        return self._later(frame.seq) if frame.seq == 1 else None

    async def _later(self, seq):
        await asyncio.sleep(0)
        self.seen.append(f"awaited{seq}")

    def on_batch(self, ctx):
        self.seen.append("batch")

    def on_tick(self, ctx, sensed):
        self.seen.append("tick")


def test_calls_run_hooks_in_order_and_await_only_async_results():
    from swarmactors.robot.behavior import Frame

    mod = types.ModuleType("order_mod")
    mod._Order = _Order
    sys.modules["order_mod"] = mod
    run = RunInfo("lockstep", 1.0, 0, 10, 10.0, 0)
    robot = Robot(RobotDescr(0, [0.0, 0.0, 0.0], [{"use": "order_mod:_Order"}], "ground", 1.0, 1.0, 1.0), run,
                  allow={"order_mod"})
    frames = [Frame(1, "K", None, 1, 0.0), Frame(2, "K", None, 2, 0.0)]
    robot.ctx.after(0, lambda: robot.behaviors[0].seen.append("timer"))
    rest = run_calls(robot, robot.calls(frames, []))
    assert robot.behaviors[0].seen == ["start", "frame1"] and rest is not None
    asyncio.run(rest)
    assert robot.behaviors[0].seen == ["start", "frame1", "awaited1", "frame2", "batch", "timer", "tick"]
    assert run_calls(robot, robot.calls([], np.zeros(0))) is None  # a plain step finishes at once
    assert robot.behaviors[0].seen[-1] == "tick" and robot.error is None
