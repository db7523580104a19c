"""Message-expiration flooding (Kobayashi et al. 2022, Sec. III-C).

The originator broadcasts (origin, msg_id, deadline, payload), the deadline
being the send time plus the expiration period. Rules, per robot:

* F1 - a copy that arrives after its deadline is ignored (counted ``expired``);
* F2 - the first copy of (origin, msg_id) is delivered once (``received``
  records its hop count, arrival time and sender);
* F3 - on that first copy, while the deadline has not passed (arrival <=
  deadline), the robot forwards it to all its neighbours except the sender
  (a broadcast excluding the sender);
* F4 - with a hop limit H (option ``hops``), a copy travels at most H hops, and
  a robot forwards again when a copy arrives with strictly more hops left
  than any before, so that asynchrony cannot hide a robot behind a long path.

With a time deadline alone, forwarding on first arrival reaches exactly the
robots whose earliest possible arrival is not after the deadline: in lockstep
with per-hop latency c, the robots within floor(expiry / c) hops.

Parameters: ``origin`` (robot id), ``at`` (tick of origination), ``expiry``
(ticks in lockstep, seconds in realtime; none = no deadline), ``hops``
(optional limit), ``payload``. One flood per run.
"""

from __future__ import annotations

from collections import Counter, defaultdict

import networkx as nx

from swarmactors import Behavior, Context, Frame, Outcome, Result
from swarmactors.conformance import Case, Family, comb, ladder, line, random_geometric, ring

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
def _params(result: Result) -> dict:
    """The flood's parameters (defaults for any a user's implementation does not declare)."""
    return {"origin": 0, "at": 0, "expiry": None, "hops": None} | result.behavior_params("flooding")


def _receivers(result: Result, behavior: str = "flooding") -> dict[int, dict]:
    return {rid: next(iter(r["received"].values())) for rid, r in result.reports(behavior).items() if r.get("received")}


def oracle_arrivals(result: Result) -> tuple[dict[int, int], dict[int, int]]:
    """Earliest arrival tick and hop per robot, lossless, lockstep (time-expanded BFS over true positions)."""
    p = _params(result)
    c = result["scenario"]["radio"]["latency"]
    deadline = None if p["expiry"] is None else p["at"] + p["expiry"]
    hop_limit = p["hops"]
    records = {rec["t"]: rec for rec in result.trace}
    origin_tick = min(t for t in records if t >= p["at"])
    arrival = {p["origin"]: origin_tick}
    hop = {p["origin"]: 0}
    for t in sorted(records):
        senders = [u for u, a in arrival.items() if a == t and (hop_limit is None or hop[u] < hop_limit)]
        if not senders:
            continue
        g = result.graph_at(t, directed=True)
        later = records.get(t + c)
        alive_then = {row[0] for row in later["pos"]} if later else set()
        for u in sorted(senders, key=lambda u: hop[u]):
            if u not in g:
                continue
            for v in g.successors(u):
                if v in arrival or v not in alive_then:
                    continue
                if deadline is not None and t + c > deadline:
                    continue
                arrival[v], hop[v] = t + c, hop[u] + 1
    return arrival, hop


def reach(result: Result) -> list[Outcome]:
    """Lockstep, no loss: receivers, hops and arrival ticks equal the time-expanded BFS oracle."""
    arrival, hop = oracle_arrivals(result)
    got = _receivers(result)
    missing = sorted(set(arrival) - set(got))
    extra = sorted(set(got) - set(arrival))
    wrong_hop = sorted(r for r in set(got) & set(arrival) if got[r]["hop"] != hop[r])
    wrong_tick = sorted(r for r in set(got) & set(arrival) if got[r]["tick"] != arrival[r])
    bad = missing or extra or wrong_hop or wrong_tick
    first = min([arrival[r] for r in missing + wrong_hop + wrong_tick] + [got[r]["tick"] for r in extra], default=None)
    return [
        Outcome("flooding.reach", not bad, value=len(got), bound=len(arrival),
                detail=(f"missing {missing[:10]} extra {extra[:10]} wrong hop {wrong_hop[:10]} "
                        f"wrong tick {wrong_tick[:10]}") if bad else "receivers = oracle, hop = BFS distance",
                first_tick=first),
    ]


def _flood_frames(result: Result) -> tuple[dict, list]:
    """(src, seq) -> send tick of FLOOD frames, and FLOOD deliveries [src, seq, dst, sent, at]."""
    sent = {}
    deliveries = []
    for rec in result.trace:
        for src, seq, kind, _dst, _size in rec.get("sent", []):
            if kind == KIND:
                sent[(src, seq)] = rec["t"]
    for rec in result.trace:
        for src, seq, dst, sent_tick in rec.get("del", []):
            if (src, seq) in sent:
                deliveries.append((src, seq, dst, sent_tick, rec["t"]))
    return sent, deliveries


def delivered(result: Result) -> Outcome:
    """With loss: receivers = robots that got a FLOOD delivery no later than the deadline (plus the origin)."""
    p = _params(result)
    deadline = None if p["expiry"] is None else p["at"] + p["expiry"]
    _, deliveries = _flood_frames(result)
    arrivals: dict[int, int] = {}
    for _, _, dst, _, at in deliveries:
        if deadline is None or at <= deadline:
            arrivals[dst] = min(at, arrivals.get(dst, at))
    expected = {p["origin"]} | set(arrivals)
    receivers = _receivers(result)
    got = set(receivers)
    ok = got == expected
    first = min([arrivals.get(r, p["at"]) for r in expected - got] + [receivers[r]["tick"] for r in got - expected],
                default=None)
    return Outcome("flooding.delivered", ok, value=len(got), bound=len(expected),
                   detail="" if ok else f"missing {sorted(expected - got)[:10]} extra {sorted(got - expected)[:10]}",
                   first_tick=first)


