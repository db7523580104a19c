"""Oracle side of the role-switching family: what the robots should have done, from the world's truth.

Everything here reads a finished run (``Result``: reports, trace, scenario) and uses scipy / networkx; robot
code never imports this module.

Conventions
  * Roles, links (``conn``), parents and children at tick t are the robots' ``set_status`` fields after their
    step at tick t; positions are the trace's positions at tick t (the ones the robots sensed at t).
  * Gabriel graph at tick t: over the robots whose role is local leader or explorer at t (the paper: "all
    robots' roles are either local leaders or explorers in Algorithm 2"), the Delaunay edges a-b with
    |ab| <= d_c whose closed diametral disk holds no third such robot, i.e. no k with
    (x_a - x_k) . (x_b - x_k) <= 0: a robot exactly on the circle (a right angle) breaks the edge, as the
    paper's test asks for acute angles. A closed-disk-empty edge is an edge of every
    Delaunay triangulation, so the Delaunay candidates lose nothing even with co-circular points.
  * Formed network at tick t: the links (i, j) with j in conn_i or i in conn_j that the roles allow (both
    local leader or explorer, or a chain link named by a parent / child pointer), kept only when the two
    are within radio range of each other at t. A robot is connected when the formed network holds a path from it
    to the base station.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Iterator

import networkx as nx
import numpy as np
from scipy.spatial import Delaunay, QhullError, cKDTree

from swarmactors import Outcome, Result

BS, RP, LL, EX = "base_station", "repeater", "local_leader", "explorer"
LINKABLE = (LL, EX)


# ------------------------------------------------------------------ geometry
def gabriel_edges(ids: list[int], pos: np.ndarray, d_max: float = math.inf) -> set[tuple[int, int]]:
    """Gabriel edges (a < b, as robot ids) no longer than ``d_max``, by Delaunay candidates.

    Coincident robots (a wall can pile them up) follow the same test: two robots at one point form an edge
    (no third robot is in their zero-radius disk) and every other edge of theirs is broken by the twin
    (its angle is undefined: the dot product is 0); with three or more at one point, none.
    """
    n = len(ids)
    if n < 2:
        return set()
    pos = np.asarray(pos, dtype=float)[:, :2]
    uniq, first, inverse, counts = np.unique(pos, axis=0, return_index=True, return_inverse=True,
                                             return_counts=True)
    inverse = inverse.reshape(-1)
    out = set()
    for u in np.flatnonzero(counts == 2):
        a, b = np.flatnonzero(inverse == u)
        out.add((min(ids[a], ids[b]), max(ids[a], ids[b])))
    m = len(uniq)
    cands: set[tuple[int, int]] = set()
    if m == 2:
        cands.add((0, 1))
    elif m > 2:
        try:
            tri = Delaunay(uniq)
            for s in tri.simplices:
                a, b, c = (int(v) for v in s)
                cands.update({(min(a, b), max(a, b)), (min(b, c), max(b, c)), (min(a, c), max(a, c))})
        except (QhullError, ValueError):  # collinear points: test every pair
            cands = {(a, b) for a in range(m) for b in range(a + 1, m)}
    tree = cKDTree(pos)
    for ua, ub in cands:
        if counts[ua] > 1 or counts[ub] > 1:
            continue
        a, b = int(first[ua]), int(first[ub])
        dx, dy = pos[b, 0] - pos[a, 0], pos[b, 1] - pos[a, 1]
        if dx * dx + dy * dy > d_max * d_max:
            continue
        mid = (pos[a] + pos[b]) / 2
        r = math.sqrt(dx * dx + dy * dy) / 2
        ok = True
        for k in tree.query_ball_point(mid, r * (1 + 1e-9) + 1e-12):
            if k == a or k == b:
                continue
            ax, ay = pos[a, 0] - pos[k, 0], pos[a, 1] - pos[k, 1]
            if ax * (pos[b, 0] - pos[k, 0]) + ay * (pos[b, 1] - pos[k, 1]) <= 0:
                ok = False
                break
        if ok:
            out.add((min(ids[a], ids[b]), max(ids[a], ids[b])))
    return out


def gabriel_brute(ids: list[int], pos: np.ndarray, d_max: float = math.inf) -> set[tuple[int, int]]:
    """Return the same set by testing every pair against every robot (O(n^3)); for cross-checking."""
    pos = np.asarray(pos, dtype=float)[:, :2]
    out = set()
    n = len(ids)
    for a in range(n):
        for b in range(a + 1, n):
            dx, dy = pos[b, 0] - pos[a, 0], pos[b, 1] - pos[a, 1]
            if dx * dx + dy * dy > d_max * d_max:
                continue
            if all((pos[a, 0] - pos[k, 0]) * (pos[b, 0] - pos[k, 0])
                   + (pos[a, 1] - pos[k, 1]) * (pos[b, 1] - pos[k, 1]) > 0 for k in range(n) if k not in (a, b)):
                out.add((min(ids[a], ids[b]), max(ids[a], ids[b])))
    return out


def algebraic_connectivity(nodes: list[int], edges) -> float:
    """lambda_2 of the graph's Laplacian (0 when disconnected or fewer than 2 nodes)."""
    n = len(nodes)
    if n < 2:
        return 0.0
    idx = {v: k for k, v in enumerate(nodes)}
    lap = np.zeros((n, n))
    for a, b in edges:
        if a in idx and b in idx and a != b:
            i, j = idx[a], idx[b]
            lap[i, j] -= 1
            lap[j, i] -= 1
            lap[i, i] += 1
            lap[j, j] += 1
    return max(0.0, float(np.linalg.eigvalsh(lap)[1]))


