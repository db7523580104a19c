"""Role assignment (seed 000): the paper's Figs. 3-11 as a script and sweep files; see README.md here."""

# The paper's figures this package reproduces, for ``swarmactors figures`` (swarmactors/tools/figures.py).
FIGURES = [
    {"id": "roles-fig4-5", "paper": "seed 000, Figs. 4-5",
     "title": "Algorithm 2 against the every-tick acute angle test: cost and λ2, N = 10 … 100",
     "results": "results/paper.json", "plot": "protocols.roles.experiments.paper:replot_prelim",
     "images": ["roles-fig4-aat-cost.png", "roles-fig5-lambda2.png"],
     "sweep": "protocols/roles/experiments/fig3-5.toml",
     "script": ["-m", "protocols.roles.experiments.paper", "--only", "prelim"], "trials": "--trials",
     "docs": "protocols/roles.md#preliminary-experiment-iv-a-figs-35", "repetitions": "30 trials per N"},
    {"id": "roles-fig7-11", "paper": "seed 000, Figs. 7-11",
     "title": "the patrol: disconnections, processing time per robot and role, received messages, N = 10 … 50",
     "results": "results/paper.json", "plot": "protocols.roles.experiments.paper:replot_main",
     "images": ["roles-fig7-disconnections.png", "roles-fig8-per-robot.png", "roles-fig9-per-role.png",
                "roles-fig10-11-cost-messages.png", "roles-fig7-witnesses.png"],
     "sweep": "protocols/roles/experiments/fig6-11.toml",
     "script": ["-m", "protocols.roles.experiments.paper", "--only", "main"], "trials": "--trials",
     "docs": "protocols/roles.md#patrol-iv-b-figs-611", "repetitions": "30 trials per N"},
    {"id": "roles-fig3-6", "paper": "seed 000, Figs. 3 and 6",
     "title": "snapshots of one run: the topology (Fig. 3) and the patrol (Fig. 6)",
     "results": "results/paper.json", "plot": None,
     "images": ["roles-fig3-topology.png", "roles-fig6-patrol.png"],
     "script": ["-m", "protocols.roles.experiments.paper", "--replot"],
     "docs": "protocols/roles.md#patrol-iv-b-figs-611", "repetitions": "one run each"},
]
