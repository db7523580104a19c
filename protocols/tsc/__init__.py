"""The Task Scheduling Controller of Panerati et al. (ICRA 2018, §III-C/D): TCTM and TDSM on HiGHS.

A family of its own (``suite.py``): no behaviour and no oracle check, one subcommand, ``swarmactors schedule``
(``schedule_cli.py``), which the family contributes to the command line. Import-light: the MILP solver
(scipy), the checker and the plots live in submodules imported only by who needs them:

- ``protocols.tsc.schedule``: TCTM (Eqs. 4-13) and TDSM (Eq. 14) as MILPs on HiGHS, instances as in §IV-B.
- ``protocols.tsc.schedule_check``: the independent feasibility check of a returned schedule.
- ``protocols.tsc.schedule_plot``: a schedule drawn like the paper's Fig. 6.
- ``protocols.tsc.schedule_cli``: ``swarmactors schedule TASKS.toml``, and the sequence it hands to SECS.
- ``protocols.tsc.experiments``: Table II and Figs. 6-8 (a script and its sweep file).

The SECS navigation controller that carries a schedule out is the family ``secs``. See docs/protocols/tsc.md.
"""

__all__: list[str] = []
