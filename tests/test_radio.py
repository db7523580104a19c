"""The radio medium against the oracle: range, completeness, latency, loss, cuts, bandwidth."""

from __future__ import annotations

import math
from collections import defaultdict

import numpy as np
import pytest

pytestmark = pytest.mark.slow  # every test runs scenarios over Zenoh


def beacon_scenario(seed=1, loss=0.0, latency=1, ticks=12, clock="lockstep", extra_groups=(), **radio) -> dict:
    return {
        "run": {"name": "radio", "seed": seed, "ticks": ticks, "clock": clock},
        "radio": {"range": 1.0, "latency": latency, "loss": loss, **radio},
        "world": {"bounds": [[0.0, 0.0], [3.0, 3.0]]},
        "robots": [{"count": 25, "placement": "uniform", "behaviors": [{"use": "beacon"}]}, *extra_groups],
    }


def in_range_sets(result, tick: int) -> dict[int, set[int]]:
    """Oracle: robots within each transmitter's range at ``tick`` (directed)."""
    g = result.graph_at(tick, directed=True)
    return {u: set(g.successors(u)) for u in g.nodes}


def deliveries_by_frame(result) -> tuple[dict, dict, dict]:
    sent = {}
    delivered = defaultdict(dict)
    dropped = defaultdict(dict)
    for rec in result.trace:
        for src, seq, _kind, _dst, _size in rec.get("sent", []):
            sent[(src, seq)] = rec["t"]
        for src, seq, dst, _sent_tick in rec.get("del", []):
            delivered[(src, seq)][dst] = rec["t"]
        for src, seq, dst, cause in rec.get("drop", []):
            dropped[(src, seq)][dst] = cause
    return sent, delivered, dropped


@pytest.mark.parametrize("latency", [1, 3])
def test_range_completeness_and_exact_latency_with_directed_ranges(run, latency):
    long_range = {"count": 6, "placement": "uniform", "range": 2.0, "behaviors": [{"use": "beacon"}]}
    result = run(beacon_scenario(seed=4, latency=latency, extra_groups=[long_range]))
    sent, delivered, dropped = deliveries_by_frame(result)
    last = result["ticks"] - 1
    checked = 0
    for (src, seq), t in sent.items():
        if t + latency > last:
            continue  # still in the air when the run ended
        expected = in_range_sets(result, t)[src]
        got = set(delivered[(src, seq)])
        assert got == expected - set(dropped[(src, seq)]), (src, seq, t)  # nothing beyond range, nothing missing
        assert not dropped[(src, seq)]  # no loss configured
        assert all(at == t + latency for at in delivered[(src, seq)].values())
        checked += 1
    assert checked > 100
    ranges = result.ranges()
    assert len({r for r in ranges.values()}) == 2  # heterogeneous: some links are one-way
    g = result.graph_at(0, directed=True)
    assert any(not g.has_edge(v, u) for u, v in g.edges)


def test_loss_rate_within_binomial_interval(run):
    p = 0.2
    result = run(beacon_scenario(seed=9, loss=p, ticks=40))
    lost = result["world"]["dropped"]["loss"]
    n = lost + result["world"]["deliveries"]
    assert n > 5000
    half_width = 3.29 * math.sqrt(p * (1 - p) / n)  # 99.9 % normal approximation of the binomial
    assert abs(lost / n - p) < half_width, (lost / n, p, half_width)


def test_distance_model_loses_more_at_longer_distance(run):
    result = run(beacon_scenario(seed=5, ticks=30, model="distance", delta=0.3))
    sent, delivered, dropped = deliveries_by_frame(result)
    pos = {row[0]: np.array(row[1:]) for row in result.record(0)["pos"]}
    near, far = [0, 0], [0, 0]
    for (src, _seq), dsts in dropped.items():
        for dst, cause in dsts.items():
            if cause == "loss":
                (near if np.linalg.norm(pos[src] - pos[dst]) < 0.5 else far)[0] += 1
    for (src, _seq), dsts in delivered.items():
        for dst in dsts:
            (near if np.linalg.norm(pos[src] - pos[dst]) < 0.5 else far)[1] += 1
    near_rate = near[0] / sum(near)
    far_rate = far[0] / sum(far)
    assert 0 < near_rate < far_rate  # e = exp(-delta d / Z) falls with distance


def test_cut_partition_and_bandwidth(run):
    sc = beacon_scenario(seed=3, ticks=10)
    sc["events"] = [{"at": 2, "cut": [[0, 1], [2, 3]]}, {"at": 5, "partition": [[0, 1, 2, 3, 4]]},
                    {"at": 8, "heal": True}]
    result = run(sc)
    sent, delivered, dropped = deliveries_by_frame(result)
    cut_pairs = {frozenset((0, 1)), frozenset((2, 3))}
    for (src, seq), t in sent.items():
        for dst in delivered[(src, seq)]:
            if 2 <= t < 8:
                assert frozenset((src, dst)) not in cut_pairs, (src, dst, t)
            if 5 <= t < 8:
                inside = {0, 1, 2, 3, 4}
                assert (src in inside) == (dst in inside), (src, dst, t)
        for cause in dropped[(src, seq)].values():
            assert cause == "cut" and 2 <= t < 8
    after_heal = [(s, d) for (s, q), t in sent.items() if t >= 8 for d in delivered[(s, q)]]
    assert any(frozenset(p) in cut_pairs for p in after_heal) or not any(
        frozenset((u, v)) in cut_pairs for u, vs in in_range_sets(result, 8).items() for v in vs)
    assert result["world"]["dropped"]["cut"] > 0
    capped = run(beacon_scenario(seed=3, ticks=5, bandwidth=5))  # every beacon body is larger than 5 bytes
    assert capped["world"]["deliveries"] == 0
    assert capped["world"]["dropped"]["bandwidth"] > 0


