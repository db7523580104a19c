"""Leader-follower (seed 004): the paper's figures, the start search and the sweeps; see README.md here."""

# The paper's figures this package reproduces, for ``swarmactors figures`` (swarmactors/tools/figures.py):
# trajectories of single runs, so they are drawn by running them (about a minute), not from saved results.
FIGURES = [
    {"id": "leader_follower-5.1", "paper": "seed 004, §5.1 Figs. 7-9",
     "title": "the proposed and the prior method from the same start: trajectories, distances, σ",
     "results": "results/starts.json", "plot": None,
     "images": ["leader_follower_proposed.png", "leader_follower_prior.png"],
     "script": ["-m", "protocols.leader_follower.experiments.paper"],
     "docs": "protocols/leader_follower.md#experiments-ours-beside-the-papers", "repetitions": "one run each"},
    {"id": "leader_follower-5.2", "paper": "seed 004, §5.2 Figs. 10-11",
     "title": "the heterogeneous experiment: trajectories and distances", "results": "results/starts.json",
     "plot": None, "images": ["leader_follower_experiment.png"],
     "script": ["-m", "protocols.leader_follower.experiments.paper"],
     "docs": "protocols/leader_follower.md#experiments-ours-beside-the-papers", "repetitions": "one run"},
    {"id": "leader_follower-starts", "paper": "beyond the paper", "title": "prior vs proposed over 200 random starts",
     "results": "results/starts.json", "plot": None, "sweep": "protocols/leader_follower/experiments/starts.toml",
     "docs": "protocols/leader_follower.md#beyond-the-paper", "repetitions": "200 starts"},
]
