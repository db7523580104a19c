"""Biconnectivity: oracle checks (tests and suites only)."""

from __future__ import annotations

import networkx as nx
import numpy as np

from protocols.biconnectivity.behavior import CR, DCR, MOVE
from protocols.biconnectivity.geometry import two_closest_sum
from swarmactors import Outcome, Result


# ================================================================ oracle (checks and tests only)
def paper_biconnected(g: nx.Graph) -> bool:
    """Lemma 1's biconnectivity: every pair doubly connected; so one or two robots are not."""
    return g.number_of_nodes() >= 3 and nx.is_biconnected(g)


def doubly_connected(g: nx.Graph, v) -> set:
    """Robots with two internally vertex-disjoint paths to v: those in a block of >= 3 robots with v."""
    out = set()
    for block in nx.biconnected_components(g):
        if v in block and len(block) >= 3:
            out |= block
    out.discard(v)
    return out


def path_ends(g: nx.Graph, limit: int | None = None) -> dict:
    """Number of simple paths (vertex sequences of length >= 1) ending at each vertex.

    Robot R sends ``ends[R]`` CR frames per period (its own and ``ends[R] - 1``
    relays) and receives the sum of ``ends[x]`` over its neighbours x.
    Raises OverflowError past ``limit`` paths in all.
    """
    adj = {v: list(g.neighbors(v)) for v in g}
    ends = dict.fromkeys(g, 0)
    total = 0
    for s in g:
        ends[s] += 1
        total += 1
        visited = {s}
        stack = [(s, iter(adj[s]))]
        while stack:
            u, it = stack[-1]
            for w in it:
                if w not in visited:
                    visited.add(w)
                    ends[w] += 1
                    total += 1
                    if limit is not None and total > limit:
                        raise OverflowError(f"more than {limit} simple paths")
                    stack.append((w, iter(adj[w])))
                    break
            else:
                stack.pop()
                visited.discard(u)
    return ends


def expected_counts(g: nx.Graph, limit: int | None = None) -> dict:
    """Per robot and per kind (CR and DCR alike): frames sent, relayed and received in one period."""
    ends = path_ends(g, limit)
    return {v: {"sent": ends[v], "relayed": ends[v] - 1, "received": sum(ends[x] for x in g.neighbors(v))} for v in g}


def _behaviour_params(result: Result) -> dict:
    return result.behavior_params("biconnectivity")


def _tick_len(result: Result) -> float:
    """Clock units per tick: 1 in lockstep (times are ticks), dt seconds in realtime."""
    return 1.0 if result["clock"] == "lockstep" else float(result["scenario"]["run"]["dt"])


def complete_periods(rep: dict, result: Result) -> set[int]:
    """The periods of one robot's report whose fill ran its full 3Nc.

    That is, periods cut short neither by a newer period nor by the end of the run.
    """
    unit = _tick_len(result)
    last = result.last_tick()
    wait = rep["bounds"]["fill"] / unit
    joined = sorted((int(p), st["joined_tick"]) for p, st in rep.get("periods", {}).items()
                    if st["joined_tick"] is not None)
    out = set()
    for k, (p, j) in enumerate(joined):
        end = joined[k + 1][1] if k + 1 < len(joined) else last
        if end - j >= wait - 1e-9:
            out.add(p)
    return out


def _period_graph(result: Result, p: int) -> nx.Graph:
    ticks = result.ticks()
    later = ticks[ticks >= p]
    return result.graph_at(int(later[0] if len(later) else ticks[-1]))


def lists(result: Result) -> Outcome:
    """Static, lossless: CR = the component minus the robot; DCR = robots sharing a block of >= 3 with it."""
    wrong = []
    n = 0
    graphs: dict[int, nx.Graph] = {}
    for rid, rep in result.reports("biconnectivity").items():
        p = rep.get("period")
        if p is None or rep["periods"][str(p)]["over_budget"] or p not in complete_periods(rep, result):
            continue
        if p not in graphs:
            graphs[p] = _period_graph(result, p)
        g = graphs[p]
        if rid not in g:
            continue
        n += 1
        comp = nx.node_connected_component(g, rid) - {rid}
        if set(rep["cr"]) != comp or set(rep["dcr"]) != doubly_connected(g, rid):
            wrong.append(rid)
    return Outcome("biconnectivity.lists", not wrong, value=n - len(wrong), bound=n,
                   detail=f"wrong CR/DCR at robots {wrong[:10]}" if wrong else "CR = component, DCR = shared blocks")


def verdict(result: Result) -> list[Outcome]:
    """Every check-running robot decides, equal to the paper's biconnectivity of its component, within 6Nc + 2c."""
    wrong, late, undecided = [], [], []
    n = 0
    graphs: dict[int, nx.Graph] = {}
    end = result.last_tick() * _tick_len(result)
    for rid, rep in result.reports("biconnectivity").items():
        bound = rep["bounds"]["check"]
        for ck in rep.get("checks", []):
            if ck.get("reason") in ("budget", "superseded"):
                continue
            if ck["verdict"] is None and ck["reason"] is None and end < ck["requested"] + bound:
                continue  # still running when the run ended
            n += 1
            p = ck["period"]
            if p not in graphs:
                graphs[p] = _period_graph(result, p)
            g = graphs[p]
            if ck["verdict"] is None:
                undecided.append(rid)
                continue
            truth = paper_biconnected(g.subgraph(nx.node_connected_component(g, rid)))
            if ck["verdict"] != truth:
                wrong.append(rid)
            if ck["decided"] - ck["requested"] > bound + 1e-9:
                late.append(rid)
    return [
        Outcome("biconnectivity.verdict", not (wrong or undecided), value=n - len(wrong) - len(undecided), bound=n,
                detail=f"wrong {wrong[:10]} undecided {undecided[:10]}" if wrong or undecided else ""),
        Outcome("biconnectivity.deadline", not late, value=len(late), bound=0,
                detail=f"decided after 6Nc + 2c: {late[:10]}" if late else "every decision within 6Nc + 2c"),
    ]


