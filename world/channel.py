"""The shared channel: airtime, contention, interference and path loss (``[radio.channel]``, docs/channel.md).

The model behind three rules of the radio (world/linkrules.py), all deterministic:

* **airtime** - a frame occupies the channel for ``preamble_s + (body bytes + overhead_bytes) * 8 / bitrate_bps``
  seconds from its start;
* **start** (``mac``) - lockstep: the frame's send time is drawn uniformly within the first ``window_s`` seconds
  of its tick from the counter-based generator keyed on (seed, tick, src, seq), so it does not depend on the
  process layout; realtime: the sender's own send time (``Outgoing.at``). ``aloha`` sends at once, ``slotted``
  at a slot boundary (lockstep: a slot drawn uniformly; realtime: the next boundary), ``csma`` senses first: a
  frame on the air at the sender's power ``cs_threshold_dbm`` or more, that started at least ``slot_s`` ago (the
  time to sense it), makes the channel busy; the frame then waits until that frame ends plus a random backoff of
  ``[0, backoff_slots)`` slots and senses again (the window does not grow: as IEEE 802.11 broadcasts, no frame is
  acknowledged, so none is known to have collided).
  A frame that finds the channel busy ``max_attempts`` times, or would start after the end of its tick
  (realtime: ``run.dt`` after its send time), is dropped as ``deferred_too_long``;
* **received power** - log-distance path loss with log-normal shadowing:
  ``P = tx_power_dbm - l0_db - 10 n log10(max(d, d0) / d0) + sigma X`` (d in metres: length units times
  ``unit_m``), ``X ~ N(0, 1)`` drawn per link (unordered pair: reciprocal) and per block of ``shadowing_ticks``
  ticks; no power at all beyond ``max_range`` (length units); with ``wall_loss_db`` (and ``radio.occlusion``), a link
  an obstacle blocks loses that many dB instead of being cut (an interferer out of its sender's range is taken
  as unobstructed: the world knows walls only on links within range). A copy is dropped as ``below_sensitivity`` when
  ``P < sensitivity_dbm`` or when, with noise only, it would not be received (below);
* **reception from SINR** - ``SINR = P / (N + I)`` with N the noise floor and I the sum of the powers at the
  receiver of every other frame on the air whose airtime overlaps the copy's (the whole overlap counts: a
  pessimistic reading of the power over the airtime). ``step``: received when the SINR reaches
  ``sinr_threshold_db``; ``qpsk``: with probability ``(1 - erfc(sqrt(SINR)) / 2) ** bits``, the draw keyed on
  (seed, tick, src, seq, dst). A receiver that transmits during the copy's airtime does not hear it (half
  duplex). A copy heard with noise alone but lost to interference is dropped as ``collision``; capture follows
  (a frame stronger than the others by the threshold survives them).

What is not modelled: frames decided in different batches never interfere (lockstep: frames of different
ticks; realtime: of different delivery windows); a frame deferred by CSMA is still delivered at the tick the
latency says (the deferral decides who collides, not when a copy arrives); every frame a robot hands the
world occupies the air, also one the ``bandwidth`` rule drops.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np
from scipy.special import erfc, ndtri

from transport.scenario import Channel
from world import rng
from world.sensing import gather

TOUCH_S = 1e-9  # frames that overlap by less than this (a nanosecond: rounding of back-to-back slots) do not
SHARED_KEY = "channel.schedule"  # where the decision's schedule waits for the next rule (``Transmissions.shared``)
WALLS_KEY = "channel.walls"  # where the decision's wall losses per link wait for the next rule


def normal(seed: int, *fields) -> np.ndarray:
    """Standard normal floats keyed on ``(seed, *fields)``: the inverse normal CDF of a counter-based uniform."""
    return ndtri(rng.uniform(seed, *fields) + 0.5 / (1 << 53))


def mw(dbm: np.ndarray | float) -> np.ndarray:
    """DBm to milliwatts."""
    return np.power(10.0, np.asarray(dbm, dtype=float) / 10.0)


def qpsk_prr(sinr: np.ndarray, bits: np.ndarray) -> np.ndarray:
    """Packet reception ratio of Gray-coded QPSK: ``(1 - erfc(sqrt(SINR)) / 2) ** bits`` (SINR linear)."""
    ber = 0.5 * erfc(np.sqrt(np.maximum(sinr, 0.0)))
    with np.errstate(divide="ignore"):
        return np.exp(bits * np.log1p(-np.minimum(ber, 0.5)))


@dataclass
class Schedule:
    """When each frame of a decision is on the air: ``[start, end)`` seconds, unless ``on_air`` is False.

    Lockstep times count from the start of the tick; realtime times are the senders' wall clock.
    """

    start: np.ndarray
    end: np.ndarray
    on_air: np.ndarray


class ChannelModel:
    """The channel of one run: ``[radio.channel]`` with the run's seed, tick length and clock."""

    def __init__(self, config: Channel, seed: int, dt: float = 1.0, realtime: bool = False):
        self.config, self.seed, self.dt, self.realtime = config, seed, float(dt), realtime
        self.window = float(config.window_s) if config.window_s is not None else self.dt
        self.noise_mw = float(mw(config.noise_floor_dbm))
        self.threshold = float(mw(config.sinr_threshold_db))  # linear
        self.space = None  # transport.space.Space: the walls, for walls = "crossing" (Medium.use_space)

    # ------------------------------------------------------------ power
    def airtime(self, sizes: np.ndarray) -> np.ndarray:
        """Seconds on the air of frames with these body sizes (bytes)."""
        c = self.config
        return c.preamble_s + self.bits(sizes) / float(c.bitrate_bps)

    def bits(self, sizes: np.ndarray) -> np.ndarray:
        return (np.asarray(sizes, dtype=float) + self.config.overhead_bytes) * 8.0

    def mean_dbm(self, d: np.ndarray, tx_dbm: np.ndarray | None = None) -> np.ndarray:
        """Mean received power at distances ``d`` (length units): the log-distance path loss.

        ``tx_dbm``: the transmitters' powers (None: ``tx_power_dbm``).
        """
        c = self.config
        d = np.asarray(d, dtype=float)
        metres = np.maximum(d * c.unit_m, c.d0)
        power = c.tx_power_dbm if tx_dbm is None else tx_dbm
        p = power - c.l0_db - 10.0 * c.path_loss_exponent * np.log10(metres / c.d0)
        if c.max_range is not None:
            p = np.where(d > c.max_range, -np.inf, p)
        return p

    def power_dbm(self, tick: int, a: np.ndarray, b: np.ndarray, d: np.ndarray,
                  tx_dbm: np.ndarray | None = None) -> np.ndarray:
        """Received power (dBm) from ``a`` at ``b``, distance ``d`` apart, with the link's shadowing.

        ``tx_dbm``: the transmitters' powers (None: ``tx_power_dbm``).
        """
        p = self.mean_dbm(d, tx_dbm)
        sigma = self.config.shadowing_sigma_db
        if sigma > 0 and len(p):
            block = tick // self.config.shadowing_ticks
            p = p + sigma * normal(self.seed, rng.SHADOW, block, np.minimum(a, b), np.maximum(a, b))
        return p

    def pair_power(self, tx) -> np.ndarray:
        """Each pair's received power at the send tick (``tx``: a ``Transmissions``)."""
        src = tx.pair_src
        p = self.power_dbm(tx.tick, src, tx.dst, tx.distances(), self.tx_dbm(tx, src))
        return p - self.walls(tx, tx.where)

    def walls(self, tx, where: np.ndarray) -> np.ndarray | float:
        """The wall loss (dB) of the links (indices into ``tx.table.nbrs``, -1: out of reach) obstacles block."""
        per_link = self.link_walls(tx)
        if per_link is None or not len(where):
            return 0.0
        out = np.zeros(len(where))
        known = where >= 0
        out[known] = per_link[where[known]]
        return out

    def link_walls(self, tx) -> np.ndarray | None:
        """Per link of ``tx.table`` (aligned with its ``nbrs``): the dB walls take from it; None: no wall loss.

        ``walls = "link"``: ``wall_loss_db`` on every blocked link; ``"crossing"``: the sum over the obstacles
        the link crosses of their ``loss_db`` (else ``wall_loss_db``). Computed once per decision.
        """
        c = self.config
        if c.wall_loss_db is None or tx.hidden is None:
            return None
        got = tx.shared.get(WALLS_KEY)
        if got is None:
            got = c.wall_loss_db * tx.hidden
            if c.walls == "crossing" and self.space is not None:
                got = np.zeros(len(tx.hidden))
                k = np.flatnonzero(tx.hidden)
                pts = np.asarray(tx.positions, dtype=float)
                if pts.shape[1] == 2:
                    pts = np.column_stack([pts, np.zeros(len(pts))])
                got[k] = self.space.wall_loss(pts[tx.table.owners()[k]], pts[tx.table.nbrs[k]], c.wall_loss_db)
            tx.shared[WALLS_KEY] = got
        return got

    def tx_dbm(self, tx, senders: np.ndarray) -> np.ndarray | None:
        """Each of ``senders``' transmit power (its group's ``tx_power_dbm``, else the channel's); None: all alike."""
        if tx.tx_power is None or not len(tx.tx_power):
            return None
        own = tx.tx_power[np.minimum(senders, len(tx.tx_power) - 1)]
        return np.where(np.isnan(own), self.config.tx_power_dbm, own)

    # ------------------------------------------------------------ reception
    def heard_alone(self, tx) -> np.ndarray:
        """Per pair: received with noise alone (power at least the sensitivity, then the reception rule)."""
        p = self.pair_power(tx)
        ok = p >= self.config.sensitivity_dbm
        return ok & self._receive(tx, mw(p) / self.noise_mw)

    def heard_among(self, tx) -> np.ndarray:
        """Per pair: received with the other frames on the air (SINR; half duplex)."""
        sched = self.schedule(tx)
        s = mw(self.pair_power(tx))
        interference, transmitting = self.interference(tx, sched)
        return ~transmitting & self._receive(tx, s / (self.noise_mw + interference))

    def _receive(self, tx, sinr: np.ndarray) -> np.ndarray:
        if self.config.reception == "step":
            return sinr >= self.threshold
        prr = qpsk_prr(sinr, self.bits(tx.sizes()[tx.frame]))
        u = rng.uniform(self.seed, rng.RECEPTION, tx.tick, tx.pair_src, tx.seq[tx.frame], tx.dst)
        return u < prr

    def interference(self, tx, sched: Schedule) -> tuple[np.ndarray, np.ndarray]:
        """Per pair: the power (mW) of the other frames overlapping the copy's airtime; the receiver transmits.

        The second array marks the pairs whose receiver itself sends a frame that overlaps the copy.
        """
        k = len(tx)
        total = np.zeros(k)
        transmitting = np.zeros(k, dtype=bool)
        on = np.flatnonzero(sched.on_air)
        if not k or len(on) < 2:
            return total, transmitting
        order = on[np.argsort(sched.start[on], kind="stable")]
        starts = sched.start[order]
        longest = float((sched.end[on] - sched.start[on]).max())
        pf = tx.frame
        lo = np.searchsorted(starts, sched.start[pf] - longest + TOUCH_S, side="right")
        hi = np.searchsorted(starts, sched.end[pf] - TOUCH_S, side="left")
        ptr, idx = gather(lo, np.maximum(hi, lo))
        pair = np.repeat(np.arange(k, dtype=np.int64), np.diff(ptr))
        g = order[idx]
        f = pf[pair]
        keep = (g != f) & (sched.end[g] > sched.start[f] + TOUCH_S)
        pair, g = pair[keep], g[keep]
        if not len(pair):
            return total, transmitting
        r = tx.dst[pair]
        sg = tx.src[g]
        own = sg == r
        transmitting[pair[own]] = True
        pair, sg, r = pair[~own], sg[~own], r[~own]
        d = np.linalg.norm(tx.positions[r] - tx.positions[sg], axis=1)
        p = self.power_dbm(tx.tick, sg, r, d, self.tx_dbm(tx, sg))
        if self.config.wall_loss_db is not None and tx.hidden is not None:
            p = p - self.walls(tx, tx.table.find(sg, r))
        total += np.bincount(pair, weights=mw(p), minlength=k)
        return total, transmitting

    # ------------------------------------------------------------ medium access
    def schedule(self, tx) -> Schedule:
        """When each frame of the decision is on the air (computed once per decision, kept in ``tx.shared``)."""
        got = tx.shared.get(SHARED_KEY)
        if got is None:
            got = tx.shared[SHARED_KEY] = self._schedule(tx)
        return got

    def _schedule(self, tx) -> Schedule:
        c = self.config
        n = len(tx.frames)
        air = self.airtime(tx.sizes())
        u = rng.uniform(self.seed, rng.START, tx.tick, tx.src, tx.seq) if n else np.zeros(0)
        if self.realtime:
            drawn = tx.tick * self.dt + u * self.window
            arrival = np.array([drawn[k] if f.at is None else f.at for k, f in enumerate(tx.frames)], dtype=float)
            deadline = arrival + self.dt
        else:
            arrival = u * self.window
            deadline = np.full(n, self.dt)
        on_air = np.ones(n, dtype=bool)
        if c.mac == "slotted":
            slot = float(c.aloha_slot_s) if c.aloha_slot_s is not None else float(air.max(initial=0.0)) or 1.0
            if self.realtime:
                start = np.ceil(arrival / slot) * slot
            else:
                slots = max(1, int(self.window // slot))
                start = np.floor(u * slots) * slot
        elif c.mac == "csma":
            start, on_air = self._csma(tx, arrival, deadline, air)
        else:
            start = arrival
        return Schedule(start, start + air, on_air)

    def _csma(self, tx, arrival: np.ndarray, deadline: np.ndarray, air: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Carrier sense with random backoff, frame by frame in the order of their send times."""
        c = self.config
        n = len(arrival)
        start, end, air_s = arrival.tolist(), (arrival + air).tolist(), air.tolist()
        on_air = [False] * n
        src, seq = tx.src.tolist(), tx.seq.tolist()
        pos = tx.positions.tolist()
        power = self.tx_dbm(tx, np.arange(len(tx.positions)))
        power = None if power is None else power.tolist()
        walled: dict[tuple[int, int], float] = {}  # (sender, receiver) links obstacles block: their wall loss, dB
        per_link = self.link_walls(tx)
        if per_link is not None:
            walled = dict(zip(zip(tx.table.owners()[tx.hidden].tolist(), tx.table.nbrs[tx.hidden].tolist(),
                                  strict=True), per_link[tx.hidden].tolist(), strict=True))
        senses: dict[tuple[int, int], bool] = {}  # (a, b): b senses a's frames
        threshold = float(c.cs_threshold_dbm)
        deadlines = deadline.tolist()
        heap = [(start[k], src[k], seq[k], k) for k in range(n)]
        heapq.heapify(heap)
        active: list[int] = []  # frames on the air that may still be sensed
        attempts = [0] * n
        slot = float(c.slot_s)
        while heap:
            t, s, q, k = heapq.heappop(heap)
            active = [j for j in active if end[j] > t]
            busy = []
            for j in active:
                if start[j] + slot > t:
                    continue  # started too recently to be sensed
                o = src[j]
                if o != s:
                    pair = (o, s)
                    heard = senses.get(pair)
                    if heard is None:
                        p = self.link_dbm(tx.tick, o, s, math.dist(pos[o], pos[s]),
                                          None if power is None else power[o])
                        p -= walled.get(pair, 0.0)
                        heard = senses[pair] = p >= threshold
                    if not heard:
                        continue
                busy.append(end[j])
            if not busy:
                start[k], end[k] = t, t + air_s[k]
                on_air[k] = True
                active.append(k)
                continue
            attempts[k] += 1
            if attempts[k] >= c.max_attempts:
                continue
            b = math.floor(uniform1(self.seed, rng.BACKOFF, tx.tick, s, q, attempts[k]) * c.backoff_slots)
            later = max(busy) + b * slot
            if later >= deadlines[k]:
                continue
            heapq.heappush(heap, (later, s, q, k))
        return np.array(start, dtype=float), np.array(on_air, dtype=bool)

    def link_dbm(self, tick: int, a: int, b: int, d: float, tx_dbm: float | None = None) -> float:
        """``power_dbm`` for one link, in plain Python (the same value)."""
        c = self.config
        if c.max_range is not None and d > c.max_range:
            return -math.inf
        power = c.tx_power_dbm if tx_dbm is None else tx_dbm
        p = power - c.l0_db - 10.0 * c.path_loss_exponent * math.log10(max(d * c.unit_m, c.d0) / c.d0)
        if c.shadowing_sigma_db > 0:
            u = uniform1(self.seed, rng.SHADOW, tick // c.shadowing_ticks, min(a, b), max(a, b))
            p += c.shadowing_sigma_db * float(ndtri(u + 0.5 / (1 << 53)))
        return p


_MASK = (1 << 64) - 1
_GOLDEN, _M1, _M2 = 0x9E3779B97F4A7C15, 0xBF58476D1CE4E5B9, 0x94D049BB133111EB


def _mix(z: int) -> int:
    z = ((z ^ (z >> 30)) * _M1) & _MASK
    z = ((z ^ (z >> 27)) * _M2) & _MASK
    return z ^ (z >> 31)


def uniform1(seed: int, *fields: int) -> float:
    """``world.rng.uniform`` for one key, in plain Python integers (the same value, faster for one draw)."""
    state = _mix((seed + _GOLDEN) & _MASK)
    for v in fields:
        state = _mix(state ^ (((v & _MASK) + _GOLDEN + ((state << 6) & _MASK) + (state >> 2)) & _MASK))
    return (state >> 11) * (1.0 / (1 << 53))
