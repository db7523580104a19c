"""The array radio (``world.sensing.reach`` + ``Medium.decide_batch``) against a per-frame reference written here.

The reference decides one frame at a time, one receiver at a time, in plain Python, by the rules of
world/radio.py's docstring:

* reach: robot j hears robot i when j != i, both alive, and dx*dx + dy*dy <= r_i * r_i (directed ranges);
* a broadcast's candidates are the sender's reach; a copy to a robot on its exclude list goes through every rule
  below and, if it arrives, is ``overheard`` rather than delivered (with ``exclude = "filter"`` such robots are
  no candidates at all); the ones an obstacle hides are dropped as ``occluded``; an addressed frame is dropped
  as ``dead`` (no such robot, or dead), ``range`` (out of the sender's reach, by the same squared-distance
  rule) or ``occluded`` (in reach but hidden);
* every frame adds its body's length to its sender's bytes this tick, in sending order, whether or not it has
  candidates; a frame past the cap is dropped as ``bandwidth`` for all its candidates;
* then severed links (cuts, partitions) are dropped as ``cut``;
* then loss: the decoding probability is 1 - loss (``bernoulli``), or the Gilbert-Elliott pair state's
  (written out here as a per-pair Markov chain advanced in closed form), times the distance model's e when
  ``model = "distance"``; the pair is lost when the counter-based uniform keyed on (seed, LOSS, tick, src, seq,
  dst) is >= that probability.

Randomised scenarios (hypothesis) draw positions, directed ranges, dead robots, loss models, cuts, partitions,
bandwidth caps, unicasts (some to dead or unknown robots), exclude lists, obstacles hiding links, several ticks
and several batches per tick; array radio and reference must give the same outcome for every (frame, receiver)
pair. Also here: the delivery rows' msgpack bytes from arrays equal msgpack's own (``transport.rows``), and the
severed-link mask equals the per-pair rule (``transport.severance``).
"""

from __future__ import annotations

import math

import msgpack
import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from transport.rows import IntRows, packb
from transport.scenario import Radio
from transport.severance import Severance
from world import rng
from world.linkrules import DROP_CAUSES
from world.radio import Medium, Outgoing
from world.sensing import reach

# ------------------------------------------------------------------------------------------------ the reference


class Reference:
    """The radio rules, one frame and one receiver at a time."""

    def __init__(self, cfg: dict, seed: int):
        self.cfg = cfg
        self.seed = seed
        self.used: dict[int, int] = {}
        self.tick = -1
        self.burst: dict[tuple[int, int], tuple[int, int]] = {}

    def hears(self, pos, ranges, alive, i, j) -> bool:
        if i == j or not alive[i] or not alive[j]:
            return False
        d2 = 0.0
        for a, b in zip(pos[i], pos[j], strict=True):
            d2 += (b - a) * (b - a)
        return d2 <= ranges[i] * ranges[i]

    def keep(self, tick, src, dst) -> float:
        """Probability that the pair's frame survives the loss rule (before the distance model)."""
        cfg = self.cfg
        if cfg.get("loss_model") != "gilbert":
            return 1.0 - cfg.get("loss", 0.0)
        p_gb, p_bg = cfg["p_gb"], cfg["p_bg"]
        pi = p_gb / (p_gb + p_bg) if p_gb + p_bg > 0 else 0.0
        lam = 1.0 - (p_gb + p_bg)
        seen = self.burst.get((src, dst))
        if seen is not None and seen[0] == tick:
            s = seen[1]
        else:
            p_bad = pi if seen is None else pi + (seen[1] - pi) * lam ** (tick - seen[0])
            s = int(float(rng.uniform(self.seed, rng.BURST, tick, src, dst)) < p_bad)
            self.burst[(src, dst)] = (tick, s)
        return 1.0 - (cfg["loss_bad"] if s else cfg["loss_good"])

    def decide(self, tick, frames, pos, ranges, alive, links: Severance, blocked: set) -> dict:
        cfg = self.cfg
        n = len(pos)
        if tick != self.tick:
            self.tick, self.used = tick, {}
        out = {}
        for f in frames:
            key = lambda j, f=f: (f.src, f.seq, j)  # noqa: E731
            receivers = []
            if f.dst is None:
                for j in range(n):
                    if not self.hears(pos, ranges, alive, f.src, j):
                        continue
                    if j in f.exclude and cfg.get("exclude") == "filter":
                        continue
                    if frozenset((f.src, j)) in blocked:
                        out[key(j)] = "occluded"
                    else:
                        receivers.append(j)
            else:
                d = f.dst
                if not (0 <= d < n) or not alive[d]:
                    out[key(d)] = "dead"
                elif not self.hears(pos, ranges, alive, f.src, d):
                    out[key(d)] = "range"
                elif frozenset((f.src, d)) in blocked:
                    out[key(d)] = "occluded"
                else:
                    receivers.append(d)
            if cfg.get("bandwidth"):
                self.used[f.src] = self.used.get(f.src, 0) + len(f.body)
                if self.used[f.src] > cfg["bandwidth"]:
                    out.update((key(j), "bandwidth") for j in receivers)
                    continue
            for j in receivers:
                if links.severed(f.src, j):
                    out[key(j)] = "cut"
                    continue
                p = self.keep(tick, f.src, j)
                if cfg.get("model") == "distance":
                    dist = float(np.linalg.norm(np.array(pos[j]) - np.array(pos[f.src])))
                    delta = cfg["delta"]
                    p = (1.0 if dist < delta else float(np.exp(-delta * dist / ranges[f.src]))) * p
                u = float(rng.uniform(self.seed, rng.LOSS, tick, f.src, f.seq, j))
                arrived = "overheard" if f.dst is None and j in f.exclude else "delivered"
                out[key(j)] = "loss" if u >= p else arrived
        return out


