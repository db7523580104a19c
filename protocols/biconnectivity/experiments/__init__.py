"""Biconnectivity (seed 001): the paper's coverage experiment and figures; see README.md here."""

# The paper's figures this package reproduces, for ``swarmactors figures`` (swarmactors/tools/figures.py).
FIGURES = [
    {"id": "biconnectivity-coverage", "paper": "seed 001, §5 coverage (73 % / 91 %)",
     "title": "area covered after 100 episodes of additions and removals, cr = 4 and 2 (oracle-level)",
     "results": "results/paper.json", "plot": "protocols.biconnectivity.experiments.paper:replot_coverage",
     "images": ["biconnectivity-coverage.png"],
     "script": ["-m", "protocols.biconnectivity.experiments.paper", "--only", "coverage"],
     "docs": "protocols/biconnectivity.md#coverage", "repetitions": "the paper's 100 episodes; 30 seeds"},
    {"id": "biconnectivity-coverage-emulated", "paper": "seed 001, §5 coverage (73 % / 91 %)",
     "title": "the coverage experiment played by the robots through the emulator, cr = 4 and 2",
     "results": "results/paper.json", "plot": None,
     "sweep": "protocols/biconnectivity/experiments/coverage.toml",
     "docs": "protocols/biconnectivity.md#coverage-through-the-emulator",
     "repetitions": "100 episodes an experiment; 28 experiments per cr"},
    {"id": "biconnectivity-messages", "paper": "seed 001, §4 message counts",
     "title": "messages per robot and period of the check (ring of 35: the paper's 69)",
     "results": "results/paper.json", "plot": "protocols.biconnectivity.experiments.paper:replot_messages",
     "images": ["biconnectivity-messages.png"],
     "script": ["-m", "protocols.biconnectivity.experiments.paper", "--only", "messages"],
     "docs": "protocols/biconnectivity.md#messages-per-robot-and-period", "repetitions": "deterministic"},
    {"id": "biconnectivity-loss", "paper": "beyond the paper (loss)",
     "title": "the check's verdicts under per-frame loss", "results": "results/paper.json",
     "plot": "protocols.biconnectivity.experiments.paper:replot_loss", "images": ["biconnectivity-loss.png"],
     "script": ["-m", "protocols.biconnectivity.experiments.paper", "--only", "loss"],
     "docs": "protocols/biconnectivity.md#the-check-under-loss", "repetitions": "10 seeds per graph"},
]