# ------------------------------------------------------------------ reading a run
def _name(result: Result, name: str | None) -> str:
    if name:
        return name
    for g in result["scenario"]["robots"]:
        for b in g["behaviors"]:
            if b.get("as") in ("roles", "aat"):
                return b["as"]
    raise ValueError("no roles or aat behaviour in this scenario")


def params(result: Result, name: str = "roles") -> dict:
    return result.behavior_params(name)


def timeline(result: Result) -> Iterator[tuple[int, dict[int, np.ndarray], dict[int, dict]]]:
    """Per tick: (t, {id: position}, {id: status so far}) - status after the robots' step at t."""
    status: dict[int, dict] = defaultdict(dict)
    for rec in result.records():
        for rid, ch in rec.get("status", {}).items():
            status[int(rid)].update(ch)
        pos = {row[0]: np.array(row[1:3], dtype=float) for row in rec.get("pos", [])}
        yield rec["t"], pos, status


def formed_graph(pos: dict[int, np.ndarray], status: dict[int, dict], range_: float) -> nx.Graph:
    """Return the links the robots hold (either side) that their roles allow, within radio range.

    Allowed: local leader / explorer pairs, and chain links named by a parent or child pointer.
    """
    g = nx.Graph()
    g.add_nodes_from(pos)
    r2 = range_ * range_
    for i in pos:
        si = status.get(i, {})
        for j in si.get("conn") or []:
            if j not in pos or j == i:
                continue
            sj = status.get(j, {})
            allowed = (si.get("role") in LINKABLE and sj.get("role") in LINKABLE) or j in (
                si.get("parent"), si.get("child")) or i in (sj.get("parent"), sj.get("child"))
            if not allowed:
                continue
            d = pos[i] - pos[j]
            if d[0] * d[0] + d[1] * d[1] <= r2:
                g.add_edge(i, j)
    return g


def _gabriel_at(pos: dict[int, np.ndarray], d_c: float) -> set[tuple[int, int]]:
    ids = sorted(pos)
    return gabriel_edges(ids, np.array([pos[i] for i in ids]), d_c)


def _radio_range(result: Result) -> float:
    return float(min(result.ranges().values()))


def _link_range(result: Result, name: str) -> float:
    """The longest link the robots running ``name`` may hold: min of their radio range d_c and sensing range d_s.

    The behaviour reads both from its context (the robot group's ``range`` and ``sensing``).
    """
    robots = result.robots
    return float(min((min(robots[r]["range"], robots[r]["sensing"]) for r in result.reports(name)),
                     default=_radio_range(result)))


# ------------------------------------------------------------------ checks
def leader(result: Result, settle: int = 0, name: str | None = None) -> Outcome:
    """Exactly one local leader at every tick from ``settle`` on."""
    bad = []
    for t, pos, st in timeline(result):
        if t < settle:
            continue
        n = sum(1 for r in pos if st.get(r, {}).get("role") == LL)
        if n != 1:
            bad.append((t, n))
    return Outcome("roles.leader", not bad, value=len(bad), bound=0,
                   detail=f"ticks without exactly one local leader (tick, count): {bad[:8]}" if bad else
                   f"one local leader at every tick from {settle}", first_tick=bad[0][0] if bad else None)


