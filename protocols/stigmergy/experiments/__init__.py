"""Virtual stigmergy: convergence, cost and elections measured in the emulator; see README.md here."""

# The figures this package draws, for ``swarmactors figures`` (swarmactors/tools/figures.py).
FIGURES = [
    {"id": "stigmergy-convergence", "paper": "virtual stigmergy (seed 002 uses it; no paper figure)",
     "title": "convergence ticks and frames per robot, N = 10 … 200, loss 0 … 0.3, anti-entropy on/off",
     "results": "results/convergence.json", "plot": "protocols.stigmergy.experiments.convergence:replot",
     "images": ["stigmergy-convergence.png"], "sweep": "protocols/stigmergy/experiments/convergence.toml",
     "script": ["-m", "protocols.stigmergy.experiments.convergence", "--jobs", "2"],
     "docs": "protocols/stigmergy.md#measured", "repetitions": "3 seeds per point (no paper figure)"},
]
