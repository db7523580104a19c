"""Distributed estimation of the algebraic connectivity λ2 (Panerati et al., ICRA 2018, Sec. II-B).

Three spectral methods compared by the paper's Fig. 2, each as real message exchanges (one L2 frame per
robot per tick): PI1, power iteration with a beacon's norm flooded every ``period`` iterations (Bertrand &
Moonen [11]); PI2, power iteration, ``power`` steps per round, with the mean by average consensus and the
scale by max-consensus in the same frames (Di Lorenzo & Barbarossa [14]); Wave, the wave equation on the
graph and the FFT of each robot's own signal (Sahai et al. [17]). ``rules`` holds the pure updates,
``messages`` the frame body, ``behavior`` the robot side, ``oracle`` the checks against numpy's eigenvalues
of the true Laplacian, ``suite`` the conformance family, ``experiments`` the paper's Fig. 2. Every reading of
the garbled text and every choice: docs/protocols/lambda2.md.
"""