def chain_ok(pos: dict[int, np.ndarray], st: dict[int, dict], base: int, d_c: float | None) -> str | None:
    """Why the repeaters do not form a chain base station -> ... -> local leader (None when they do)."""
    leaders = [r for r in pos if st.get(r, {}).get("role") == LL]
    if len(leaders) != 1:
        return f"{len(leaders)} local leaders"
    repeaters = {r for r in pos if st.get(r, {}).get("role") == RP}
    seen = [base]
    cur = base
    while True:
        nxt = st.get(cur, {}).get("child")
        if nxt is None or nxt not in pos:
            return f"chain ends at {cur} (child {nxt})"
        if st.get(nxt, {}).get("parent") != cur:
            return f"{nxt}'s parent is {st.get(nxt, {}).get('parent')}, not {cur}"
        if d_c is not None:
            d = pos[nxt] - pos[cur]
            if d[0] * d[0] + d[1] * d[1] > d_c * d_c:
                return f"chain link {cur}-{nxt} out of range ({math.hypot(*d):.3f})"
        if nxt in seen:
            return f"loop at {nxt}"
        seen.append(nxt)
        role = st.get(nxt, {}).get("role")
        if role == LL:
            break
        if role != RP:
            return f"{nxt} on the chain is a {role}"
        cur = nxt
    stray = repeaters - set(seen)
    if stray:
        return f"repeaters off the chain: {sorted(stray)}"
    return None


def chain(result: Result, settle: int = 0, physical: bool = True, name: str | None = None) -> Outcome:
    """Check the repeater chain from ``settle`` on.

    The base station's child pointers lead through repeaters (whose parent pointers agree) to the one local
    leader, every repeater is on that chain and, with ``physical``, every chain link
    is within radio range.
    """
    nm = _name(result, name)
    base = params(result, nm).get("base", 0)
    rng = _radio_range(result) if physical else None
    bad = []
    for t, pos, st in timeline(result):
        if t < settle:
            continue
        why = chain_ok(pos, st, base, rng)
        if why:
            bad.append((t, why))
    return Outcome("roles.chain", not bad, value=len(bad), bound=0,
                   detail=f"{bad[:5]}" if bad else "base station -> repeaters -> local leader at every tick",
                   first_tick=bad[0][0] if bad else None)


