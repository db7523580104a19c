"""Experiments of the λ2 family: the paper's Fig. 2 (seed 003, Sec. II-B) in the emulator; see README.md."""
