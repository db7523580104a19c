"""Swarm Relays' Fig. 6 analysis helpers (protocols/relays/experiments/fig6.py), pure."""

from __future__ import annotations

import math

from protocols.relays.experiments.fig6 import _back, slope, variant


def test_the_worker_s_time_back_is_read_from_relays_healed_s_detail():
    detail = "kill at tick 330: whole again after 5.2 s, worker back at its target after 23.4 s"
    assert _back(detail) == 23.4
    assert _back("kill at tick 330: whole again after 5.2 s, worker back at its target never") is None


def test_the_variant_names_wp_and_the_two_asks():
    assert variant({"wp": True, "ask": "plan"}) == "WP"
    assert variant({"wp": False, "ask": "plan"}) == "no WP (plan)"
    assert variant({"wp": False}) == "no WP (stretched)"


def test_the_failure_slope_and_its_ci_per_failed_robot():
    rows = [{"failed": f, "recovery_s": 5.0 + 1.5 * f + e, "path_m": 10.0}
            for f in range(1, 6) for e in (-0.2, 0.2)]
    fit = slope(rows)
    assert math.isclose(fit["slope"], 1.5) and math.isclose(fit["intercept"], 5.0)
    assert 0 < fit["half"] < 0.3 and fit["n"] == 10 and fit["traversal"] == 20.0
    assert slope([{"failed": 1, "recovery_s": 5.2}, {"failed": 1, "recovery_s": 5.4}]) is None


def test_the_end_chain_stops_where_a_parent_is_missing():
    """A cut chain (a robot without a parent, or with a parent that has no report) ends there, not in a KeyError."""
    from protocols.relays.experiments.fig6 import _chain

    whole = {12: {"role": "worker", "parent": 2}, 2: {"role": "networker", "parent": 0},
             0: {"role": "root", "parent": None}}
    assert _chain(whole) == [12, 2, 0]
    cut = {**whole, 2: {"role": "networker", "parent": 9}, 9: {"role": "free", "parent": None}}
    assert _chain(cut) == [12, 2, 9]
    assert _chain({**whole, 2: {"role": "networker", "parent": None}}) == [12, 2]
