"""A robot-host process: its entry point, its Zenoh session, its garbage-collector setting.

Kept apart from ``swarmactors.launcher`` (which imports the world, and so scipy) so that a host process
imports only the robot side: the Behavior API, the host, the transport and the behaviours it runs
(tests/test_host_imports.py checks that no oracle, networkx or scipy reaches it).
"""

from __future__ import annotations

import asyncio
import gc
import logging
from collections.abc import Collection
from contextlib import contextmanager

from swarmactors.host import RobotHost
from transport import Endpoints, Keys, Link


def host_process(endpoint: str, run_id: str, count: int | None, allow: tuple[str, ...] = ()) -> None:
    """Entry point of a spawned robot-host process."""
    logging.basicConfig(level=logging.WARNING)
    try:
        asyncio.run(serve_host(Endpoints(mode="peer", connect=[endpoint]), run_id, count, allow))
    except KeyboardInterrupt:  # Ctrl-C reaches the whole process group; the world ends the run
        pass


async def serve_host(endpoints: Endpoints, run_id: str, count: int | None, allow: Collection[str] = ()) -> None:
    """Join run ``run_id`` through ``endpoints`` and run robots until the world stops.

    ``allow``: modules whose Behavior subclasses the host may build, beside the registered entry points.
    """
    with Link(endpoints) as link, quiet_gc():
        host = RobotHost(link, Keys(run_id), count, allow)
        await host.join()
        await host.run()


@contextmanager
def quiet_gc():
    """Tune the garbage collector for a run: freeze what set-up allocated, collect rarely.

    A full collection walks every object (about 120,000 after importing scipy
    and networkx), and pauses of ~100 ms at N = 1000 took half the wall time
    (docs/benchmarks.md). Outcomes and trace hashes do not depend on it.
    """
    old = gc.get_threshold()
    gc.collect()
    gc.freeze()
    gc.set_threshold(50_000, 50, 1000)
    try:
        yield
    finally:
        gc.set_threshold(*old)
        gc.unfreeze()