# ------------------------------------------------------------------------------------------------ scenarios


@st.composite
def scenarios(draw):
    n = draw(st.integers(min_value=2, max_value=12))
    dims = draw(st.sampled_from([2, 3]))
    coord = st.integers(min_value=0, max_value=300).map(lambda k: k / 100)
    pos = [tuple(draw(coord) for _ in range(dims)) for _ in range(n)]
    ranges = draw(st.lists(st.sampled_from([0.5, 1.0, 1.3, 2.0, 5.0]), min_size=n, max_size=n))
    alive = draw(st.lists(st.sampled_from([True, True, True, False]), min_size=n, max_size=n).filter(any))
    ids = st.integers(min_value=0, max_value=n - 1)
    loss_model = draw(st.sampled_from(["bernoulli", "gilbert"]))
    cfg = {"model": draw(st.sampled_from(["bernoulli", "distance"])), "delta": draw(st.sampled_from([0.3, 1.0])),
           "bandwidth": draw(st.sampled_from([0, 0, 5, 12])), "loss_model": loss_model,
           "exclude": draw(st.sampled_from(["overheard", "filter"]))}
    if loss_model == "gilbert":
        cfg.update(p_gb=draw(st.sampled_from([0.1, 0.5])), p_bg=draw(st.sampled_from([0.2, 0.6])),
                   loss_good=draw(st.sampled_from([0.0, 0.1])), loss_bad=draw(st.sampled_from([0.7, 1.0])))
    else:
        cfg["loss"] = draw(st.sampled_from([0.0, 0.0, 0.3, 1.0]))
    links = Severance()
    for a, b in draw(st.lists(st.tuples(ids, ids).filter(lambda p: p[0] != p[1]), max_size=4)):
        links.cut(a, b)
    if draw(st.booleans()):
        members = draw(st.lists(st.sampled_from([None, 0, 1, 2]), min_size=n, max_size=n))
        links.partition([[i for i in range(n) if members[i] == g] for g in range(3)])
    blocked = {frozenset(p) for p in draw(st.lists(st.tuples(ids, ids).filter(lambda p: p[0] != p[1]), max_size=5))}
    senders = [i for i in range(n) if alive[i]]
    ticks = []
    seq = 0
    for _tick in range(draw(st.integers(min_value=1, max_value=3))):
        batches = []
        for _ in range(draw(st.integers(min_value=1, max_value=3))):
            frames = []
            for _ in range(draw(st.integers(min_value=0, max_value=8))):
                seq += 1
                src = draw(st.sampled_from(senders))
                body = b"x" * draw(st.sampled_from([0, 3, 6]))
                if draw(st.booleans()):
                    exclude = tuple(draw(st.lists(st.integers(min_value=-1, max_value=n + 1), max_size=3)))
                    frames.append(Outgoing(src, None, "B", seq, body, exclude))
                else:
                    dst = draw(st.integers(min_value=-1, max_value=n + 1).filter(lambda d, s=src: d != s))
                    frames.append(Outgoing(src, dst, "U", seq, body))
            batches.append(frames)
        ticks.append(batches)
    return pos, ranges, alive, cfg, links, blocked, ticks, draw(st.integers(min_value=0, max_value=2**40))


