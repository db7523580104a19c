"""The TSC's paper experiments (Table II, Figs. 6-8): ``tsc_experiments.py`` and its sweep file (README.md)."""
