"""Sensing rules of ``world/sensing.py`` (``within``, ``sense``), without Zenoh.

Rules tested, against brute force and statistics computed here:

* who is sensed (``within``, used for radio reach and for sensing): for each alive robot i, exactly the alive
  robots j != i with |x_j - x_i| <= radius_i, sorted; dead robots neither sense nor are sensed; radii differ
  per robot (directed); 2-D and 3-D;
* what is sensed (``sense``): per observer, the ids in the given order and their positions flattened,
  rounded to ``digits`` decimals; exact (rounded) when the observer's noise is 0;
* noise: with noise sigma > 0, Gaussian noise is added to x and y only (z is exact): per axis the mean lies in
  a 99.9 % band around 0, the variance in a 99.9 % chi-square interval around sigma**2, the standardised
  errors pass a Kolmogorov-Smirnov test against N(0, 1), and x and y errors are uncorrelated;
* the noise is keyed on (seed, tick, observer, observed): reproducible, independent of which other robots the
  observer senses, different (uncorrelated) for another observer, tick or seed.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from world.sensing import sense, within

ALPHA = 1e-3
EDGE = 1e-9


@st.composite
def swarms(draw):
    n = draw(st.integers(min_value=1, max_value=14))
    dims = draw(st.sampled_from([2, 3]))
    coord = st.integers(min_value=0, max_value=250).map(lambda k: k / 100)
    pos = [[draw(coord) for _ in range(dims)] for _ in range(n)]
    radii = draw(st.lists(st.sampled_from([0.3, 0.5, 1.0, 1.3, 2.0]), min_size=n, max_size=n))
    alive = draw(st.lists(st.sampled_from([True, True, False]), min_size=n, max_size=n))
    return pos, radii, alive


@settings(max_examples=100, deadline=None)
@given(swarms())
def test_within_is_brute_force_neighbourhood(swarm):
    pos, radii, alive = swarm
    n = len(pos)
    alive_ids = np.array([i for i in range(n) if alive[i]], dtype=np.int64)
    got = within(np.array(pos, dtype=float), alive_ids, np.array(radii, dtype=float))
    assert set(got) == set(alive_ids.tolist())  # one entry per alive robot, none for the dead
    for i, ids in got.items():
        ids = ids.tolist()
        assert ids == sorted(ids) and i not in ids
        edge = {j for j in range(n) if abs(math.dist(pos[i], pos[j]) - radii[i]) <= EDGE}
        want = {j for j in range(n) if j != i and alive[j] and math.dist(pos[i], pos[j]) <= radii[i]}
        assert set(ids) - edge == want - edge, (i, ids, want)


def test_within_is_directed_for_different_radii():
    pos = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 0.5]])
    got = within(pos, np.arange(3), np.array([1.0, 0.5, 0.6]))
    assert {k: v.tolist() for k, v in got.items()} == {0: [1, 2], 1: [], 2: [0]}


def test_within_of_nobody_is_empty():
    assert within(np.zeros((3, 2)), np.array([], dtype=np.int64), np.ones(3)) == {}


def test_sense_without_noise_gives_the_rounded_positions_in_the_given_order():
    pos = np.array([[0.1234567891, 1.0, 2.0], [3.0, 4.0000004, 5.5], [6.0, 7.0, -8.00000051]])
    neighbours = {0: np.array([2, 1]), 1: np.array([], dtype=np.int64), 2: np.array([0])}
    got = sense(pos, neighbours, np.zeros(3), seed=1, tick=0, digits=6)
    assert got == {
        0: [[2, 1], [6.0, 7.0, -8.000001, 3.0, 4.0, 5.5]],
        1: [[], []],
        2: [[0], [0.123457, 1.0, 2.0]],
    }


def noisy_errors(sigma, seed, tick, n=6000, observer_count=1, dims=2, spread=3.0):
    """Each observer (noise sigma) senses robots observer_count..: (errors[observer][j, axis], observed ids)."""
    g = np.random.default_rng(seed)
    total = observer_count + n
    pos = g.uniform(-spread, spread, (total, dims))
    noise = np.zeros(total)
    noise[:observer_count] = sigma
    ids = np.arange(observer_count, total)
    got = sense(pos, {o: ids for o in range(observer_count)}, noise, seed, tick, digits=6)
    errors = {}
    for o in range(observer_count):
        got_ids, flat = got[o]
        assert got_ids == ids.tolist()
        errors[o] = np.array(flat).reshape(n, dims) - pos[ids]
    return errors, ids, pos


@pytest.mark.parametrize("sigma,seed,tick", [(0.05, 1, 0), (0.01, 2, 7), (0.5, 3, 123)])
def test_noise_is_gaussian_with_mean_zero_and_the_configured_std(sigma, seed, tick):
    errors, _, _ = noisy_errors(sigma, seed, tick)
    e = errors[0]
    n = len(e)
    tests = 2 * 3 + 1  # 2 axes x (mean, variance, KS), + correlation; Bonferroni
    z = stats.norm.ppf(1 - ALPHA / (2 * tests))
    for axis in (0, 1):
        x = e[:, axis]
        assert abs(x.mean()) < z * sigma / math.sqrt(n), (axis, x.mean())
        q = (n - 1) * x.var(ddof=1) / sigma**2
        lo, hi = stats.chi2.ppf(ALPHA / (2 * tests), n - 1), stats.chi2.ppf(1 - ALPHA / (2 * tests), n - 1)
        assert lo < q < hi, (axis, math.sqrt(x.var(ddof=1)), sigma)
        ks = stats.kstest(x / sigma, "norm")
        assert ks.pvalue > ALPHA / tests, (axis, ks)
    r = float(np.corrcoef(e[:, 0], e[:, 1])[0, 1])
    assert abs(r) < z / math.sqrt(n), r


def test_noise_leaves_z_exact_in_3d():
    errors, ids, pos = noisy_errors(0.1, 4, 2, n=500, dims=3)
    e = errors[0]
    assert np.all(np.abs(e[:, 2]) <= 5e-7 + 1e-12)  # only the rounding to 6 decimals
    assert np.std(e[:, 0]) > 0.05 and np.std(e[:, 1]) > 0.05


def test_noise_is_per_observer():
    pos = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]])
    neighbours = {0: np.array([1, 2]), 1: np.array([0, 2]), 2: np.array([0, 1])}
    got = sense(pos, neighbours, np.array([0.0, 0.2, 0.0]), seed=3, tick=1)
    assert got[0] == [[1, 2], [1.0, 1.0, 2.0, 2.0]]
    assert got[2] == [[0, 1], [0.0, 0.0, 1.0, 1.0]]
    assert got[1][0] == [0, 2] and got[1][1] != [0.0, 0.0, 2.0, 2.0]


def test_noise_is_reproducible_and_keyed_on_observer_and_observed():
    errors, ids, pos = noisy_errors(0.1, 5, 9, n=3000, observer_count=2)
    again, _, _ = noisy_errors(0.1, 5, 9, n=3000, observer_count=2)
    assert np.array_equal(errors[0], again[0]) and np.array_equal(errors[1], again[1])
    # the noise on robot j does not depend on the other robots the observer senses
    noise = np.zeros(len(pos))
    noise[0] = 0.1
    for j in (ids[0], ids[17], ids[-1]):
        alone = sense(pos, {0: np.array([j])}, noise, 5, 9)[0][1]
        assert np.allclose(np.array(alone) - pos[j], errors[0][j - ids[0]], atol=1e-12)
    # another observer, another tick, another seed: uncorrelated errors on the same robots
    band = stats.norm.ppf(1 - ALPHA / (2 * 6)) / math.sqrt(len(ids))
    other_tick, _, _ = noisy_errors(0.1, 5, 10, n=3000, observer_count=2)
    other_seed = sense(pos, {0: ids}, noise, 6, 9)[0][1]
    other_seed = np.array(other_seed).reshape(len(ids), 2) - pos[ids]
    for axis in (0, 1):
        for other in (errors[1], other_tick[0], other_seed):
            r = float(np.corrcoef(errors[0][:, axis], other[:, axis])[0, 1])
            assert abs(r) < band, (axis, r)
