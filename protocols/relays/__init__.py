"""Swarm Relays (Varadharajan et al. 2020): self-healing connectivity chains from a root to targets.

behavior.py is the robot side (roles, stigmergy plan sharing, elections, CBAA recruiting, Eqs. 6-8,
self-healing); zones.py, planner.py and motion.py its pure rules; oracle.py the checks; suite.py the
scenarios and the conformance family. docs/protocols/relays.md is the specification as built.
"""
