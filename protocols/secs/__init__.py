"""Panerati et al. (ICRA 2018): the SECS navigation controller.

Import-light on purpose: robot hosts import this package. The Task Scheduling Controller whose schedule it
carries out is the family ``tsc`` (``protocols.tsc``); its modules' earlier paths here (``schedule``,
``schedule_check``, ``schedule_cli``, ``schedule_plot``) still import, with a DeprecationWarning.

- ``protocols.secs.behavior``: the Robot Navigation Controller's robot side (SECS prominences with the ∠T and
  ∠M messages, rendez-vous, flocking; §III-B), built on the pure rules of ``protocols.secs.rules``.
- ``protocols.secs.oracle``: its checks (connected at every tick, tasks reached, ∠T against the truth);
  ``protocols.secs.suite``: the conformance family ``secs``; ``protocols.secs.scenarios``: the §IV-A set-up.

See docs/protocols/tsc.md and docs/protocols/secs.md.
"""

__all__: list[str] = []
