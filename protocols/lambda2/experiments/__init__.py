"""Experiments of the λ2 family: the paper's Fig. 2 (seed 003, Sec. II-B) in the emulator; see README.md."""

# The paper's figures this package reproduces, for ``swarmactors figures`` (swarmactors/tools/figures.py).
FIGURES = [
    {"id": "lambda2-fig2", "paper": "seed 003, Fig. 2",
     "title": "iterations until the λ2 estimate is within 1 %, against packet drop p (K = 10: PI1, PI2, wave)",
     "results": "results/fig2.json", "plot": "protocols.lambda2.experiments.fig2:replot",
     "images": ["lambda2-fig2.png", "lambda2-error.png"],
     "sweep": "protocols/lambda2/experiments/fig2.toml",
     "script": ["-m", "protocols.lambda2.experiments.fig2", "--jobs", "2", "--graphs0", "20", "--graphs", "20"],
     "docs": "protocols/lambda2.md#fig-2-iterations-to-converge-against-packet-drop",
     "repetitions": "20 random geometric graphs per point"},
]
