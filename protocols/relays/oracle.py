"""Swarm Relays: oracle checks over the trace (tests and suites only).

The checks read only the status contract (``role``, ``chain``, ``parent``, ``child``, ``depth``, published
with ``set_status``), the trace's positions and events, and the scenario's parameters; they never call the
protocol's own code. A chain at tick t is the list of robots met by following ``parent`` from the robot
whose role is ``worker`` for that chain to the root. A link is in the true radio graph when both robots are
alive and within each other's range (the scenario's ranges; occlusion is not modelled here: the cases have
none or keep links clear of obstacles).
"""

from __future__ import annotations

import math

from swarmactors import Outcome, Result


def _timeline(result: Result, kills: list[int] | None = None):
    """Yield (tick, positions {id: (x, y)}, statuses {id: {field: value}}) tick by tick (replayed changes).

    ``kills``: a list that receives the ticks with a kill event, in the same pass (what ``_kills`` returns
    once the pass is over), so a check that needs both reads the trace once.
    """
    status: dict[int, dict] = {}
    for rec in result.records():
        for rid, fields in rec.get("status", {}).items():
            status.setdefault(int(rid), {}).update(fields)
        pos = {row[0]: tuple(row[1:]) for row in rec.get("pos", [])}  # 3-D in a 3-D world
        if kills is not None and any("kill" in ev for ev in rec.get("ev", ())):
            kills.append(rec["t"])
        yield rec["t"], pos, status


def _params(result: Result) -> dict:
    try:
        return result.behavior_params("relays")
    except KeyError:
        return {}


def _per_target(p: dict) -> int:
    """C_n, the chains per target: chain c serves target c // C_n (status contract)."""
    return int(p.get("chains_per_target", 1))


def _tolerance(p: dict) -> float:
    """How near its target a worker must come: r_col, widened when C_n workers share one target.

    C_n bodies cannot all stand within r_col of one point; they stand side by side ``spacing`` apart (0.3 m,
    the reference code's strand offset), so the outermost is (C_n - 1)/2 * spacing off the target.
    """
    return p.get("rcol", 0.25) + (_per_target(p) - 1) / 2 * p.get("spacing", 0.3)


def _chains(status: dict[int, dict], pos: dict) -> dict[int, list[list[int]]]:
    """Map chain -> one path per alive robot whose role is worker for it.

    A path is [worker, ..., the last robot reached by parent pointers]; it ends at the root when whole.
    Two workers of one chain are two paths.
    """
    out: dict[int, list[list[int]]] = {}
    for rid, s in sorted(status.items()):
        if s.get("role") != "worker" or s.get("chain") is None or rid not in pos:
            continue
        path, seen, cur = [rid], {rid}, status[rid].get("parent")
        while cur is not None and cur not in seen:
            path.append(cur)
            seen.add(cur)
            if status.get(cur, {}).get("role") == "root":
                break
            cur = status.get(cur, {}).get("parent")
        out.setdefault(s["chain"], []).append(path)
    return out


def _whole(paths: list[list[int]], pos: dict, status: dict, rng: dict) -> bool:
    """Every path ends at the root and each of its links is in range between alive robots."""
    for path in paths:
        if status.get(path[-1], {}).get("role") != "root":
            return False
        for a, b in zip(path, path[1:], strict=False):
            if a not in pos or b not in pos or math.dist(pos[a], pos[b]) > min(rng.get(a, 0), rng.get(b, 0)):
                return False
    return True


def _kills(result: Result) -> list[int]:
    return sorted({rec["t"] for rec in result.records() for ev in rec.get("ev", ()) if "kill" in ev})


