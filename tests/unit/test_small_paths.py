"""The small-N paths of the world's tick give exactly what the numpy paths give.

``world.sensing.reach_small`` (every pair in Python floats, for a few robots) against ``reach_tree`` (the k-d
tree), and ``transport.rows.packb`` through msgspec (a few rows) against ``packb_numpy``: bit for bit, on
positions at and near the edge of the range, directed radii, dead robots, 1 to 3 dimensions.
"""

from __future__ import annotations

import msgpack
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from transport.rows import SMALL_ROWS, packb, packb_numpy
from world.sensing import SMALL_N, reach, reach_small, reach_tree

_COORD = st.one_of(st.sampled_from([0.0, 0.5, 0.75, 1.0, 1.5, -0.75, 0.1 + 0.2, 1e-9]),
                   st.floats(min_value=-3.0, max_value=3.0, allow_nan=False))
_RADIUS = st.one_of(st.sampled_from([0.0, 0.75, 1.0, 0.3 + 0.45]), st.floats(min_value=0.0, max_value=4.0))


@st.composite
def swarms(draw):
    dims = draw(st.integers(min_value=1, max_value=3))
    n = draw(st.integers(min_value=2, max_value=SMALL_N + 4))
    pos = np.array(draw(st.lists(st.lists(_COORD, min_size=dims, max_size=dims), min_size=n, max_size=n)))
    if draw(st.booleans()):  # a grid, as the scenarios place robots: many pairs exactly at the range
        pos = np.array([[(i % 4) * 0.5, (i // 4) * 0.5, 0.0][:dims] for i in range(n)])
    radii = np.array(draw(st.lists(_RADIUS, min_size=n, max_size=n)))
    if draw(st.booleans()):
        radii[:] = radii[0]
    alive = np.array(draw(st.lists(st.booleans(), min_size=n, max_size=n)))
    alive[:2] = True
    return pos, np.flatnonzero(alive).astype(np.int64), radii


@settings(max_examples=300, deadline=None)
@given(swarms())
def test_all_pairs_in_python_give_the_k_d_trees_table(case):
    pos, alive_ids, radii = case
    want = reach_tree(pos, alive_ids, radii)
    got = reach_small(pos, alive_ids, radii)
    assert got.indptr.dtype == want.indptr.dtype == np.int64 and got.nbrs.dtype == want.nbrs.dtype
    assert got.indptr.tolist() == want.indptr.tolist()
    assert got.nbrs.tolist() == want.nbrs.tolist()
    both = reach(pos, alive_ids, radii)
    assert both.indptr.tolist() == want.indptr.tolist() and both.nbrs.tolist() == want.nbrs.tolist()


def test_a_negative_radius_goes_to_the_tree():
    pos = np.array([[0.0, 0.0], [0.5, 0.0], [5.0, 0.0]])
    ids = np.arange(3, dtype=np.int64)
    radii = np.array([-1.0, 1.0, 1.0])
    assert reach_small(pos, ids, radii) is None
    got, want = reach(pos, ids, radii), reach_tree(pos, ids, radii)
    assert got.indptr.tolist() == want.indptr.tolist() and got.nbrs.tolist() == want.nbrs.tolist()


_INT = st.one_of(st.sampled_from([0, 1, 31, 127, 128, 255, 256, 65_535, 65_536, 2**32 - 1, 2**32, -1, -32, -33,
                                  -128, -129, -32_768, -32_769, -2**31, -2**31 - 1, 2**63 - 1, -2**63]),
                 st.integers(min_value=-2**63, max_value=2**63 - 1))


@settings(max_examples=300, deadline=None)
@given(st.integers(min_value=1, max_value=6).flatmap(
    lambda w: st.lists(st.lists(_INT, min_size=w, max_size=w), min_size=1, max_size=60)))
def test_few_rows_pack_as_the_numpy_path_and_msgpack(rows):
    array = np.array(rows, dtype=np.int64)
    assert packb(array) == packb_numpy(array) == msgpack.packb(rows, use_bin_type=True)


def test_many_rows_take_the_numpy_path():
    array = np.arange(4 * (SMALL_ROWS + 1), dtype=np.int64).reshape(-1, 4)
    assert packb(array) == msgpack.packb(array.tolist(), use_bin_type=True)
