"""Swarm Relays (seed 002): the paper's Figs. 6 and 7 as scripts and sweep files; see README.md here."""
