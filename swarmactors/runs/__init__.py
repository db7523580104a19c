"""Starting runs: scenarios, the launcher and its process layouts, the conformance kit.

* ``scenario`` (TOML files: loading, overrides, resolution), ``builder`` (``Scenario`` in code), ``schema``
  (the scenario model as JSON Schema and docs tables), ``maps`` (grid maps, mazes).
* ``launcher``: the world, its robot hosts, the trace and the result of a run over Zenoh; ``inprocess``: a
  lockstep run in one process without Zenoh; ``cluster``: trials on a Dask cluster; ``progress``: a run's live
  progress in the terminal.
* ``conformance``: the protocol families' suites, run and checked against their oracles.

Loaded by the command line, the tools, notebooks and tests; never by a robot host. The layer above
``swarmactors.oracle`` (the launcher writes result.json through it) and below ``swarmactors.tools``: it imports
no tool (a ``lint-imports`` contract checks it). Not to be confused with the function ``swarmactors.run``, which
runs a scenario.
"""
