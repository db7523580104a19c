"""Bursty loss (world/bursts.py, through world/radio.py), without Zenoh.

Rules tested, against the Gilbert-Elliott chain's own formulas and binomial intervals (99.9 %, z = 3.29):

* the stationary fraction of Bad states, and of lost frames, with states sampled far apart (independent);
* burst lengths, in ticks, with the pair evaluated every tick: geometric with P(length = 1) = p_bg and mean
  1 / p_bg (a burst ends each tick with p_bg);
* the closed form over unevaluated ticks: P(Bad at t + k | Bad at t) = pi_B + (1 - pi_B) (1 - p_gb - p_bg)^k;
* frames of the same tick share their pair's state; the states do not depend on the order of evaluation;
* through ``Medium.decide``: bursts replace the Bernoulli loss, and multiply with the distance model.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from transport.scenario import Radio
from world.bursts import GilbertElliott
from world.radio import Medium, Outgoing

Z = 3.29


def inside(k: int, n: int, p: float) -> bool:
    """Whether k successes in n trials are within the binomial interval of probability p."""
    return abs(k - n * p) <= Z * math.sqrt(n * p * (1 - p)) + 1


def test_stationary_state_and_loss_rate():
    ge = GilbertElliott(seed=3, p_gb=0.05, p_bg=0.25, loss_good=0.02, loss_bad=0.9)
    receivers = np.arange(1, 41)
    states = np.concatenate([ge.states(t, 0, receivers) for t in range(0, 100 * 60, 60)])  # 0.7^60: independent
    assert inside(int(states.sum()), len(states), 1 / 6)
    p_loss = ge.stationary_loss()
    assert p_loss == pytest.approx(5 / 6 * 0.02 + 1 / 6 * 0.9)
    u = np.random.default_rng(0).random(len(states))
    lost = u >= np.where(states == 1, 0.1, 0.98)
    assert inside(int(lost.sum()), len(states), p_loss)


def test_burst_lengths_are_geometric_in_ticks():
    p_gb, p_bg = 0.1, 0.3
    ge = GilbertElliott(seed=5, p_gb=p_gb, p_bg=p_bg)
    receivers = np.arange(1, 21)
    seq = np.array([ge.states(t, 0, receivers) for t in range(3000)])  # every tick, per pair
    lengths = []
    for col in seq.T:
        run = 0
        for s in col[1:]:  # the first burst may be cut by the start
            if s:
                run += 1
            elif run:
                lengths.append(run)
                run = 0
    lengths = np.array(lengths)
    assert len(lengths) > 1000
    assert inside(int((lengths == 1).sum()), len(lengths), p_bg)
    assert inside(int((lengths == 2).sum()), len(lengths), (1 - p_bg) * p_bg)
    mean_sd = math.sqrt(1 - p_bg) / p_bg / math.sqrt(len(lengths))
    assert abs(lengths.mean() - 1 / p_bg) < Z * mean_sd


def test_closed_form_over_unevaluated_ticks():
    p_gb, p_bg, k = 0.05, 0.2, 3
    ge = GilbertElliott(seed=11, p_gb=p_gb, p_bg=p_bg)
    pi_b = p_gb / (p_gb + p_bg)
    want = pi_b + (1 - pi_b) * (1 - p_gb - p_bg) ** k
    receivers = np.arange(1, 201)
    bad_then, bad_after = 0, 0
    for t in range(0, 200 * 40, 40):  # 0.75^40: each evaluation pair independent of the last
        s0 = ge.states(t, 0, receivers)
        s1 = ge.states(t + k, 0, receivers)
        bad_then += int(s0.sum())
        bad_after += int((s0 & s1).sum())
    assert inside(bad_after, bad_then, want)


def test_same_tick_shares_the_state_and_order_does_not_matter():
    a = GilbertElliott(seed=2, p_gb=0.3, p_bg=0.3)
    b = GilbertElliott(seed=2, p_gb=0.3, p_bg=0.3)
    receivers = np.arange(10)
    for t in range(50):
        sa = a.states(t, 1, receivers)
        assert np.array_equal(sa, a.states(t, 1, receivers[::-1])[::-1])  # a second frame of the same tick
        sb = np.concatenate([b.states(t, 1, receivers[5:]), b.states(t, 1, receivers[:5])])
        assert np.array_equal(sa, np.concatenate([sb[5:], sb[:5]]))


def sparse_rate(cfg: dict, pos: np.ndarray, samples: int = 300) -> tuple[int, int]:
    """(delivered, sent to a receiver) for one broadcast from robot 0 every 25 ticks (independent states).

    The radio is built unchecked (a scenario refuses ``loss`` with gilbert), to show the medium ignores it too.
    """
    m = Medium(Radio(**{"range": 10.0, **cfg}), seed=9)
    n = len(pos)
    alive, ranges, reach = np.ones(n, dtype=bool), np.full(n, 10.0), {0: np.arange(1, n)}
    got = lost = 0
    for k in range(samples):
        d, drops, _ = m.decide(25 * k, [Outgoing(0, None, "K", k + 1, b"x")], reach, alive, pos, ranges)
        got += len(d)
        lost += sum(1 for x in drops if x[4] == "loss")
    return got, got + lost


def test_bursts_replace_bernoulli_loss_and_multiply_with_the_distance_model():
    p_gb, p_bg = 0.1, 0.4
    pi_b = p_gb / (p_gb + p_bg)
    pos = np.array([[0.0, 0.0]] + [[3.0, 0.0]] * 30)
    cfg = {"loss_model": "gilbert", "p_gb": p_gb, "p_bg": p_bg, "loss_good": 0.0, "loss_bad": 1.0}
    got, n = sparse_rate({**cfg, "model": "distance", "delta": 0.5}, pos)
    assert inside(got, n, (1 - pi_b) * math.exp(-0.5 * 3.0 / 10.0))
    # the bursts take the place of the Bernoulli loss: radio.loss is not applied on top
    got, n = sparse_rate({**cfg, "loss": 0.5}, pos)
    assert inside(got, n, 1 - pi_b)
    # frames of the same tick share the state: with loss_bad = 1 and loss_good = 0 they all pass or all fail
    m = Medium(Radio.from_dict({"range": 10.0, **cfg}), seed=9)
    outcomes = set()
    for t in range(200):
        fs = [Outgoing(0, None, "K", 4 * t + i, b"x") for i in range(4)]
        d, _, _ = m.decide(t, fs, {0: np.array([1])}, np.ones(2, dtype=bool), pos[:2], np.full(2, 10.0))
        outcomes.add(len(d))
    assert outcomes == {0, 4}


def test_bernoulli_is_unchanged_by_default():
    radio = Radio.from_dict({"range": 10.0, "loss": 0.3})
    assert Medium(radio, seed=1).rule("loss").bursts is None
    with pytest.raises(ValueError, match="gilbert"):
        Medium(Radio.from_dict({"loss_model": "gilbert", "p_gb": 0.1, "p_bg": 0.1}), 1).set_loss(0.2)
