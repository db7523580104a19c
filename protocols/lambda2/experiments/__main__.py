"""``python -m protocols.lambda2.experiments [options]``: the Fig. 2 experiment (``fig2.main``; see README.md)."""

from protocols.lambda2.experiments.fig2 import main

main()
