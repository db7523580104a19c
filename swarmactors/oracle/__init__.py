"""The oracle: judging a finished run from what it recorded, with the full knowledge no robot has.

* ``trace``: trace files, their readers and the trace hash; ``trace_tables``: the tables a trace holds.
* ``result``: result.json, built from the world's summary and the trace, and read back (``Result``, networkx).
* ``checks``: the oracle verdicts on a run (``Outcome``); ``world_checks``: the world's own rules
  (``world.no_collisions``); ``occlusion_oracle``: an independent oracle for radio occlusion (shapely).

Loaded by the launcher (which writes result.json through ``result``), by the conformance kit, the tools and
tests; never by a robot host. It sits above ``swarmactors.robot`` and below ``swarmactors.runs``: it imports
neither ``swarmactors.runs`` nor ``swarmactors.tools`` (a ``lint-imports`` contract checks it).
"""