def paths(result: Result, limit: int = 2_000_000) -> Outcome:
    """Static, lossless, within budget: per period, frames received/relayed = the oracle's simple-path counts."""
    wrong = []
    n = 0
    cache: dict[int, dict] = {}
    for rid, rep in result.reports("biconnectivity").items():
        complete = complete_periods(rep, result)
        for p, st in rep.get("periods", {}).items():
            p = int(p)
            if st["over_budget"] or p not in complete:
                continue
            if p not in cache:
                g = _period_graph(result, p)
                comp_of = {}
                for comp in nx.connected_components(g):
                    exp = expected_counts(g.subgraph(comp), limit)
                    comp_of.update(exp)
                cache[p] = comp_of
            exp = cache[p].get(rid)
            if exp is None:
                continue
            n += 1
            for kind in (CR, DCR):
                got = (st["received"].get(kind, 0), st["relayed"].get(kind, 0), st["sent"].get(kind, 0))
                if got != (exp["received"], exp["relayed"], exp["sent"]):
                    wrong.append((rid, p, kind, got, (exp["received"], exp["relayed"], exp["sent"])))
    return Outcome("biconnectivity.paths", not wrong, value=n - len({w[:2] for w in wrong}), bound=n,
                   detail=f"(robot, period, kind, got, expected): {wrong[:5]}" if wrong
                   else "received/relayed/sent = simple-path counts")


def removal(result: Result) -> list[Outcome]:
    """After a removal: the final swarm is biconnected, and no link present at the first MOVE breaks later."""
    leads = [r for rep in result.reports("biconnectivity").values() for r in rep.get("removals", [])]
    rec, severed = result.last_state()
    g_end = result.graph_at(rec["t"], rec=rec, severed=severed)
    ok_end = paper_biconnected(g_end)
    broken: list = []
    first = None
    edges0: set = set()
    for rec, severed in result.states():  # one streamed pass: the first MOVE, then every later tick's graph
        if first is None:
            if any(row[2] == MOVE for row in rec.get("sent", [])):
                first = rec["t"]
                alive_end = set(g_end)
                g0 = result.graph_at(first, rec=rec, severed=severed)
                edges0 = {tuple(sorted(e)) for e in g0.edges if e[0] in alive_end and e[1] in alive_end}
            continue
        g = result.graph_at(rec["t"], rec=rec, severed=severed)
        for a, b in edges0:
            if a in g and b in g and not g.has_edge(a, b):
                broken.append((rec["t"], a, b))
        if broken:
            break
    return [
        Outcome("biconnectivity.removal_biconnected", ok_end and bool(leads), value=ok_end, bound=True,
                detail=f"leaders' removals: {[(r['removed'], r['d'], r['rounds'], r['verdict']) for r in leads]}"),
        Outcome("biconnectivity.links_kept", not broken, value=len(broken), bound=0,
                detail=f"links broken during the moves (tick, a, b): {broken[:5]}" if broken else "", first_tick=first),
    ]


def oracle_best_join(centres: np.ndarray, reach: float, spacing: float) -> float:
    """Best heuristic value over a fine grid of positions within ``reach`` of at least two centres."""
    centres = np.asarray(centres, dtype=float)
    lo = centres.min(axis=0) - reach
    hi = centres.max(axis=0) + reach
    xs = np.arange(lo[0], hi[0] + spacing, spacing)
    ys = np.arange(lo[1], hi[1] + spacing, spacing)
    best = 0.0
    for y in ys:
        pts = np.stack([xs, np.full_like(xs, y)], axis=1)
        d = np.linalg.norm(pts[:, None, :] - centres[None, :, :], axis=-1)
        ok = (d <= reach).sum(axis=1) >= min(2, len(centres))
        if ok.any():
            two = np.partition(d[ok], 1, axis=1)[:, :2].sum(axis=1) if d.shape[1] > 1 else d[ok][:, 0]
            best = max(best, float(two.max()))
    return best


def join(result: Result, ratio: float = 0.95, spacing: float | None = None) -> list[Outcome]:
    """A joiner ends with >= 2 neighbours, the swarm stays biconnected, value >= ratio x the grid optimum."""
    params = _behaviour_params(result)
    region = float(params.get("region", 0.0))
    rec, severed = result.last_state()
    g = result.graph_at(rec["t"], rec=rec, severed=severed)
    pos = {row[0]: np.array(row[1:3]) for row in rec["pos"]}
    outs = []
    for rid, rep in result.reports("biconnectivity").items():
        j = rep.get("join")
        if not j:
            continue
        others = np.array([p for r, p in pos.items() if r != rid])
        reach = float(result.robots[rid]["range"]) - 2 * region  # the joiner's radio range, from its group
        best = oracle_best_join(others, reach, spacing or reach / 400)
        value = float(two_closest_sum(pos[rid][None], others)[0])
        deg = g.degree(rid) if rid in g else 0
        outs.append(Outcome("biconnectivity.join", deg >= 2 and paper_biconnected(g) and value >= ratio * best,
                            value=round(value / best, 4) if best else None, bound=ratio,
                            detail=f"robot {rid}: degree {deg}, biconnected {paper_biconnected(g)}, "
                                   f"value {value:.4f}, grid best {best:.4f}"))
    if not outs:
        outs.append(Outcome("biconnectivity.join", False, detail="no robot joined"))
    return outs