def component(result: Result) -> Outcome:
    """Every robot of the origin's component (true graph at origination) receives, with hop >= BFS distance."""
    p = _params(result)
    t0 = min(rec["t"] for rec in result.trace if rec["t"] >= p["at"])
    g = result.graph_at(t0)
    dist = nx.single_source_shortest_path_length(g, p["origin"])
    got = _receivers(result)
    missing = sorted(set(dist) - set(got))
    extra = sorted(set(got) - set(dist))
    short = sorted(r for r in got if r in dist and got[r]["hop"] < dist[r])
    ok = not (missing or extra or short)
    return Outcome("flooding.component", ok, value=len(got), bound=len(dist),
                   detail="" if ok else f"missing {missing[:10]} extra {extra[:10]} hop < BFS {short[:10]}")


def forwarding(result: Result) -> list[Outcome]:
    """Each receiver forwarded exactly once (expiry-only) and never back to the robot it got the flood from."""
    p = _params(result)
    got = _receivers(result)
    sent, deliveries = _flood_frames(result)
    per_src = Counter(src for src, _ in sent)
    if p["hops"] is None:
        wrong = sorted(r for r in got if per_src.get(r, 0) != 1)
        outcome_count = Outcome("flooding.forward_once", not wrong, value=len(got) - len(wrong), bound=len(got),
                                detail="" if not wrong else f"robots forwarding != 1 time: {wrong[:10]}")
    else:
        wrong = sorted(r for r in got if (got[r]["hop"] < p["hops"]) != (per_src.get(r, 0) >= 1))
        outcome_count = Outcome("flooding.forward_once", not wrong, value=len(got) - len(wrong), bound=len(got),
                                detail="" if not wrong else f"robots forwarding against the hop limit: {wrong[:10]}")
    first_from = {r: e["from"] for r, e in got.items()}
    senders_first_seq = defaultdict(lambda: None)
    for (src, seq), _t in sorted(sent.items(), key=lambda kv: kv[0][1]):
        if senders_first_seq[src] is None:
            senders_first_seq[src] = seq
    back = sorted({src for src, seq, dst, _, _ in deliveries
                   if seq == senders_first_seq[src] and first_from.get(src) is not None and dst == first_from[src]})
    return [
        outcome_count,
        Outcome("flooding.not_to_sender", not back, value=len(back), bound=0,
                detail="" if not back else f"robots that sent the flood back to their sender: {back[:10]}"),
    ]


# ---------------------------------------------------------------- conformance suite
def _flood_case(name: str, positions: list, checks: list[str], *, expiry=4, loss=0.0, clock="lockstep",
                seed=1, events=(), ticks=None) -> Case:
    run = {"seed": seed, "clock": clock, "ticks": ticks or int(expiry) + 4}
    radio = {"range": 1.0, "latency": 1, "loss": loss}
    if clock == "realtime":
        run.update(dt=0.05, ticks=ticks or 40)
        radio.update(latency_s=0.02, latency_min_s=0.01)
    scenario = {"run": run, "radio": radio,
                "robots": [{"positions": positions,
                            "behaviors": [{"use": "flooding", "origin": 0, "at": 1, "expiry": expiry}]}],
                "events": list(events)}
    return Case(f"flooding/{name}", scenario, [{"use": c} for c in checks])


def suite(mode: str) -> list[Case]:
    """Graph families x clocks x loss x faults; ``quick`` is a small subset of ``full``."""
    exact = ["flooding.reach", "flooding.forwarding"]
    lossy = ["flooding.delivered", "flooding.forwarding"]
    cases = [
        _flood_case("ring-8", ring(8), exact, expiry=3),
        _flood_case("comb-9", comb(9), exact, expiry=5),
        _flood_case("rgg-20-s1", random_geometric(20, 1), exact),
        _flood_case("rgg-20-s1-loss-0.2", random_geometric(20, 1), lossy, loss=0.2, expiry=6),
        _flood_case("line-8-killed-relay", line(8), exact, expiry=8, events=[{"at": 0, "kill": [3]}]),
        _flood_case("rgg-12-s2-realtime", random_geometric(12, 2), ["flooding.component", "flooding.forwarding"],
                    expiry=3.0, clock="realtime"),
    ]
    if mode == "full":
        for n in (16, 32):
            cases.append(_flood_case(f"ring-{n}", ring(n), exact, expiry=n // 3))
        for n in (10, 20):
            cases.append(_flood_case(f"ladder-{n}", ladder(n), exact, expiry=4))
        cases.append(_flood_case("comb-17", comb(17), exact, expiry=6))
        for n in (10, 40):
            for seed in (1, 2, 3):
                cases.append(_flood_case(f"rgg-{n}-s{seed}", random_geometric(n, seed), exact, seed=seed))
        for loss in (0.1, 0.3):
            for seed in (2, 3):
                cases.append(_flood_case(f"rgg-30-s{seed}-loss-{loss}", random_geometric(30, seed), lossy,
                                         loss=loss, expiry=8, seed=seed))
        cases.append(_flood_case("rgg-30-s3-realtime", random_geometric(30, 3),
                                 ["flooding.component", "flooding.forwarding"], expiry=4.0, clock="realtime"))
        cases.append(_flood_case("ring-12-cut", ring(12), exact, expiry=8, events=[{"at": 0, "cut": [[0, 1]]}]))
    return cases


FAMILY = Family(name="flooding", behavior="flooding", report={"received": dict, "forwarded": int}, suite=suite)
