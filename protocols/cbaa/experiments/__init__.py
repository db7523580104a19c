"""CBAA: rounds, equality with greedy and score against the optimum on random instances; see README.md here."""
