"""Flooding: the robot side (rules F1-F3). Imports no oracle."""

from __future__ import annotations

from collections import Counter

from swarmactors import Behavior, Context, Frame

KIND = "FLOOD"


class Flooding(Behavior):
    """Forward-once flooding with a deadline and an optional hop limit."""

    name = "flooding"
    kinds = (KIND,)
    plot_field = "hop"

    def __init__(self, origin: int = 0, at: int = 0, expiry: float | None = None, hops: int | None = None,
                 payload: object = None):
        self.origin, self.at, self.expiry, self.hops, self.payload = origin, at, expiry, hops, payload
        self.received: dict[str, dict] = {}
        self.best_hop: dict[str, int] = {}
        self.forwards: Counter = Counter()
        self.expired = 0
        self.duplicates = 0
        self.malformed = 0
        self.originated = False

    @staticmethod
    def validate(params: dict) -> str | None:
        if params.get("expiry") is None and params.get("hops") is None:
            return "give expiry (the expiration period) or hops (a hop limit), or both"
        for key in ("origin", "at", "hops"):
            v = params.get(key)
            if v is not None and (not isinstance(v, int) or isinstance(v, bool) or v < 0):
                return f"{key} = {v!r} must be a non-negative integer"
        e = params.get("expiry")
        if e is not None and (not isinstance(e, (int, float)) or isinstance(e, bool) or e < 0):
            return f"expiry = {e!r} must be a non-negative number"
        return None

    def on_tick(self, ctx: Context, sensed) -> None:
        if ctx.id == self.origin and not self.originated and ctx.tick >= self.at:
            self.originated = True
            msg = f"{ctx.id}/0"
            deadline = None if self.expiry is None else ctx.now + self.expiry
            self.received[msg] = {"hop": 0, "tick": ctx.tick, "time": ctx.now, "from": None}
            self.best_hop[msg] = 0
            ctx.set_status(hop=0)
            self._send(ctx, msg, deadline, 1, exclude=())

    def on_frame(self, ctx: Context, frame: Frame) -> None:
        body = frame.body
        try:
            msg, deadline, hop, payload = body["m"], body["dl"], int(body["h"]), body.get("p")
        except (TypeError, KeyError, ValueError):
            self.malformed += 1
            return
        if deadline is not None and ctx.now > deadline:  # F1
            self.expired += 1
            return
        first = msg not in self.received
        if first:  # F2
            self.received[msg] = {"hop": hop, "tick": ctx.tick, "time": ctx.now, "from": frame.src}
            ctx.set_status(hop=hop)
        else:
            self.duplicates += 1
        improved = hop < self.best_hop.get(msg, hop + 1)
        if improved:
            self.best_hop[msg] = hop
        may_forward = self.hops is None or hop < self.hops
        if may_forward and (first or (self.hops is not None and improved)):  # F3, F4
            self._send(ctx, msg, deadline, hop + 1, exclude=(frame.src,), payload=payload)

    def _send(self, ctx: Context, msg: str, deadline, hop: int, exclude, payload=None) -> None:
        self.forwards[msg] += 1
        ctx.broadcast(KIND, {"m": msg, "dl": deadline, "h": hop, "p": payload if payload is not None else self.payload},
                      exclude=exclude)

    def report(self) -> dict:
        return {
            "received": self.received,
            "forwarded": sum(self.forwards.values()),
            "forwards": dict(self.forwards),
            "best_hop": self.best_hop,
            "expired": self.expired,
            "duplicates": self.duplicates,
            "malformed": self.malformed,
        }

    @classmethod
    def metrics(cls, reports: dict[int, dict]) -> dict:
        got = [r for r in reports.values() if r.get("received")]
        hops = [e["hop"] for r in got for e in r["received"].values()]
        return {
            "robots": len(reports),
            "received": len(got),
            "coverage": len(got) / len(reports) if reports else 0.0,
            "max_hop": max(hops, default=None),
            "frames_forwarded": sum(r.get("forwarded", 0) for r in reports.values()),
        }


# ---------------------------------------------------------------- oracle checks
