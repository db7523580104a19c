"""Panerati et al. (ICRA 2018): the Task Scheduling Controller and the SECS navigation controller.

Import-light on purpose: robot hosts may import this package, so the MILP solver (scipy), the checker and the
plots live in submodules that are imported only by who needs them:

- ``protocols.secs.schedule``: TCTM (Eqs. 4-13) and TDSM (Eq. 14) as MILPs on HiGHS, instances as in §IV-B.
- ``protocols.secs.schedule_check``: the independent feasibility check of a returned schedule.
- ``protocols.secs.schedule_plot``: a schedule drawn like the paper's Fig. 6.
- ``protocols.secs.behavior``: the Robot Navigation Controller's robot side (SECS prominences with the ∠T and
  ∠M messages, rendez-vous, flocking; §III-B), built on the pure rules of ``protocols.secs.rules``.
- ``protocols.secs.oracle``: its checks (connected at every tick, tasks reached, ∠T against the truth);
  ``protocols.secs.suite``: the conformance family ``secs``; ``protocols.secs.scenarios``: the §IV-A set-up.

See docs/protocols/tsc.md and docs/protocols/secs.md.
"""

__all__: list[str] = []
