"""SECS navigation (seed 003): Table I, Fig. 4/5 and T = 5 as scripts and sweep files; see README.md here."""

# The paper's figures and tables this package reproduces, for ``swarmactors figures``
# (swarmactors/tools/figures.py): Table I is a table (docs/protocols/secs.md), Fig. 5 the trajectories of one run.
FIGURES = [
    {"id": "secs-table1", "paper": "seed 003, Table I",
     "title": "one task, N robots, δ = 120 and 240: latencies, reach, link redundancy",
     "results": "results/table1.json", "plot": None, "sweep": "protocols/secs/experiments/table1.toml",
     "docs": "protocols/secs.md#table-i-and-fig-5-protocolssecsexperimentstable1py",
     "repetitions": "the paper does not print its count; the sweep file has 5 repetitions"},
    {"id": "secs-fig5", "paper": "seed 003, Fig. 5",
     "title": "N = 16, three tasks 120° apart: trajectories of one run", "results": "results/table1.json",
     "plot": None, "images": ["secs_fig5.png"],
     "script": ["-m", "protocols.secs.experiments.fig5", "--seconds", "300", "--seed", "1"],
     "docs": "protocols/secs.md#table-i-and-fig-5-protocolssecsexperimentstable1py", "repetitions": "one run"},
]
