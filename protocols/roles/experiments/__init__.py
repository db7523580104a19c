"""Role assignment (seed 000): the paper's Figs. 3-11 as a script and sweep files; see README.md here."""
