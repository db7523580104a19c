"""Heterogeneous leader-follower navigation without collisions (Sano et al. 2022).

A sensing-only protocol: followers use only the vectors they sense to the closest point of the other bodies.
``rules`` holds the pure equations (Eqs. 9–24), ``behavior`` the robot side (leader and follower, no oracle
import), ``oracle`` the checks from the trace (spanning tree, target distance, speed, σ, assumptions),
``suite`` the scenarios (Table 1, Table 2, random configurations) and the conformance family. Every reading
of the garbled text and every choice: docs/protocols/leader_follower.md.
"""
