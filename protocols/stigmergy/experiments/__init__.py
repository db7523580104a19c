"""Virtual stigmergy: convergence, cost and elections measured in the emulator; see README.md here."""
