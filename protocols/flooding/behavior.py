"""Flooding: the robot side (rules F1-F4, F1r with ``lifetime = "remaining"``). Imports no oracle."""

from __future__ import annotations

from collections import Counter

from protocols.flooding.messages import BODIES, KIND, Flood
from swarmactors import Behavior, Context, Frame
from swarmactors.robot.bodies import UNSET


class Flooding(Behavior):
    """Forward-once flooding with an expiration period and an optional hop limit.

    ``lifetime = "deadline"`` (the default): a copy carries the absolute deadline, origin's clock + expiry,
    and each receiver compares it with its own clock (F1). ``lifetime = "remaining"`` (F1r): a
    copy carries its remaining lifetime; each hop consumes ``hop_cost`` of it (Kobayashi et al. §III-A:
    "consuming a single timestep per hop"), and a copy with a negative remainder has expired. No clock is
    compared across robots, so clock offset and drift cannot change who receives the message.
    """

    name = "flooding"
    kinds = (KIND,)
    plot_field = "hop"

    def __init__(self, origin: int = 0, at: int = 0, expiry: float | None = None, hops: int | None = None,
                 payload: object = None, lifetime: str = "deadline", hop_cost: float | None = None):
        self.origin, self.at, self.expiry, self.hops, self.payload = origin, at, expiry, hops, payload
        self.lifetime = lifetime  # "deadline" (F1) or "remaining" (F1r)
        self.hop_cost = hop_cost  # F1r: lifetime one hop consumes; None = one tick (1 in lockstep, dt in realtime)
        self.received: dict[str, dict] = {}
        self.best_hop: dict[str, int] = {}
        self.forwards: Counter = Counter()
        self.expired = 0
        self.duplicates = 0
        self.malformed: Counter = Counter()  # undecodable FLOOD bodies by cause
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
        if params.get("lifetime", "deadline") not in ("deadline", "remaining"):
            return f"lifetime = {params['lifetime']!r} must be 'deadline' or 'remaining'"
        h = params.get("hop_cost")
        if h is not None and (not isinstance(h, (int, float)) or isinstance(h, bool) or h <= 0):
            return f"hop_cost = {h!r} must be a number > 0"
        return None

    def _cost(self, ctx: Context) -> float:
        """F1r: what one hop consumes of a copy's lifetime (one time step: a tick, in the clock's unit)."""
        if self.hop_cost is not None:
            return float(self.hop_cost)
        return 1.0 if ctx.clock == "lockstep" else ctx.dt

    def on_tick(self, ctx: Context, sensed) -> None:
        if ctx.id == self.origin and not self.originated and ctx.tick >= self.at:
            self.originated = True
            msg = f"{ctx.id}/0"
            if self.lifetime == "remaining":
                deadline = self.expiry  # F1r: the whole lifetime is left when the origin sends
            else:
                deadline = None if self.expiry is None else ctx.now + self.expiry
            self.received[msg] = {"hop": 0, "tick": ctx.tick, "time": ctx.now, "from": None}
            self.best_hop[msg] = 0
            ctx.set_status(hop=0)
            self._send(ctx, msg, deadline, 1, exclude=())

    def on_frame(self, ctx: Context, frame: Frame) -> None:
        body = BODIES.decode(frame, self.malformed)
        if not isinstance(body, Flood):
            return
        remaining = self.lifetime == "remaining"
        msg, deadline, hop, payload = body.msg, body.remaining if remaining else body.deadline, body.hop, body.payload
        if deadline is UNSET:  # the other lifetime's key: a copy this robot cannot judge
            self.malformed["missing_field"] += 1
            return
        if deadline is not None and remaining:
            deadline = float(deadline) - self._cost(ctx)  # F1r: the hop consumed one time step
        if deadline is not None and (deadline < -1e-9 if remaining else ctx.now > deadline):  # F1 / F1r
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
        remaining = self.lifetime == "remaining"  # F1r: the lifetime left as the copy leaves
        BODIES.broadcast(ctx, Flood(msg=msg, deadline=UNSET if remaining else deadline,
                                    remaining=deadline if remaining else UNSET, hop=hop,
                                    payload=payload if payload is not None else self.payload), exclude=exclude)

    def report(self) -> dict:
        return {
            "received": self.received,
            "forwarded": sum(self.forwards.values()),
            "forwards": dict(self.forwards),
            "best_hop": self.best_hop,
            "expired": self.expired,
            "duplicates": self.duplicates,
            "malformed": dict(self.malformed),
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