def test_realtime_delivery_never_earlier_than_c_min(run):
    sc = beacon_scenario(seed=2, ticks=20, clock="realtime", latency_s=0.02, latency_min_s=0.01)
    sc["run"]["dt"] = 0.05
    result = run(sc)
    reports = result.reports("beacon")
    mins = [r["min_delay"] for r in reports.values() if r["min_delay"] is not None]
    assert len(mins) > 10
    assert min(mins) >= 0.01 - 1e-4
    assert result["world"]["deliveries"] > 500


def test_realtime_now_is_seconds_since_start(run):
    sc = beacon_scenario(seed=2, ticks=10, clock="realtime", latency_s=0.01)
    sc["run"]["dt"] = 0.05
    sc["robots"][0]["behaviors"] = [{"use": "tests_support:Clock"}]
    result = run(sc)
    nows = [r["last_now"] for r in result.reports("clock").values()]
    assert all(0.3 < n < 2.0 for n in nows), nows  # 10 ticks of 0.05 s, not a Unix time


def test_sensing_noise_is_seeded_and_bounded(run):
    sc = beacon_scenario(seed=2, ticks=3)
    sc["robots"][0]["behaviors"] = [{"use": "tests_support:Clock"}]
    sc["robots"][0]["noise"] = 0.05
    a, b = run(sc), run(sc)
    firsts = {rid: r["first"] for rid, r in a.reports("clock").items() if r["first"]}
    assert firsts == {rid: r["first"] for rid, r in b.reports("clock").items() if r["first"]}  # seeded
    true = {row[0]: np.array(row[1:]) for row in a.record(0)["pos"]}
    errors = [float(np.linalg.norm(np.array(f[1:]) - true[f[0]])) for f in firsts.values()]
    assert len(errors) > 10
    assert 0.0 < max(errors) < 0.05 * 6  # noisy, within six sigma
    assert 0.01 < float(np.mean(errors)) < 0.15  # Rayleigh mean of sigma 0.05 is about 0.063


def flood_scenario(clock="lockstep", loss=0.0, exclude="overheard") -> dict:
    return {
        "run": {"name": "overheard", "seed": 7, "ticks": 12, "clock": clock,
                "dt": 1.0 if clock == "lockstep" else 0.05},
        "radio": {"range": 1.0, "latency": 1, "latency_s": 0.01, "loss": loss, "exclude": exclude},
        "world": {"bounds": [[0.0, 0.0], [4.0, 4.0]]},
        "robots": [{"count": 30, "placement": "uniform", "connected": True,
                    "behaviors": [{"use": "flooding", "origin": 0, "at": 2, "expiry": 6}]}],
    }


def copies(result, key: str) -> dict[tuple[int, int], set[int]]:
    out = defaultdict(set)
    for rec in result.trace:
        for src, seq, dst, _sent in rec.get(key, []):
            out[(src, seq)].add(dst)
    return out


@pytest.mark.parametrize("loss", [0.0, 0.3])
def test_excluded_robots_overhear_broadcasts_which_are_recorded_counted_and_never_handed_over(run, loss):
    """A forwarded flood excludes the robot it came from (Kobayashi Sec. III-C); the radio still carries that copy.

    Each frame's receivers in range split into delivered, overheard and dropped, the overheard ones are exactly
    what ``exclude = "filter"`` leaves out, and the behaviours see the same frames either way.
    """
    heard = run(flood_scenario(loss=loss), name="overheard")
    filtered = run(flood_scenario(loss=loss, exclude="filter"), name="filtered")
    assert copies(heard, "del") == copies(filtered, "del")  # the behaviours got the same frames
    assert not copies(filtered, "ovh")
    ovh = copies(heard, "ovh")
    sent, _, dropped = deliveries_by_frame(heard)
    _, _, dropped_filtered = deliveries_by_frame(filtered)
    delivered = copies(heard, "del")
    for (src, seq), t in sent.items():
        in_range = in_range_sets(heard, t)[src]
        fates = [delivered[(src, seq)], ovh[(src, seq)], set(dropped[(src, seq)])]
        assert set().union(*fates) == in_range, (src, seq)
        assert sum(len(f) for f in fates) == len(in_range)  # one fate per copy
        excluded_lost = set(dropped[(src, seq)]) - set(dropped_filtered[(src, seq)])
        if loss == 0.0:
            assert not dropped[(src, seq)]
        assert all(dropped[(src, seq)][d] == "loss" for d in excluded_lost)
    total = sum(len(v) for v in ovh.values())
    assert total >= 5
    world = heard["world"]
    assert world["overheard"] == total and filtered["world"]["overheard"] == 0
    assert sum(heard.frame_counts(r)["overheard"] for r in range(30)) == total


def test_overheard_copies_in_realtime(run):
    result = run(flood_scenario(clock="realtime"), name="rt")
    ovh = copies(result, "ovh")
    delivered = copies(result, "del")
    assert sum(len(v) for v in ovh.values()) == result["world"]["overheard"] > 0
    assert all(not (ovh[k] & delivered[k]) for k in ovh)
