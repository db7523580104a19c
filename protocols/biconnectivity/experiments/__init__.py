"""Biconnectivity (seed 001): the paper's coverage experiment and figures; see README.md here."""
