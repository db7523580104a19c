"""Observer streams never slow the run: a slow viewer loses snapshots, not ticks."""

from __future__ import annotations

import asyncio
import multiprocessing
import time

import pytest

from swarmactors.runs.launcher import new_run_id, run_world
from swarmactors.runs.scenario import resolve_scenario
from transport import Endpoints, Keys, make_config

pytestmark = pytest.mark.slow  # runs a world over Zenoh

TICKS = 400
SLEEP = 0.25  # seconds the viewer spends on each snapshot: 100 s if it held every tick back


def slow_viewer(endpoint: str, run_id: str, counter, ready) -> None:
    import zenoh

    session = zenoh.open(make_config(Endpoints(mode="peer", connect=[endpoint])))

    def on_state(sample) -> None:
        with counter.get_lock():
            counter.value += 1
        time.sleep(SLEEP)

    sub = session.declare_subscriber(Keys(run_id).state, zenoh.handlers.Callback(on_state, indirect=False))
    ready.set()
    time.sleep(60)
    sub.undeclare()
    session.close()


def test_a_slow_viewer_loses_snapshots_not_ticks(tmp_path):
    raw = {"run": {"name": "obs", "ticks": TICKS, "trace": False},
           "robots": [{"count": 30, "placement": "grid", "spacing": 0.5, "behaviors": [{"use": "beacon"}]}]}
    sc = resolve_scenario(raw, "<test>")
    run_id = new_run_id("obs")
    ctx = multiprocessing.get_context("spawn")
    counter, ready = ctx.Value("i", 0), ctx.Event()
    viewer = []

    def on_open(world, link):
        viewer.append(ctx.Process(target=slow_viewer, args=(link.locators()[0], run_id, counter, ready), daemon=True))
        viewer[0].start()
        assert ready.wait(30)

    async def main():
        return await run_world(sc, tmp_path, Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]), run_id,
                               on_open=on_open)

    started = time.monotonic()
    result = asyncio.run(main())
    elapsed = time.monotonic() - started
    seen = counter.value
    viewer[0].kill()
    assert result["ticks"] == TICKS
    assert seen >= 1  # the viewer was really subscribed
    assert seen < TICKS / 4, seen  # it got only some of the snapshots ...
    assert elapsed < TICKS * SLEEP / 4, elapsed  # ... and the run did not wait for it (100 s if it had)