def array_outcomes(decision, frames) -> dict:
    out = {}
    for k, d, c, o in zip(decision.frame.tolist(), decision.dst.tolist(), decision.cause.tolist(),
                          decision.overheard.tolist(), strict=True):
        f = frames[k]
        key = (f.src, f.seq, d)
        assert key not in out, f"two outcomes for {key}"
        out[key] = ("overheard" if o else "delivered") if c < 0 else DROP_CAUSES[c]
    return out


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(scenarios())
def test_the_array_radio_decides_every_pair_as_the_per_frame_reference(scenario):
    pos, ranges, alive, cfg, links, blocked, ticks, seed = scenario
    p = np.array(pos, dtype=float)
    r = np.array(ranges, dtype=float)
    a = np.array(alive, dtype=bool)
    medium = Medium(Radio.from_dict(cfg), seed)
    medium.links = links
    ref = Reference(cfg, seed)
    table = reach(p, np.flatnonzero(a), r)
    owners = table.owners().tolist()
    hidden = np.array([frozenset((i, j)) in blocked for i, j in zip(owners, table.nbrs.tolist(), strict=True)],
                      dtype=bool)
    for tick, batches in enumerate(ticks):
        for frames in batches:
            got = array_outcomes(medium.decide_batch(tick, frames, table, a, p, r, hidden if hidden.any() else None),
                                 frames)
            want = ref.decide(tick, frames, pos, ranges, alive, links, blocked)
            assert got == want


@settings(max_examples=100, deadline=None)
@given(st.lists(st.lists(st.integers(min_value=-2**63, max_value=2**63 - 1), min_size=4, max_size=4), max_size=40),
       st.sampled_from([0, 1, 15, 16, 70_000]))
def test_rows_packed_from_arrays_are_msgpacks_own_bytes(rows, extra):
    rows = rows + [[1, 2, 300, 70_000]] * extra
    array = np.array(rows, dtype=np.int64).reshape(-1, 4)
    assert packb(array) == msgpack.packb(rows, use_bin_type=True)
    assert IntRows(array) == rows and len(IntRows(array)) == len(rows)


_EDGES = [0, 1, 31, 127, 128, 200, 255, 256, 999, 65_535, 65_536, 2**31, 2**32 - 1]


@settings(max_examples=200, deadline=None)
@given(st.integers(min_value=1, max_value=6).flatmap(lambda w: st.lists(
    st.lists(st.one_of(st.sampled_from(_EDGES), st.integers(min_value=0, max_value=2**32 - 1)),
             min_size=w, max_size=w), max_size=40)))
def test_non_negative_rows_take_the_word_path_and_pack_the_same(rows):
    """Values in [0, 2**32) (every trace row of a run) are packed as words of 4 or 8 bytes, then compressed."""
    width = len(rows[0]) if rows else 4
    array = np.array(rows, dtype=np.int64).reshape(-1, width)
    assert packb(array) == msgpack.packb(rows, use_bin_type=True)


@settings(max_examples=200, deadline=None)
@given(st.integers(min_value=2, max_value=30).flatmap(lambda n: st.tuples(
    st.just(n),
    st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)), max_size=6),
    st.lists(st.lists(st.integers(0, n - 1), max_size=5), max_size=3),
    st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)), max_size=40))))
def test_the_severed_mask_is_the_per_pair_rule(case):
    n, cuts, groups, pairs = case
    links = Severance()
    for a, b in cuts:
        links.apply({"cut": [[a, b]]})
    if groups:
        links.apply({"partition": groups})
    src = np.array([a for a, _ in pairs], dtype=np.int64)
    dst = np.array([b for _, b in pairs], dtype=np.int64)
    want = []
    group = {r: g + 1 for g, members in enumerate(groups) for r in members}
    cut = {frozenset(c) for c in cuts}
    for a, b in pairs:
        want.append(frozenset((a, b)) in cut or group.get(a, 0) != group.get(b, 0))
    assert links.mask(src, dst).tolist() == want
    assert [links.severed(a, b) for a, b in pairs] == want


def test_distances_at_the_edge_follow_the_squared_rule():
    """A pair at exactly the range (3-4-5 triangle scaled) is in reach; one float step beyond is not."""
    pos = np.array([[0.0, 0.0], [0.3, 0.4], [0.0, math.nextafter(0.5, 1.0)]])
    table = reach(pos, np.arange(3), np.full(3, 0.5))
    d2 = 0.3 * 0.3 + 0.4 * 0.4
    assert (1 in table.row(0).tolist()) == (d2 <= 0.25)
    assert 2 not in table.row(0).tolist()
