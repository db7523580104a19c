"""The counter-based generator ``world/rng.py``, without Zenoh.

Rules tested:

* ``hash64(seed, *fields)`` is SplitMix64's finaliser applied to the seed and then to each field in turn; it
  equals a pure-Python big-integer reference written out here (so numpy's wrapping uint64 arithmetic, the
  int64 -> uint64 view of negative fields and the masking of large or negative seeds are right, and the
  stream cannot change silently: recorded trace hashes depend on it);
* ``uniform`` is the top 53 bits of ``hash64`` over 2**53, hence always in [0, 1);
* reproducibility: the same key gives the same value on every call, and a vectorised call (arrays,
  broadcast together) gives element for element what the scalar calls give;
* keys are distinct: field order and field count matter, and no collision among 2**17 neighbouring keys;
* independence: values keyed by neighbouring fields, neighbouring seeds or different streams are
  uncorrelated (Pearson r within a 99.9 % band, Bonferroni-corrected), every output bit is set half of the
  time, flipping one input bit flips 32 output bits on average (avalanche);
* uniformity: chi-square over 100 bins and Kolmogorov-Smirnov against U(0, 1) do not reject at 0.1 %.

The statistical tests use fixed keys, so they are deterministic: they pass or fail the same way every run.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from world import rng

ALPHA = 1e-3
MASK = (1 << 64) - 1
GOLDEN = 0x9E3779B97F4A7C15
INT64 = st.integers(min_value=-(2**63), max_value=2**63 - 1)
SEEDS = st.integers(min_value=-(2**70), max_value=2**70)
STREAMS = (rng.LOSS, rng.LATENCY, rng.BURST, rng.PLACEMENT, rng.NOISE)


def _splitmix_finaliser(z: int) -> int:
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
    return z ^ (z >> 31)


def reference_hash(seed: int, *fields: int) -> int:
    """Pure-Python big-integer reference: finalise the seed, then combine each field in turn."""
    state = _splitmix_finaliser(((seed & MASK) + GOLDEN) & MASK)
    for value in fields:
        v = value & MASK  # an int64 field as its two's-complement uint64
        state = _splitmix_finaliser(state ^ ((v + GOLDEN + (state << 6) + (state >> 2)) & MASK))
    return state


@settings(max_examples=100, deadline=None)
@given(SEEDS, st.lists(INT64, max_size=6))
def test_hash64_equals_the_big_integer_reference(seed, fields):
    assert int(rng.hash64(seed, *fields)) == reference_hash(seed, *fields)


@settings(max_examples=100, deadline=None)
@given(SEEDS, st.lists(INT64, max_size=6))
def test_uniform_is_the_top_53_bits_and_lies_in_unit_interval(seed, fields):
    u = float(rng.uniform(seed, *fields))
    assert u == (reference_hash(seed, *fields) >> 11) / 2.0**53
    assert 0.0 <= u < 1.0
    assert float(rng.uniform(seed, *fields)) == u  # same key, same value


def test_uniform_upper_end_stays_below_one():
    # the largest possible hash maps below 1: (2**64 - 1) >> 11 = 2**53 - 1
    assert ((MASK >> 11) / 2.0**53) < 1.0
    assert (np.uint64(MASK) >> np.uint64(11)).astype(np.float64) * (1.0 / (1 << 53)) < 1.0


@settings(max_examples=60, deadline=None)
@given(st.integers(min_value=0, max_value=2**64 - 1), st.sampled_from(STREAMS), INT64, INT64, INT64,
       st.lists(INT64, min_size=1, max_size=20))
def test_vectorised_call_equals_scalar_calls(seed, stream, tick, src, seq, dsts):
    vec = rng.uniform(seed, stream, tick, src, seq, np.array(dsts, dtype=np.int64))
    assert vec.shape == (len(dsts),)
    for k, dst in enumerate(dsts):
        assert vec[k] == rng.uniform(seed, stream, tick, src, seq, dst)


def test_broadcast_over_two_fields_equals_scalar_calls():
    srcs = np.arange(-3, 9)
    dsts = np.arange(0, 40, 3)
    grid = rng.uniform(11, rng.NOISE, 5, srcs[:, None], 7, dsts[None, :])
    assert grid.shape == (len(srcs), len(dsts))
    for a, s in enumerate(srcs.tolist()):
        for b, d in enumerate(dsts.tolist()):
            assert grid[a, b] == rng.uniform(11, rng.NOISE, 5, s, 7, d)
            assert int(rng.hash64(11, rng.NOISE, 5, s, 7, d)) == reference_hash(11, rng.NOISE, 5, s, 7, d)


def test_field_order_and_count_matter():
    assert rng.uniform(1, rng.LOSS, 0, 1, 2, 3) != rng.uniform(1, rng.LOSS, 0, 2, 1, 3)
    assert rng.uniform(1, rng.LOSS, 0, 1, 2, 3) != rng.uniform(1, rng.LOSS, 0, 1, 3, 2)
    assert rng.uniform(1, rng.LOSS, 0, 1, 2) != rng.uniform(1, rng.LOSS, 0, 1, 2, 0)
    assert rng.uniform(1) != rng.uniform(1, 0)


def test_no_collisions_among_neighbouring_keys():
    a = np.arange(1 << 9)
    b = np.arange(1 << 8)
    h = rng.hash64(3, rng.LOSS, 0, a[:, None], b[None, :], 0).ravel()  # 2**17 keys: (src, seq) in a grid
    assert np.unique(h).size == h.size


def _pearson_bound(n: int, tests: int) -> float:
    """Half-width of the two-sided (1 - ALPHA) band of Pearson's r for independent samples, Bonferroni-corrected."""
    z = stats.norm.ppf(1 - ALPHA / (2 * tests))
    return z / np.sqrt(n)