def connected(result: Result, heal_window: float = 60.0) -> list[Outcome]:
    """Every chain is a whole path root -> worker in the radio graph at every tick.

    With C_n chains per target (``chains_per_target``), the chains of one target share no robot but the root.

    Ticks within ``heal_window`` seconds after a kill are not judged; the value is the longest
    disconnection outside them (ticks).
    """
    dt = result["scenario"]["run"].get("dt", 1.0)
    win = round(heal_window / dt)
    windows = [(k, k + win) for k in _kills(result)]
    rng = result.ranges()
    cn = _per_target(_params(result))
    longest, run, first, ticks, broken, shared = 0, {}, None, 0, 0, 0
    for t, pos, status in _timeline(result):
        if any(a <= t <= b for a, b in windows):
            run = {}
            continue
        chains = _chains(status, pos)
        for c, path in chains.items():
            ticks += 1
            mine = {r for q in path for r in q if status.get(r, {}).get("role") != "root"}
            overlap = any(mine & set(q) for c2, p2 in chains.items() if c2 != c and c2 // cn == c // cn
                          for q in p2)  # redundant chains of one target share only the root
            shared += overlap
            if _whole(path, pos, status, rng) and not overlap:
                run[c] = 0
            else:
                broken += 1
                run[c] = run.get(c, 0) + 1
                longest = max(longest, run[c])
                first = first if first is not None else t
    ok = longest == 0 and ticks > 0
    return [Outcome("relays.connected", ok, longest, 0,
                    f"{ticks} chain-ticks judged, {broken} broken; longest disconnection {longest} ticks"
                    + (f"; {shared} chain-ticks sharing a robot with another chain of the same target" if shared
                       else "")
                    + (f" (healing windows of {heal_window} s after kills {_kills(result)} excluded)"
                       if windows else "")
                    + ("" if ticks else "; no chain was ever built"), first)]


def links_within_db(result: Result) -> list[Outcome]:
    """No chain link (a robot and its parent, both alive) is ever longer than d_b; time beyond d_s reported."""
    p = _params(result)
    db = p.get("db", 1.8)
    dt = result["scenario"]["run"].get("dt", 1.0)
    worst, first, beyond = _scan(result)["links"]
    return [Outcome("relays.links_within_db", first is None, round(worst, 6), db,
                    f"longest chain link {worst:.3f} m (d_b = {db}); link-time beyond d_s + 1 cm = {beyond * dt:.1f} s",
                    first, op="<=")]


