"""The TSC's paper experiments (Table II, Figs. 6-8): ``tsc_experiments.py`` and its sweep file (README.md)."""

# The paper's figures this package reproduces, for ``swarmactors figures`` (swarmactors/tools/figures.py).
FIGURES = [
    {"id": "tsc-table2", "paper": "seed 003, Table II and Figs. 7-8",
     "title": "TCTM and TDSM solve times per class and density; dislocation and arm cost, TDSM against TCTM",
     "results": "../../../benchmarks/results/tsc.json", "plot": "protocols.tsc.experiments.tsc_experiments:replot",
     "images": ["tsc-times.png", "tsc-dislocation.png", "tsc-arms.png"],
     "sweep": "protocols/tsc/experiments/tsc-table2.toml",
     "script": ["-m", "protocols.tsc.experiments.tsc_experiments", "--resume"], "trials": "--per-cell",
     "docs": "protocols/tsc.md#results-beside-the-papers-table-ii-figs-68",
     "repetitions": "the paper's instance count per cell (24 here: 720 instances)"},
    {"id": "tsc-fig6", "paper": "seed 003, Fig. 6", "title": "one instance's TCTM and TDSM schedules",
     "results": "../../../benchmarks/results/tsc.json", "plot": None, "images": ["tsc-schedule.png"],
     "script": ["-m", "protocols.tsc.experiments.tsc_experiments", "--resume"],
     "docs": "protocols/tsc.md#fig-6-one-schedule", "repetitions": "one instance"},
]
