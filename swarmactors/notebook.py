"""Running swarms from Jupyter (or any code that already runs an asyncio loop).

``swarmactors.launcher.run`` calls ``asyncio.run``, which refuses to start inside a running loop, as in a
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
import copy
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from swarmactors.result import Result


def _resolve(scenario, processes: int | None, overrides, settings) -> dict:
    from swarmactors.scenario import read_raw, resolve_scenario, set_value

    if hasattr(scenario, "raw"):  # a swarmactors.Scenario
        raw, source = copy.deepcopy(scenario.raw), f"<Scenario {scenario.raw['run'].get('name')}>"
    elif isinstance(scenario, dict):
        raw, source = copy.deepcopy(scenario), "<dict>"
    else:
        raw, source = read_raw(scenario), str(scenario)
    for key, value in settings.items():
        set_value(raw, key.replace("__", "."), value, source)
    if processes is not None:
        set_value(raw, "run.processes", processes, source)
    return resolve_scenario(raw, source, list(overrides))


async def arun(scenario, *, out: str | Path | None = None, processes: int | None = None,
               overrides: list[str] = (), **settings) -> Result:
    """``swarmactors.launcher.run`` as a coroutine, for code that already runs an asyncio loop.

    Args:
        scenario: a TOML path, a dict as parsed from TOML, or a ``swarmactors.Scenario``.
        out: output directory (default ``out/<run.name>``).
        processes: robot host processes (0: robots in this process).
        overrides: ``"section.key=value"`` strings, as on the command line.
        **settings: overrides written ``section__key=value``.

    Returns:
        The run's Result.
    """
    from swarmactors.launcher import new_run_id, run_world
    from transport import Endpoints

    sc = _resolve(scenario, processes, overrides, settings)
    out_dir = Path(out) if out is not None else Path("out") / sc["run"]["name"]
    endpoints = Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"])
    return await run_world(sc, out_dir, endpoints, new_run_id(sc["run"]["name"]), processes=sc["run"]["processes"])


def run_anywhere(scenario, **kwargs) -> Result:
    """``swarmactors.launcher.run`` that also works inside a running event loop (in a worker thread then)."""
    from swarmactors.launcher import run

    try:
        asyncio.get_running_loop()
    except RuntimeError:
        return run(scenario, **kwargs)
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="swarmactors-run") as pool:
        return pool.submit(run, scenario, **kwargs).result()