N = 50_000
_IDX = np.arange(N)
# (description, first key, second key): keys that differ in one neighbouring field; _IDX varies over the sample
_PAIRS = [
    ("dst and dst+1", (1, rng.LOSS, 4, 2, 9, _IDX), (1, rng.LOSS, 4, 2, 9, _IDX + 1)),
    ("seq and seq+1", (1, rng.LOSS, 4, 2, _IDX, 3), (1, rng.LOSS, 4, 2, _IDX + 1, 3)),
    ("src and src+1", (1, rng.LOSS, 4, 2, 9, _IDX), (1, rng.LOSS, 4, 3, 9, _IDX)),
    ("tick and tick+1", (1, rng.LOSS, _IDX, 2, 9, 3), (1, rng.LOSS, _IDX + 1, 2, 9, 3)),
    ("seed and seed+1", (1, rng.LOSS, 4, 2, 9, _IDX), (2, rng.LOSS, 4, 2, 9, _IDX)),
    ("LOSS and LATENCY", (1, rng.LOSS, 4, 2, 9, _IDX), (1, rng.LATENCY, 4, 2, 9, _IDX)),
    ("LOSS and NOISE", (1, rng.LOSS, 4, 2, 9, _IDX), (1, rng.NOISE, 4, 2, 9, _IDX)),
    ("NOISE 2j and 2j+1", (1, rng.NOISE, 4, 2, 2 * _IDX), (1, rng.NOISE, 4, 2, 2 * _IDX + 1)),
    ("PLACEMENT and BURST", (1, rng.PLACEMENT, 4, 2, _IDX), (1, rng.BURST, 4, 2, _IDX)),
]


@pytest.mark.parametrize("first,second", [p[1:] for p in _PAIRS], ids=[p[0] for p in _PAIRS])
def test_neighbouring_keys_are_uncorrelated(first, second):
    x, y = rng.uniform(*first), rng.uniform(*second)
    r = float(np.corrcoef(x, y)[0, 1])
    assert abs(r) < _pearson_bound(N, len(_PAIRS)), r
    # rank correlation too: a monotone but non-linear dependence would show here
    rho = stats.spearmanr(x, y).statistic
    assert abs(rho) < _pearson_bound(N, len(_PAIRS)), rho


_VARYING = {
    "dst": lambda n: rng.uniform(7, rng.LOSS, 3, 1, 2, np.arange(n)),
    "seq": lambda n: rng.uniform(7, rng.LOSS, 3, 1, np.arange(n), 0),
    "tick": lambda n: rng.uniform(7, rng.LATENCY, np.arange(n), 1, 2, 0),
    "observed": lambda n: rng.uniform(7, rng.NOISE, 3, 1, np.arange(n)),
}


@pytest.mark.parametrize("name", sorted(_VARYING))
def test_uniformity_chi_square_and_ks(name):
    n = 200_000
    u = _VARYING[name](n)
    assert u.min() >= 0.0 and u.max() < 1.0
    counts, _ = np.histogram(u, bins=100, range=(0.0, 1.0))
    chi = stats.chisquare(counts)
    assert chi.pvalue > ALPHA, chi
    ks = stats.kstest(u, "uniform")
    assert ks.pvalue > ALPHA, ks


def test_every_output_bit_is_balanced():
    n = 100_000
    h = rng.hash64(5, rng.LOSS, 0, 1, 2, np.arange(n))
    bits = ((h[:, None] >> np.arange(64, dtype=np.uint64)[None, :]) & np.uint64(1)).astype(np.int64)
    share = bits.mean(axis=0)
    z = stats.norm.ppf(1 - ALPHA / (2 * 64))
    assert np.all(np.abs(share - 0.5) < z * 0.5 / np.sqrt(n)), share


@pytest.mark.parametrize("field", [1, 2, 3, 4])  # tick, src, seq, dst (field 0 is the stream)
def test_flipping_one_input_bit_flips_half_the_output_bits(field):
    n = 20_000
    keys = np.random.default_rng(field).integers(0, 2**40, size=(5, n))
    base = rng.hash64(9, *keys)
    z = stats.norm.ppf(1 - ALPHA / (2 * 12 * 4))
    for bit in range(12):  # low bits: neighbouring ids and ticks differ there
        flipped = keys.copy()
        flipped[field] ^= 1 << bit
        changed = np.bitwise_count(base ^ rng.hash64(9, *flipped)).astype(float)
        # Binomial(64, 1/2) per key: mean 32, standard deviation 4
        assert abs(changed.mean() - 32.0) < z * 4.0 / np.sqrt(n), (bit, changed.mean())
