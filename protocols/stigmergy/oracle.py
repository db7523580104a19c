"""Virtual stigmergy: oracle checks (tests and suites only)."""

from __future__ import annotations

import math

import networkx as nx

from protocols.stigmergy.table import Entry, conflict_rule
from swarmactors import Outcome, Result


# ------------------------------------------------------------------ oracle checks
def _last_tick(result: Result) -> int:
    return result.last_tick()


def oracle_tables(result: Result, behavior: str = "stigmergy", graph: nx.Graph | None = None) -> dict[int, dict]:
    """Robot -> {str(key): [value, ts, writer]} that the write log implies for its component.

    For each key: among the writes by robots of the component, the highest
    timestamp; among those, the winner of the conflict rule (folded pairwise).
    """
    params = result.behavior_params(behavior)
    rule = conflict_rule(params.get("conflict", "higher_id"))
    reports = result.reports(behavior)
    g = graph if graph is not None else result.graph_at(_last_tick(result))
    out: dict[int, dict] = {}
    for comp in nx.connected_components(g):
        best: dict[str, Entry] = {}
        for rid in sorted(comp):
            for _tick, key, value, ts in reports.get(rid, {}).get("writes", []):
                e = Entry(value, ts, rid)
                k = str(key)
                cur = best.get(k)
                if cur is None or e.ts > cur.ts:
                    best[k] = e
                elif e.ts == cur.ts and e.writer != cur.writer:
                    best[k] = Entry(*rule(key, cur, e))
        table = {k: [e.value, e.ts, e.writer] for k, e in best.items()}
        for rid in comp:
            out[rid] = table
    return out


def consistent(result: Result, behavior: str = "stigmergy", within: int | None = None) -> Outcome:
    """Every robot holds exactly the oracle's table of its component (last-tick graph).

    With ``within``, also: every robot's last change is no later than ``within`` ticks after its component's
    last write.
    """
    oracle = oracle_tables(result, behavior)
    reports = result.reports(behavior)
    wrong = sorted(rid for rid, rep in reports.items() if rid in oracle and rep["table"] != oracle[rid])
    late: list[int] = []
    if within is not None:
        g = result.graph_at(_last_tick(result))
        for comp in nx.connected_components(g):
            last_write = max((w[0] for r in comp for w in reports.get(r, {}).get("writes", [])), default=None)
            if last_write is None:
                continue
            late += [r for r in comp if max(reports[r]["changed_at"].values(), default=0) > last_write + within]
    ok = not wrong and not late
    detail = ""
    if wrong:
        r = wrong[0]
        detail = f"robots with a wrong table {wrong[:10]}; robot {r} has {reports[r]['table']} != {oracle[r]}"
    elif late:
        detail = f"robots that changed later than {within} ticks after the last write: {sorted(late)[:10]}"
    return Outcome("stigmergy.consistent", ok, value=len(reports) - len(wrong), bound=len(reports), detail=detail)


def latency(result: Result, behavior: str = "stigmergy") -> Outcome:
    """Lockstep, no loss: robot r holds each key's final entry by t_w + c * hops(writer, r)."""
    c = result["scenario"]["radio"]["latency"]
    reports = result.reports(behavior)
    g = result.graph_at(_last_tick(result))
    oracle = oracle_tables(result, behavior, g)
    write_tick = {(rid, str(w[1]), w[3]): w[0] for rid, r in reports.items() for w in r["writes"]}
    late = []
    for rid, rep in reports.items():
        for key, (_v, ts, writer) in oracle.get(rid, {}).items():
            bound = write_tick[(writer, key, ts)] + c * nx.shortest_path_length(g, writer, rid)
            got = rep["changed_at"].get(key)
            if got is None or got > bound:
                late.append((rid, key, got, bound))
    return Outcome("stigmergy.latency", not late, value=len(late), bound=0,
                   detail="" if not late else f"(robot, key, changed at, bound): {late[:5]}")


def oracle_elections(result: Result, behavior: str = "election") -> dict[int, dict[str, int]]:
    """Robot -> {key: winner}: per component, the lowest (distance to target, id) at each election's opening.

    With ``exclusive``, one election after the other, without the earlier winners.
    """
    params = result.behavior_params(behavior)
    start, duration = params.get("start", 1), params.get("duration", 20)
    exclusive = params.get("exclusive", True)
    specs = params["elections"]
    g = result.graph_at(start)
    out: dict[int, dict[str, int]] = {}
    for comp in nx.connected_components(g):
        taken: set[int] = set()
        winners: dict[str, int] = {}
        for i, spec in enumerate(specs):
            t = start + (i * duration if exclusive else 0)
            pos = {row[0]: row[1:] for row in result.record(t)["pos"]}
            target = list(spec["target"])
            cands = []
            for r in comp:
                if exclusive and r in taken or r not in pos:
                    continue
                p = pos[r]
                d = round(math.dist(p, (target + [0.0] * len(p))[: len(p)]), 9)
                cands.append((d, r))
            if cands:
                winners[spec["key"]] = min(cands)[1]
                taken.add(winners[spec["key"]])
        for r in comp:
            out[r] = winners
    return out


def election(result: Result, behavior: str = "election") -> Outcome:
    """Every robot read the oracle's winner of every election (lowest distance, then lowest id)."""
    oracle = oracle_elections(result, behavior)
    reports = result.reports(behavior)
    wrong = sorted(r for r, rep in reports.items() if r in oracle and rep["elected"] != oracle[r])
    detail = ""
    if wrong:
        r = wrong[0]
        detail = f"robots with a wrong winner {wrong[:10]}; robot {r} read {reports[r]['elected']} != {oracle[r]}"
    return Outcome("stigmergy.election", not wrong, value=len(reports) - len(wrong), bound=len(reports),
                   detail=detail)
