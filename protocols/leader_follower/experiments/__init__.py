"""Leader-follower (seed 004): the paper's figures, the start search and the sweeps; see README.md here."""
