"""λ2 estimation: the robot side (PI1, PI2, Wave). Imports no oracle.

One iteration per tick. After iteration k every robot broadcasts one L2 frame {k, v, ...} (v its x_i or
s_i, plus what the method piggybacks); at iteration k + 1 it uses the values its neighbours sent.

* R1 (drop = "drop", the authors' makeAnoisy) - only the frames that arrived since the last iteration are
  used; a lost frame removes both its x_j and its share of the degree for that iteration. In realtime (where
  a late frame and a lost one look alike) each neighbour's value of the previous iteration is used, or its
  latest older one within ``hold`` iterations.
  (drop = "reuse") - the last value heard from each neighbour within ``hold`` iterations is used.
* R2 - a frame that is not a dict of finite numbers, or whose k is from the future (k > own k, one more in
  realtime), is refused and counted by cause; it changes nothing.
* R3 - warm-up (no ``dmax`` given): for ``warmup`` ticks robots count who they hear and flood the largest
  degree (max of theirs and what they hear); then d_max is frozen and iteration 0 starts.
* PI1 - rules.pi1_phase/pi1_step; at the start of each period (an L step) the beacon computes its norm and
  the period's length (rules.pi1_period, from its own estimate) and floods (epoch, norm, length) piggybacked
  (latest epoch wins); every robot divides by the norm ``flood`` iterations later and starts the next
  period when this one ends (``period`` iterations until it has heard the length).
* PI2 - rules.pi2_phase: a power step w = x − γLx, then ``consensus`` steps of (I − εL) on (w, w²) in the
  same frames, then x = (w − mean)/RMS.
* Wave - rules.wave_step on the robot's own signal; rules.wave_estimate on its FFT.

Each iteration's estimate goes to the status field ``l2`` and to the report's ``estimates``.
"""

from __future__ import annotations

import math
from collections import Counter

from protocols.lambda2 import rules
from swarmactors import Behavior, Context, Frame

KIND = "L2"


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


class Lambda2(Behavior):
    """Distributed estimate of the Laplacian's λ2 by PI1, PI2 or the wave method."""

    name = "lambda2"
    kinds = (KIND,)
    plot_field = "l2"

    def __init__(self, method: str = "pi1", drop: str = "drop", hold: int = 10, dmax: int | None = None,
                 warmup: int = 12, period: int = 30, flood: int = 12, beacon: int = 0, consensus: int = 100,
                 window: int = 1024, at: int = 0):
        self.method, self.drop, self.hold, self.dmax = method, drop, hold, dmax
        self.warmup = 0 if dmax is not None else warmup
        self.period, self.flood, self.beacon, self.consensus = period, flood, beacon, consensus
        self.window, self.at = window, at
        self.k = -1 - self.warmup - at  # iteration of the state held (k < 0: before iteration 0)
        self.x = 0.0
        self.heard: dict[int, dict[int, tuple[int, dict]]] = {}  # neighbour -> its k -> (own k at receipt, body)
        self.fresh: set[int] = set()  # neighbours heard since the last iteration
        self.ever: set[int] = set()
        self.dm = 0  # warm-up max-degree flood
        self.estimates: list[float | None] = []
        self.refused: Counter = Counter()
        self.norm = (-1, 1.0, period)  # PI1: latest (epoch, norm, period length) the beacon flooded
        self.epoch, self.start, self.plen = -1, 1, 0  # PI1: current period, its first iteration, its length
        self.normalised = 0
        self.missed_norm = 0
        self.w = self.a = self.q = 0.0  # PI2 round state
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
                         ("consensus", 1), ("window", 16), ("at", 0), ("dmax", 1)):
            v = params.get(key)
            if v is not None and (not isinstance(v, int) or isinstance(v, bool) or v < low):
                return f"{key} = {v!r} must be an integer >= {low}"
        if params.get("flood", 12) + 3 > params.get("period", 30):
            return f"flood = {params.get('flood', 12)} must be at most period - 3 = {params.get('period', 30) - 3}"
        return None

    # -------------------------------------------------------------- receive
    def on_frame(self, ctx: Context, frame: Frame) -> None:
        body = frame.body
        if (not isinstance(body, dict) or not isinstance(body.get("k"), int) or isinstance(body.get("k"), bool)
                or "v" not in body):
            self.refused["malformed"] += 1
            return
        for key, v in body.items():
            if key == "n":
                ok = (isinstance(v, list) and len(v) == 3 and isinstance(v[0], int) and _finite(v[1]) and v[1] > 0
                      and isinstance(v[2], int) and v[2] > self.flood + 2)
            else:
                ok = _finite(v)
            if not ok:  # R2: a value that is not a finite number
                self.refused["nonfinite" if isinstance(v, float) else "malformed"] += 1
                return
        slack = 1 if ctx.clock == "realtime" else 0
        if body["k"] > self.k + slack:  # R2: an iteration number from the future
            self.refused["future"] += 1
            return
        kept = self.heard.setdefault(frame.src, {})
        if len(kept) >= 3 and body["k"] < min(kept):  # older than the three iterations kept
            self.refused["stale"] += 1
            return
        kept[body["k"]] = (self.k, body)
        if len(kept) > 3:
            del kept[min(kept)]
        self.fresh.add(frame.src)
        if "dm" in body:
            self.dm = max(self.dm, int(body["dm"]))
        if "n" in body and body["n"][0] > self.norm[0]:  # PI1 flood: the latest epoch wins
            self.norm = (body["n"][0], float(body["n"][1]), body["n"][2])

    def _neighbours(self, k: int, realtime: bool) -> list[tuple[int, dict]]:
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
            ctx.broadcast(KIND, {"k": k, "v": self.x, "dm": self.dm})
            return
        if k == 0:
            self.dmax = self.dmax if self.dmax is not None else max(self.dm, len(self.ever), 1)
            self.gamma = rules.step_size(self.dmax)
            self.k2 = rules.wave_k2(self.dmax)
            self.signal = [self.x]
            self.prev = self.x
            self._send(ctx)
            return
        values = [b["v"] for _, b in nbrs]
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
        r = rules.pi2_phase(self.k, self.consensus)
        if r == 0:  # power step, then consensus on (w, w²) starts
            self.est = rules.ratio_estimate(self.x, lx)
            self.w = self.x - self.gamma * lx
            self.a, self.q = self.w, self.w * self.w
        else:
            # A neighbour's a, q were sent one iteration ago, in the same round (its r - 1 >= 0).
            eps = rules.consensus_eps(self.dmax)
            self.a = rules.consensus_step(self.a, [b["a"] for _, b in nbrs if "a" in b], eps)
            self.q = rules.consensus_step(self.q, [b["q"] for _, b in nbrs if "q" in b], eps)
            if r == self.consensus:
                self.x = rules.pi2_normalise(self.w, self.a, self.q)
        return getattr(self, "est", None)

    def _wave(self, ctx: Context, nbrs, values, lx) -> float | None:
        s = rules.wave_step(self.x, self.prev, lx, self.k2)
        self.prev, self.x = self.x, s
        self.signal.append(s)
        if len(self.signal) > self.window:
            del self.signal[0]
        return rules.wave_estimate(self.signal, self.k2)

    def _send(self, ctx: Context) -> None:
        body = {"k": self.k, "v": self.x}
        if self.method == "pi1" and self.norm[0] >= 0:
            body["n"] = list(self.norm)
        elif self.method == "pi2":
            body.update(a=self.a, q=self.q)
        ctx.broadcast(KIND, body)

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
