"""Beacons: the workload of the benchmarks and the radio tests (``behavior.py``). No oracle, no suite."""
