"""The tools around runs: viewing, replaying, plotting, exporting, sweeping, scaffolding.

* ``viewer``, ``scene``, ``replay``, ``see`` (the ``view``, ``replay`` and ``sweep`` commands), ``plots``,
  ``trajectories``, ``charts``, ``draw_space``: seeing a run, live or from its trace.
* ``export``, ``mcap_export``, ``foxglove_topics``, ``foxglove_live``: a run as tables, as MCAP, as a Foxglove feed.
* ``sweep``: parameter sweeps; ``notebook``: runs from Jupyter; ``newproject``: ``swarmactors new``;
  ``suggest``: the "did you mean" of an unknown name.

The top layer of the core: loaded by the command line, notebooks and tests, never by a robot host, and imported
by neither ``swarmactors.runs``, ``swarmactors.oracle`` nor ``swarmactors.robot`` (a ``lint-imports`` contract
checks it). Heavy optional dependencies (matplotlib, aiohttp, foxglove, pandas) stay imported where they are used.
"""