def _scan(result: Result, tol: float | None = None) -> dict:
    """One pass over the trace for ``reached`` and ``links_within_db`` (kept on the result, per ``tol``).

    ``tol`` None: any pass already made (the links do not depend on it), else one with ``_tolerance``.
    first_reach: chain -> the first tick its worker is within ``tol`` of its target (horizontally); kills:
    the ticks with a kill event; links: (longest chain link, first tick one exceeds d_b, link-ticks beyond
    d_s + 1 cm) over every robot with a role of worker or networker and a parent, both with a position.
    """
    memo = result.__dict__.setdefault("_relays_scan", {})
    if tol is None and memo:
        return next(iter(memo.values()))
    p = _params(result)
    tol = _tolerance(p) if tol is None else tol
    if tol in memo:
        return memo[tol]
    cn, targets = _per_target(p), p.get("targets", [])
    ds, db = p.get("ds", 1.4), p.get("db", 1.8)
    first_reach: dict[int, int] = {}
    kills: list[int] = []
    worst, first, beyond = 0.0, None, 0
    for t, pos, status in _timeline(result, kills):
        for rid, s in status.items():
            role, c = s.get("role"), s.get("chain")
            if role == "worker" and is_chain(c, len(targets) * cn) and rid in pos \
                    and c not in first_reach and math.dist(pos[rid][:2], targets[c // cn][:2]) <= tol:
                first_reach[c] = t
            par = s.get("parent")
            if role not in ("worker", "networker") or par is None or rid not in pos or par not in pos:
                continue
            d = math.dist(pos[rid], pos[par])
            worst = max(worst, d)
            beyond += d > ds + 0.01
            if d > db and first is None:
                first = t
    memo[tol] = {"first_reach": first_reach, "kills": kills, "links": (worst, first, beyond)}
    return memo[tol]


def reached(result: Result, tol: float | None = None, slack: float = 1.0) -> list[Outcome]:
    """Each reachable target's worker comes within r_col of it (horizontally) in time.

    The bound is the specified T = planning + n (bidding + d_s / v_max) + d_path / v_max with bidding =
    ``bid_time``, plus the elections (``at`` and one bid_time per target up to this one) and 60 s per kill,
    times ``slack``. An unreachable target is reported so by its worker (plan_status), not looped on.
    """
    p = _params(result)
    cn = _per_target(p)
    targets = p.get("targets", [])
    tol = tol if tol is not None else _tolerance(p)
    dt = result["scenario"]["run"].get("dt", 1.0)
    reports = result.reports("relays")
    out = []
    scan = _scan(result, tol)
    first_reach, kills = scan["first_reach"], scan["kills"]
    for c in range(len(targets) * cn):
        target = targets[c // cn]
        rep = next((r for r in reports.values() if r.get("chain") == c and r.get("role") == "worker"
                    and r.get("path")), None)  # a worker that died before planning is no worker to judge by
        rep = rep or next((r for r in reports.values() if r.get("chain") == c and r.get("role") == "worker"), None)
        if rep is None:  # no worker now: the one that planned says why (a hand-over to a flying robot is no reason)
            rep = next((r for r in reports.values() if r.get("chain") == c and r.get("plan_status")
                        and not str(r["plan_status"]).startswith("handed")), None)
        if rep is not None and rep.get("plan_status") not in ("ok", None):
            out.append(Outcome("relays.reached", True, None, None,
                               f"{_name(c, cn)} {target}: reported {rep['plan_status']!r}, no chain built"))
            continue
        path = rep.get("path") if rep else None
        dpath = sum(math.dist(a[:2], b[:2]) for a, b in zip(path, path[1:], strict=False)) if path else math.nan
        ds, v = p.get("ds", 1.4), p.get("vmax", 0.5)
        n = math.ceil(dpath / ds) if path else 0
        bid = p.get("bid_time", 10.0)
        bound_s = (p.get("at", 1) * dt + (c + 1) * bid + p.get("plan_time", 2.0)
                   + n * (bid + ds / v) + dpath / v + 60.0 * len(kills)) * slack
        got = first_reach.get(c)
        ok = got is not None and got * dt <= bound_s
        out.append(Outcome("relays.reached", ok, None if got is None else round(got * dt, 3),
                           round(bound_s, 3) if math.isfinite(bound_s) else None,
                           f"{_name(c, cn)} {target}: worker within {tol} m at "
                           f"{'never' if got is None else f'{got * dt:.1f} s'}; path {dpath:.2f} m, n = {n}",
                           None if ok else got, op="<="))
    return out or [Outcome("relays.reached", False, None, None, "no target")]


def is_chain(c, n: int) -> bool:
    return isinstance(c, int) and 0 <= c < n


def _name(c: int, cn: int) -> str:
    return f"target {c}" if cn == 1 else f"chain {c} (target {c // cn})"


def healed(result: Result) -> list[Outcome]:
    """After each kill, every chain is whole again (root -> worker, no dead robot); recovery time reported."""
    dt = result["scenario"]["run"].get("dt", 1.0)
    rng = result.ranges()
    kills = _kills(result)
    if not kills:
        return [Outcome("relays.healed", True, None, None, "no failure injected")]
    p = _params(result)
    targets, cn, tol = p.get("targets", []), _per_target(p), _tolerance(p)
    pending = list(kills)
    times, back = {}, {}
    for t, pos, status in _timeline(result):
        if times and len(back) < len(times):  # after healing: the worker back at its target
            for rid, s in status.items():
                c = s.get("chain")
                if s.get("role") == "worker" and is_chain(c, len(targets) * cn) and rid in pos \
                        and math.dist(pos[rid][:2], targets[c // cn][:2]) <= tol:
                    for k in times:
                        back.setdefault(k, t)
        if not pending or t <= pending[0]:
            continue
        chains = _chains(status, pos)
        if chains and all(_whole(p, pos, status, rng) for p in chains.values()):
            times[pending.pop(0)] = t
    ok = not pending
    worst = max((t - k for k, t in times.items()), default=None)
    return [Outcome("relays.healed", ok, None if worst is None else round(worst * dt, 3), None,
                    "; ".join(f"kill at tick {k}: whole again after {(t - k) * dt:.1f} s, worker back at its "
                              f"target {'never' if k not in back else f'after {(back[k] - k) * dt:.1f} s'}"
                              for k, t in times.items())
                    + (f"; never healed after kills at ticks {pending}" if pending else ""),
                    pending[0] if pending else None)]
