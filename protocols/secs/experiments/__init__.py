"""SECS navigation (seed 003): Table I, Fig. 4/5 and T = 5 as scripts and sweep files; see README.md here."""
