"""CBAA: rounds, equality with greedy and score against the optimum on random instances; see README.md here."""

# The figures this package draws, for ``swarmactors figures`` (swarmactors/tools/figures.py).
FIGURES = [
    {"id": "cbaa-instances", "paper": "CBAA (seed 002's recruiting): N_min·D bound, greedy, 1/2 guarantee",
     "title": "rounds against the N_min·D bound and the diameter; score against the optimum, 160 instances",
     "results": "results/instances.json", "plot": "protocols.cbaa.experiments.instances:replot",
     "images": ["cbaa-rounds-and-ratio.png"], "sweep": "protocols/cbaa/experiments/instances.toml",
     "script": ["-m", "protocols.cbaa.experiments.instances", "--jobs", "2"],
     "docs": "protocols/cbaa.md#measured", "repetitions": "160 instances (no paper figure)"},
]