def gabriel(result: Result, grace: int = 2, min_formed: float = 0.0, exact: bool = False,
            cross_grace: int | None = None, name: str | None = None) -> list[Outcome]:
    """Check the links among the local leader and explorers (the ones Algorithm 2 governs).

    * ``roles.gabriel``: every link a robot holds at tick t is an edge of the Gabriel graph of the positions
      at some tick t' in [t - grace, t] over the robots that are local leader or explorer at some tick t''
      with |t'' - t'| <= grace (a CONNECT / DISCONNECT takes ``latency`` ticks to reach the other side, and
      so does the news of a role change, which the two robots of a hand-over apply a little before or after
      the others hear of it);
    * ``roles.cross_links``: no explorer keeps a link with a repeater or the base station for more than
      ``cross_grace`` ticks (default ``grace``);
    * ``roles.gabriel_formed``: at the last tick, the fraction of Gabriel edges between local-leader /
      explorer robots that are formed on both sides is at least ``min_formed``;
    * with ``exact``, ``roles.gabriel_exact``: the links equal the Gabriel graph at every tick (the baseline).
    """
    nm = _name(result, name)
    d_c = _link_range(result, nm)
    cross_grace = grace if cross_grace is None else cross_grace
    # (t, pos, role, {i: (conn, parent)}) by tick index, streamed: only ticks k - 2·grace .. k + grace are held
    views: dict[int, tuple[int, dict, dict, dict]] = {}
    source = timeline(result)
    read = 0  # views read so far (all of them once the trace is over)

    def fill(upto: int) -> None:
        nonlocal read
        if read > upto:
            return
        for t, pos, st in source:
            role = {r: st.get(r, {}).get("role") for r in pos}
            views[read] = (t, pos, role, {r: (st.get(r, {}).get("conn") or [], st.get(r, {}).get("parent"))
                                          for r in pos})
            read += 1
            if read > upto:
                return

    cache: dict[tuple[int, int], set] = {}

    def gab(a: int, b: int) -> set:
        if (a, b) not in cache:
            pos, role = views[a][1], views[b][2]
            cache[(a, b)] = _gabriel_at({r: p for r, p in pos.items() if role.get(r) in LINKABLE}, d_c)
        return cache[(a, b)]

    def acceptable(e: tuple[int, int], k: int) -> bool:
        for a in range(k, max(k - grace, 0) - 1, -1):
            for b in range(max(a - grace, 0), min(a + grace, read - 1) + 1):
                if e in gab(a, b):
                    return True
        return False

    bad: list[tuple] = []
    cross: dict[tuple[int, int], int] = {}
    cross_bad: list[tuple] = []
    not_exact: list[int] = []
    fractions = []
    lg = mutual = set()
    t = None
    k = -1
    while True:
        k += 1
        fill(k + grace)
        if k >= read:
            break
        t, pos, role, links = views[k]
        for old in [key for key in cache if key[0] < k - 2 * grace - 1]:
            del cache[old]
        views.pop(k - 2 * grace - 1, None)
        now = gab(k, k)
        held = set()
        now_cross = {}
        for i in pos:
            if role[i] not in LINKABLE:
                continue
            conn, parent = links[i]
            for j in conn:
                if j not in pos or (role[i] == LL and j == parent):
                    continue  # the local leader's parent is a chain link, not an Algorithm 2 link
                e = (min(i, j), max(i, j))
                if role[j] in LINKABLE:
                    held.add((i, j))
                    if e not in now and not acceptable(e, k):
                        bad.append((t, i, j))
                else:
                    since = cross.get((i, j), t)
                    now_cross[(i, j)] = since
                    if t - since > cross_grace:
                        cross_bad.append((t, i, j))
        cross = now_cross
        lg = now
        mutual = {(min(i, j), max(i, j)) for i, j in held if (j, i) in held}
        if lg:
            fractions.append(len(lg & mutual) / len(lg))
        if exact:
            one_sided = {(min(i, j), max(i, j)) for i, j in held}
            if one_sided != lg or mutual != lg:
                not_exact.append(t)
    frac = len(lg & mutual) / len(lg) if lg else 1.0
    mean = float(np.mean(fractions)) if fractions else 1.0
    out = [
        Outcome("roles.gabriel", not bad, value=len(bad), bound=0,
                detail=f"links outside the Gabriel graph (tick, i, j): {bad[:8]}" if bad else
                f"every local-leader/explorer link is a Gabriel edge (grace {grace} ticks)",
                first_tick=bad[0][0] if bad else None),
        Outcome("roles.cross_links", not cross_bad, value=len(cross_bad), bound=0,
                detail=f"explorer links to repeaters/base station beyond {cross_grace} ticks: {cross_bad[:8]}"
                if cross_bad else "none", first_tick=cross_bad[0][0] if cross_bad else None),
        Outcome("roles.gabriel_formed", frac >= min_formed, value=round(frac, 4), bound=min_formed,
                detail=f"{len(lg & mutual)} of {len(lg)} Gabriel edges formed at tick {t}; "
                       f"mean over the run {mean:.3f}"),
    ]
    if exact:
        out.append(Outcome("roles.gabriel_exact", not not_exact, value=len(not_exact), bound=0,
                           detail=f"ticks where links != Gabriel graph: {not_exact[:10]}" if not_exact else
                           "links = Gabriel graph at every tick", first_tick=not_exact[0] if not_exact else None))
    return out


def disconnection_episodes(result: Result, name: str | None = None) -> dict:
    """Return the disconnections from the base station, by the oracle.

    Per robot, the intervals [start, end) during which the formed network held no path to the base station
    (end None: still disconnected at the last tick), and per tick the number of disconnected robots.
    """
    nm = _name(result, name)
    base = params(result, nm).get("base", 0)
    rng = _radio_range(result)
    open_: dict[int, int] = {}
    episodes: list[tuple[int, int, int | None]] = []
    per_tick = []
    last_t = None
    for t, pos, st in timeline(result):
        g = formed_graph(pos, st, rng)
        reach = nx.node_connected_component(g, base) if base in g else set()
        off = set(pos) - reach
        per_tick.append((t, len(off)))
        for r in off:
            open_.setdefault(r, t)
        for r in list(open_):
            if r not in off:
                episodes.append((r, open_.pop(r), t))
        last_t = t
    for r, s in open_.items():
        episodes.append((r, s, None))
    return {"episodes": sorted(episodes, key=lambda e: (e[1], e[0])), "per_tick": per_tick, "last": last_t}


