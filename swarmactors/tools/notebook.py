"""Running swarms from Jupyter (or any code that already runs an asyncio loop).

``swarmactors.runs.launcher.run`` calls ``asyncio.run``, which refuses to start inside a running loop, as in a
Jupyter cell. Two ways around it:

* ``await arun(scenario, ...)``: the same arguments as ``run``; the world (and, with K = 0, the robots) run as
  tasks of the caller's loop. In a notebook: ``result = await arun("flooding.toml")``.
* ``run_anywhere(scenario, ...)``: a plain call that works everywhere: without a running loop it is ``run``;
  inside one it runs ``run`` in a worker thread and waits for it.

Classes defined in a notebook cell live in ``__main__`` of the kernel, which spawned host processes cannot
import: use them with K = 0 (the default: robots in this process), or put them in a module file next to the
notebook for ``processes`` ≥ 1.
"""

from __future__ import annotations

import asyncio
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from swarmactors.oracle.result import Result


async def arun(scenario, *, out: str | Path | None = None, processes: int | None = None,
               overrides: list[str] = (), **settings) -> Result:
    """``swarmactors.runs.launcher.run`` as a coroutine, for code that already runs an asyncio loop.

    Args:
        scenario: a TOML path, a dict as parsed from TOML, or a ``swarmactors.Scenario``.
        out: output directory (default ``out/<run.name>/<UTC time>-s<seed>``, with ``out/<run.name>/latest``).
        processes: robot host processes (0: robots in this process).
        overrides: ``"section.key=value"`` strings, as on the command line.
        **settings: overrides written ``section__key=value``.

    Returns:
        The run's Result.
    """
    from swarmactors.runs.launcher import arun as _arun

    return await _arun(scenario, out=out, processes=processes, overrides=overrides, **settings)


def run_anywhere(scenario, **kwargs) -> Result:
    """``swarmactors.runs.launcher.run`` that also works inside a running event loop (in a worker thread then)."""
    from swarmactors.runs.launcher import run

    try:
        asyncio.get_running_loop()
    except RuntimeError:
        return run(scenario, **kwargs)
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="swarmactors-run") as pool:
        return pool.submit(run, scenario, **kwargs).result()
