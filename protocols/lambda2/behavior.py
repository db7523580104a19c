"""λ2 estimation: the robot side (PI1, PI2, Wave). Imports no oracle.

One iteration per tick. After iteration k every robot broadcasts one L2 frame {k, v, ...} (v its x_i or
s_i, plus what the method piggybacks); at iteration k + 1 it uses the values its neighbours sent.

* R1 (drop = "drop", the authors' makeAnoisy) - only the frames that arrived since the last iteration are
  used; a lost frame removes both its x_j and its share of the degree for that iteration. In realtime (where
  a late frame and a lost one look alike) each neighbour's value of the previous iteration is used, or its
  latest older one within ``hold`` iterations.
  (drop = "reuse") - the last value heard from each neighbour within ``hold`` iterations is used.
* R2 - a frame whose body is not an ``messages.L2`` (decoded by msgspec) or holds a number that is not
  finite, or whose k is from the future (k > own k, one more in realtime), is refused and counted by cause;
  it changes nothing.
* R3 - warm-up (no ``dmax`` given): for ``warmup`` ticks robots count who they hear and flood the largest
  degree (max of theirs and what they hear); then d_max is frozen and iteration 0 starts.
* PI1 - rules.pi1_phase/pi1_step; at the start of each period (an L step) the beacon computes its norm and
  the period's length (rules.pi1_period, from its own estimate) and floods (epoch, norm, length) piggybacked
  (latest epoch wins); every robot divides by the norm ``flood`` iterations later and starts the next
  period when this one ends (``period`` iterations until it has heard the length).
* PI2 - rules.pi2_phase: rounds of ``power`` power steps x ← x − γLx (w: the result), then ``consensus``
  steps of average consensus a ← (I − εL)a from a = w and of max-consensus m ← max(m, m_j) from m = |w|, in
  the same frames; then x = (w − a)/m (rules.pi2_normalise). ``power`` = 1 is the paper's literal rule (one
  power step per consensus), which can settle on λ3 (rules.pi2_gain).
* Wave - rules.wave_step on the robot's own signal; rules.wave_estimate on its FFT.

Each iteration's estimate goes to the status field ``l2`` and to the report's ``estimates``.
"""

from __future__ import annotations

import math
from collections import Counter

from protocols.lambda2 import rules
from protocols.lambda2.messages import KIND, L2, decode, encode
from swarmactors import Behavior, Context, Frame