def disconnections(result: Result, max_recovery: int | None = None, settle: int = 0,
                   name: str | None = None) -> Outcome:
    """Check the disconnections from the base station (per robot, by the oracle).

    Every one is recovered within ``max_recovery`` ticks (one still open at the end counts when it is already longer).
    """
    info = disconnection_episodes(result, name)
    eps = [e for e in info["episodes"] if e[1] >= settle]
    last = info["last"]
    lengths = [(e[2] if e[2] is not None else last + 1) - e[1] for e in eps]
    closed = [e[2] - e[1] for e in eps if e[2] is not None]
    worst = max(lengths, default=0)
    ok = max_recovery is None or worst <= max_recovery
    swarm = sum(1 for _, n in info["per_tick"] if n)
    return Outcome("roles.disconnections", ok, value=worst, bound=max_recovery,
                   detail=f"{len(eps)} disconnections, mean length {np.mean(closed) if closed else 0:.1f} ticks, "
                          f"{sum(e[2] is None for e in eps)} open at the end, {swarm} ticks with a robot "
                          f"disconnected",
                   first_tick=next((e[1] for e, n in zip(eps, lengths, strict=True)
                                    if max_recovery and n > max_recovery), None))


def targets(result: Result, min_targets: int = 0, name: str | None = None) -> Outcome:
    """Check that the base station saw at least ``min_targets`` targets reached (reported up the chain)."""
    nm = _name(result, name)
    reached = sum(len(r.get("reached", [])) for r in result.reports(nm).values())
    return Outcome("roles.targets", reached >= min_targets, value=reached, bound=min_targets)


def connectivity(result: Result, every: int = 10, min_lambda2: float = 0.0, nodes: str = "all",
                 name: str | None = None) -> Outcome:
    """Report the mean algebraic connectivity of the formed network, sampled every ``every`` ticks.

    ``nodes`` = "all" or "linkable" (local leader and explorers only).
    """
    rng = _radio_range(result)
    vals = []
    for t, pos, st in timeline(result):
        if t % every:
            continue
        g = formed_graph(pos, st, rng)
        keep = list(pos) if nodes == "all" else [r for r in pos if st.get(r, {}).get("role") in LINKABLE]
        vals.append(algebraic_connectivity(sorted(keep), g.subgraph(keep).edges))
    mean = float(np.mean(vals)) if vals else 0.0
    return Outcome("roles.connectivity", mean >= min_lambda2, value=round(mean, 6), bound=min_lambda2,
                   detail=f"mean lambda_2 over {len(vals)} samples")


def ll_counts(result: Result) -> dict[int, int]:
    """Tick -> number of robots whose role is local leader."""
    return {t: sum(1 for r in pos if st.get(r, {}).get("role") == LL) for t, pos, st in timeline(result)}


def handover_gaps(result: Result, window: int = 60, name: str | None = None) -> list[dict]:
    """Return each hand-over request (from the requesters' reports) with its gap.

    The gap: the ticks from the request until the next request (at most ``window``) on which there was not
    exactly one local leader.
    """
    nm = _name(result, name)
    counts = ll_counts(result)
    hos = sorted(({"robot": rid, **h} for rid, r in result.reports(nm).items() for h in r.get("handovers", [])),
                 key=lambda h: (h["t"], h["robot"]))
    out = []
    for k, h in enumerate(hos):
        stop = min(hos[k + 1]["t"] if k + 1 < len(hos) else h["t"] + window, h["t"] + window)
        gap = [t for t in range(h["t"], max(stop, h["t"] + 1)) if t in counts and counts[t] != 1]
        out.append({**h, "gap": len(gap), "gap_ticks": gap[:10]})
    return out


def handover(result: Result, H: int = 3, quantile: float = 0.99, window: int = 60,
             name: str | None = None) -> list[Outcome]:
    """Check hand-overs under loss.

    At least ``quantile`` of them have at most ``H`` ticks without exactly one local leader, and no tick
    outside a hand-over's window lacks exactly one local leader.
    """
    gaps = handover_gaps(result, window, name)
    within = sum(g["gap"] <= H for g in gaps)
    frac = within / len(gaps) if gaps else 1.0
    counts = ll_counts(result)
    covered = set()
    for g in gaps:
        covered.update(range(g["t"], g["t"] + window))
    stray = sorted(t for t, n in counts.items() if n != 1 and t not in covered)
    worst = max((g["gap"] for g in gaps), default=0)
    return [
        Outcome("roles.handover_gap", frac >= quantile, value=round(frac, 4), bound=quantile,
                detail=f"{within} of {len(gaps)} hand-overs with gap <= {H} ticks; worst gap {worst}; "
                       f"outcomes {dict(_count(g['outcome'] for g in gaps))}"),
        Outcome("roles.leader_outside_handovers", not stray, value=len(stray), bound=0,
                detail=f"ticks without exactly one local leader outside hand-overs: {stray[:10]}" if stray else "",
                first_tick=stray[0] if stray else None),
    ]


def _count(it) -> dict:
    out: dict = {}
    for v in it:
        out[v] = out.get(v, 0) + 1
    return out
