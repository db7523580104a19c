"""Protocol families, one package each.

Each has ``behavior.py`` (robot side, imports no oracle), pure helpers, ``oracle.py`` (checks) and ``suite.py``
(conformance cases).
"""