class Lambda2(Behavior):
    """Distributed estimate of the Laplacian's λ2 by PI1, PI2 or the wave method."""

    name = "lambda2"
    kinds = (KIND,)
    plot_field = "l2"

    def __init__(self, method: str = "pi1", drop: str = "drop", hold: int = 10, dmax: int | None = None,
                 warmup: int = 12, period: int = 30, flood: int = 12, beacon: int = 0, consensus: int = 100,
                 power: int = 20, gamma: float | None = None, eps: float | None = None, window: int = 1024,
                 at: int = 0):
        self.method, self.drop, self.hold, self.dmax = method, drop, hold, dmax
        self.warmup = 0 if dmax is not None else warmup
        self.period, self.flood, self.beacon, self.consensus = period, flood, beacon, consensus
        self.power, self.gamma_set, self.eps_set = power, gamma, eps
        self.window, self.at = window, at
        self.k = -1 - self.warmup - at  # iteration of the state held (k < 0: before iteration 0)
        self.x = 0.0
        self.heard: dict[int, dict[int, tuple[int, L2]]] = {}  # neighbour -> its k -> (own k at receipt, body)
        self.fresh: set[int] = set()  # neighbours heard since the last iteration
        self.ever: set[int] = set()
        self.dm = 0  # warm-up max-degree flood
        self.estimates: list[float | None] = []
        self.refused: Counter = Counter()
        self.norm = (-1, 1.0, period)  # PI1: latest (epoch, norm, period length) the beacon flooded
        self.epoch, self.start, self.plen = -1, 1, 0  # PI1: current period, its first iteration, its length
        self.normalised = 0
        self.missed_norm = 0
        self.w = self.a = self.m = 0.0  # PI2 round state: w after the power steps, the consensus values
        self.est: float | None = None
        self.signal: list[float] = []
        self.prev = 0.0  # wave: s(t-2)

    @staticmethod
    def validate(params: dict) -> str | None:
        m = params.get("method", "pi1")
        if m not in rules.METHODS:
            return f"method = {m!r} must be one of {list(rules.METHODS)}"
        d = params.get("drop", "drop")
        if d not in rules.DROPS:
            return f"drop = {d!r} must be one of {list(rules.DROPS)}"
        for key, low in (("hold", 1), ("warmup", 1), ("period", 5), ("flood", 0), ("beacon", 0),
                         ("consensus", 1), ("power", 1), ("window", 16), ("at", 0), ("dmax", 1)):
            v = params.get(key)
            if v is not None and (not isinstance(v, int) or isinstance(v, bool) or v < low):
                return f"{key} = {v!r} must be an integer >= {low}"
        for key in ("gamma", "eps"):
            v = params.get(key)
            if v is not None and (not isinstance(v, (int, float)) or isinstance(v, bool) or not 0.0 < v < 1.0):
                return f"{key} = {v!r} must be a number in (0, 1)"
        if params.get("flood", 12) + 3 > params.get("period", 30):
            return f"flood = {params.get('flood', 12)} must be at most period - 3 = {params.get('period', 30) - 3}"
        return None

    # -------------------------------------------------------------- receive
    def on_frame(self, ctx: Context, frame: Frame) -> None:
        msg = decode(frame.body, self.flood)
        if isinstance(msg, str):  # R2: not an L2 body, or a number that is not finite
            self.refused[msg] += 1
            return
        slack = 1 if ctx.clock == "realtime" else 0
        if msg.k > self.k + slack:  # R2: an iteration number from the future
            self.refused["future"] += 1
            return
        kept = self.heard.setdefault(frame.src, {})
        if len(kept) >= 3 and msg.k < min(kept):  # older than the three iterations kept
            self.refused["stale"] += 1
            return
        kept[msg.k] = (self.k, msg)
        if len(kept) > 3:
            del kept[min(kept)]
        self.fresh.add(frame.src)
        if msg.dm is not None:
            self.dm = max(self.dm, msg.dm)
        if msg.n is not None and msg.n[0] > self.norm[0]:  # PI1 flood: the latest epoch wins
            self.norm = (msg.n[0], msg.n[1], msg.n[2])

    def _neighbours(self, k: int, realtime: bool) -> list[tuple[int, L2]]:
        """R1: the bodies iteration k combines, by neighbour id.

        Lockstep: each neighbour's latest body, "drop" only from those heard since the last iteration, "reuse"
        from those heard within ``hold`` iterations. Realtime (a late frame and a lost one look alike): each
        neighbour's body of iteration k − 1, or its latest older one, if not more than ``hold`` old.
        """
        out = []
        for j in sorted(self.heard):
            kept = self.heard[j]
            if realtime:
                older = [kb for kb in kept if kb <= k - 1]
                if older and k - 1 - max(older) < self.hold:
                    out.append((j, kept[max(older)][1]))
                continue
            at, body = kept[max(kept)]
            if (j in self.fresh) if self.drop == "drop" else (self.k - at < self.hold):
                out.append((j, body))
        return out

    # -------------------------------------------------------------- iterate
    def on_start(self, ctx: Context) -> None:
        self.x = float(ctx.rng.uniform(0.0, 1.0))

    def on_tick(self, ctx: Context, sensed) -> None:
        k = ctx.tick - self.at - self.warmup
        if ctx.tick < self.at or k <= self.k:
            return
        nbrs = self._neighbours(k, ctx.clock == "realtime")
        self.fresh = set()
        self.ever.update(j for j, _ in nbrs)
        self.k = k
        if k < 0:  # R3 warm-up
            self.dm = max(self.dm, len(self.ever))
            ctx.broadcast(KIND, encode(L2(k=k, v=self.x, dm=self.dm)))
            return
        if k == 0:
            self.dmax = self.dmax if self.dmax is not None else max(self.dm, len(self.ever), 1)
            self.gamma = self.gamma_set if self.gamma_set is not None else rules.step_size(self.dmax)
            self.eps = self.eps_set if self.eps_set is not None else rules.consensus_eps(self.dmax)
            self.k2 = rules.wave_k2(self.dmax)
            self.signal = [self.x]
            self.prev = self.x
            self._send(ctx)
            return
        values = [b.v for _, b in nbrs]
        lx = rules.laplacian_row(self.x, values)
        est = getattr(self, "_" + self.method)(ctx, nbrs, values, lx)
        self.estimates.append(est)
        ctx.set_status(l2=est)
        self._send(ctx)

    def _pi1(self, ctx: Context, nbrs, values, lx) -> float | None:
        est = rules.ratio_estimate(self.x, lx)
        r = self.k - self.start
        if r >= self.plen:  # a new period: its L step; its length is the default until the beacon's flood
            self.epoch, self.start, self.plen, r = self.epoch + 1, self.k, self.period, 0
        if self.norm[0] == self.epoch:
            self.plen = self.norm[2]
        phase = rules.pi1_phase(r, self.flood)
        if ctx.id == self.beacon and r == 1:  # values are post-L: the beacon's norm and this period's length
            norm = rules.beacon_norm(self.x, values)
            if norm > 0.0 and math.isfinite(norm):  # nothing heard and x_b = 0: no norm this period
                self.plen = rules.pi1_period(est, self.gamma, self.flood, self.period)
                self.norm = (self.epoch, norm, self.plen)
        self.x = rules.pi1_step(self.x, lx, phase, self.gamma)
        if phase == "GN":
            if self.norm[0] == self.epoch:
                self.x /= self.norm[1]
                self.normalised += 1
            else:
                self.missed_norm += 1
        return est

    def _pi2(self, ctx: Context, nbrs, values, lx) -> float | None:
        r = rules.pi2_phase(self.k, self.power, self.consensus)
        if r < self.power:  # a power step; the estimate is read on the vector it multiplies
            self.est = rules.ratio_estimate(self.x, lx)
            self.x -= self.gamma * lx
            if r == self.power - 1:  # w: the consensus on (w, |w|) starts with this iteration's frame
                self.w = self.x
                self.a, self.m = self.w, abs(self.w)
        else:
            # A neighbour's a, m were sent one iteration ago, in the same round (its r - 1 >= power - 1).
            self.a = rules.consensus_step(self.a, [b.a for _, b in nbrs if b.a is not None], self.eps)
            self.m = rules.max_step(self.m, [b.m for _, b in nbrs if b.m is not None])
            if r == self.power + self.consensus - 1:
                self.x = rules.pi2_normalise(self.w, self.a, self.m)
        return self.est

    def _wave(self, ctx: Context, nbrs, values, lx) -> float | None:
        s = rules.wave_step(self.x, self.prev, lx, self.k2)
        self.prev, self.x = self.x, s
        self.signal.append(s)
        if len(self.signal) > self.window:
            del self.signal[0]
        return rules.wave_estimate(self.signal, self.k2)

    def _send(self, ctx: Context) -> None:
        msg = L2(k=self.k, v=self.x)
        if self.method == "pi1" and self.norm[0] >= 0:
            msg.n = self.norm
        elif self.method == "pi2":
            msg.a, msg.m = self.a, self.m
        ctx.broadcast(KIND, encode(msg))

    # -------------------------------------------------------------- report
    def report(self) -> dict:
        return {
            "method": self.method,
            "final": self.estimates[-1] if self.estimates else None,
            "estimates": self.estimates,
            "iterations": max(self.k, 0),
            "dmax": self.dmax,
            "refused": dict(self.refused),
            "normalised": self.normalised,
            "missed_norm": self.missed_norm,
        }

    @classmethod
    def metrics(cls, reports: dict[int, dict]) -> dict:
        finals = sorted(r["final"] for r in reports.values() if r.get("final") is not None)
        return {
            "robots": len(reports),
            "median_final": finals[len(finals) // 2] if finals else None,
            "refused": sum(sum(r.get("refused", {}).values()) for r in reports.values()),
        }
