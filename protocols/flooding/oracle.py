"""Flooding: oracle checks, computed from the trace and the product's graph (tests and suites only)."""

from __future__ import annotations

from collections import Counter, defaultdict, deque

import networkx as nx

from protocols.flooding.behavior import KIND
from swarmactors import Outcome, Result


def _params(result: Result) -> dict:
    """The flood's parameters (defaults for any a user's implementation does not declare)."""
    return {"origin": 0, "at": 0, "expiry": None, "hops": None} | result.behavior_params("flooding")


def _receivers(result: Result, behavior: str = "flooding") -> dict[int, dict]:
    return {rid: next(iter(r["received"].values())) for rid, r in result.reports(behavior).items() if r.get("received")}


def oracle_arrivals(result: Result) -> tuple[dict[int, int], dict[int, int]]:
    """Earliest arrival tick and hop per robot, lossless, lockstep (time-expanded BFS over true positions).

    Streamed: the ticks from t to t + c (radio.latency) are held, no more.
    """
    p = _params(result)
    c = result["scenario"]["radio"]["latency"]
    deadline = None if p["expiry"] is None else p["at"] + p["expiry"]
    hop_limit = p["hops"]
    arrival: dict[int, int] = {}
    hop: dict[int, int] = {}
    window: deque = deque()  # (record, severed) of the ticks not yet judged, oldest first

    def judge(rec: dict, severed) -> None:
        t = rec["t"]
        if not arrival and t >= p["at"]:
            arrival[p["origin"]], hop[p["origin"]] = t, 0
        senders = [u for u, a in arrival.items() if a == t and (hop_limit is None or hop[u] < hop_limit)]
        if not senders:
            return
        g = result.graph_at(t, directed=True, rec=rec, severed=severed)
        later = rec if c == 0 else next((r for r, _ in window if r["t"] == t + c), None)
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

    for rec, severed in result.states():
        window.append((rec, severed))
        while window[0][0]["t"] + c <= rec["t"]:
            judge(*window.popleft())
            if not window:
                break
    while window:
        judge(*window.popleft())
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
        Outcome("flooding.reach", not bad, value=len(got), op="=", bound=len(arrival),
                detail=(f"missing {missing[:10]} extra {extra[:10]} wrong hop {wrong_hop[:10]} "
                        f"wrong tick {wrong_tick[:10]}") if bad else "receivers = oracle, hop = BFS distance",
                first_tick=first),
    ]


def _flood_frames(result: Result) -> tuple[dict, list]:
    """(src, seq) -> send tick of FLOOD frames, and FLOOD deliveries [src, seq, dst, sent, at]."""
    sent = {}
    deliveries = []
    for rec in result.records():  # two streamed passes: a delivery may share its send's tick record
        for src, seq, kind, _dst, _size in rec.get("sent", []):
            if kind == KIND:
                sent[(src, seq)] = rec["t"]
    for rec in result.records():
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
    return Outcome("flooding.delivered", ok, value=len(got), op="=", bound=len(expected),
                   detail="" if ok else f"missing {sorted(expected - got)[:10]} extra {sorted(got - expected)[:10]}",
                   first_tick=first)


def component(result: Result) -> Outcome:
    """Every robot of the origin's component (true graph at origination) receives, with hop >= BFS distance."""
    p = _params(result)
    t0 = result.first_tick(p["at"])
    g = result.graph_at(t0)
    dist = nx.single_source_shortest_path_length(g, p["origin"])
    got = _receivers(result)
    missing = sorted(set(dist) - set(got))
    extra = sorted(set(got) - set(dist))
    short = sorted(r for r in got if r in dist and got[r]["hop"] < dist[r])
    ok = not (missing or extra or short)
    return Outcome("flooding.component", ok, value=len(got), op="=", bound=len(dist),
                   detail="" if ok else f"missing {missing[:10]} extra {extra[:10]} hop < BFS {short[:10]}")


def forwarding(result: Result) -> list[Outcome]:
    """Each receiver forwarded exactly once (expiry-only) and never back to the robot it got the flood from."""
    p = _params(result)
    got = _receivers(result)
    sent, deliveries = _flood_frames(result)
    per_src = Counter(src for src, _ in sent)
    if p["hops"] is None:
        wrong = sorted(r for r in got if per_src.get(r, 0) != 1)
        outcome_count = Outcome("flooding.forward_once", not wrong, value=len(got) - len(wrong), op="=", bound=len(got),
                                detail="" if not wrong else f"robots forwarding != 1 time: {wrong[:10]}")
    else:
        wrong = sorted(r for r in got if (got[r]["hop"] < p["hops"]) != (per_src.get(r, 0) >= 1))
        outcome_count = Outcome("flooding.forward_once", not wrong, value=len(got) - len(wrong), op="=", bound=len(got),
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
        Outcome("flooding.not_to_sender", not back, value=len(back), op="=", bound=0,
                detail="" if not back else f"robots that sent the flood back to their sender: {back[:10]}"),
    ]


# ---------------------------------------------------------------- conformance suite


# Exact arrival ticks hold only under the lockstep clock; a realtime run asks for flooding.component.
reach.clocks = ("lockstep",)
reach.instead = {"realtime": "flooding.component"}
