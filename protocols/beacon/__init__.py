"""Beacons: the workload of the benchmarks and the radio tests (``behavior.py``; ``suite.py`` registers it).

No oracle, no conformance suite.
"""
