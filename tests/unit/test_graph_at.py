"""The oracle's radio graph (``Result.graph_at``) against the product's "who is in range" (issue 13).

The two are computed independently: the world's radio takes each robot's reach from ``world.sensing.within``
and drops what a cut or a partition severs (``Medium``); the oracle replays the trace. A bug in one must not
hide in both, so they are compared on random swarms with random cuts and partitions. Coordinates and ranges
are multiples of 1/4, so that distances at the range's edge are exact in both (the rounding there is
tests/unit/test_radio_rules.py's business).
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmactors.oracle.result import Result
from transport.scenario import Radio
from world.radio import Medium
from world.sensing import within

quarter = st.integers(min_value=0, max_value=24).map(lambda k: k / 4)


@st.composite
def swarms(draw):
    n = draw(st.integers(min_value=0, max_value=12))
    ids = sorted(draw(st.sets(st.integers(min_value=0, max_value=40), min_size=n, max_size=n)))
    pos = [[draw(quarter), draw(quarter)] for _ in ids]
    ranges = {i: draw(st.integers(min_value=1, max_value=12).map(lambda k: k / 4)) for i in ids}
    pairs = [(a, b) for a in ids for b in ids if a < b]
    cuts = draw(st.lists(st.sampled_from(pairs), max_size=5)) if pairs else []
    groups = None
    if ids and draw(st.booleans()):
        labels = [draw(st.integers(min_value=0, max_value=2)) for _ in ids]
        groups = [[i for i, lab in zip(ids, labels, strict=True) if lab == g] for g in range(3)]
        groups = [g for g in groups if g]
    return ids, pos, ranges, cuts, groups


def _oracle(ids, pos, ranges, cuts, groups) -> Result:
    ev = [{"cut": [list(c) for c in cuts]}] if cuts else []
    if groups is not None:
        ev.append({"partition": groups})
    result = Result({"robots": {str(i): {"range": ranges[i]} for i in ids}})
    result.__dict__["trace"] = [{"t": 0, "pos": [[i, *p] for i, p in zip(ids, pos, strict=True)], "ev": ev}]
    return result


def _product(ids, pos, ranges, cuts, groups) -> set[tuple[int, int]]:
    size = max(ids, default=-1) + 1
    xy = np.zeros((size, 2))
    radii = np.zeros(size)
    for i, p in zip(ids, pos, strict=True):
        xy[i], radii[i] = p, ranges[i]
    medium = Medium(Radio(), seed=1)
    for a, b in cuts:
        medium.cut(a, b)
    if groups is not None:
        medium.partition(groups)
    reach = within(xy, np.array(ids, dtype=int), radii)
    return {(i, int(j)) for i, js in reach.items() for j in js if not medium.links.severed(i, int(j))}


@settings(max_examples=300, deadline=None)
@given(swarms())
def test_the_oracle_graph_is_the_product_reach_minus_what_is_severed(swarm):
    ids = swarm[0]
    want = _product(*swarm)
    directed = _oracle(*swarm).graph_at(0, directed=True)
    assert sorted(directed.nodes) == ids
    assert set(directed.edges) == want
    mutual = {(a, b) for a, b in want if a < b and (b, a) in want}
    assert {tuple(sorted(e)) for e in _oracle(*swarm).graph_at(0).edges} == mutual
