"""λ2 estimation: oracle checks against numpy's eigenvalues of the true Laplacian (tests and suites only).

The truth is λ2 of the Laplacian of the world's radio graph (``Result.graph_at``, mutual links) at the last
tick, by ``numpy.linalg.eigh``. The paper's error is e = |λ̂2 − λ2| / (10⁻²·λ2), in percent. ``accurate``
judges **every robot's own estimate**, not the swarm's median (which the authors' Octave code reports and
``error_series`` still computes for the figures): a median can be exact while most robots are wrong.

Zeros of the Fiedler vector: a robot i where the λ2-eigenvector is (nearly) zero cannot read λ2 from the
ratio (Lx)_i/x_i (at an exact zero it reads another eigenvalue, e.g. the hub of a star reads λ_max). The
rule: with V an orthonormal basis of λ2's eigenspace (one column when λ2 is simple), robot i is **at a
zero** when the norm of its row of V is below ``zero`` (0.1) times the largest row norm; such robots are
named in the outcome with their error and not judged. A disconnected graph has λ2 = 0: the oracle says so
and judges each component against its own λ2, the only value a robot can learn by talking to its
neighbours.
"""

from __future__ import annotations

import math

import networkx as nx
import numpy as np

from swarmactors import Outcome, Result


def laplacian_lambda2(g: nx.Graph) -> float:
    """λ2 of the graph's combinatorial Laplacian D − A (0 for one robot or a disconnected graph)."""
    if g.number_of_nodes() < 2:
        return 0.0
    a = nx.to_numpy_array(g, nodelist=sorted(g))
    lap = np.diag(a.sum(axis=1)) - a
    return float(max(np.linalg.eigvalsh(lap)[1], 0.0))


def fiedler_weights(g: nx.Graph) -> tuple[float, dict[int, float]]:
    """(λ2, robot -> its row norm in an orthonormal basis of λ2's eigenspace, relative to the largest).

    λ2's eigenspace: the eigenvalues within 10⁻⁹·max(1, λ2) of λ2 (a ring's or a star's λ2 is multiple).
    """
    nodes = sorted(g)
    if len(nodes) < 2:
        return 0.0, {n: 1.0 for n in nodes}
    a = nx.to_numpy_array(g, nodelist=nodes)
    w, vecs = np.linalg.eigh(np.diag(a.sum(axis=1)) - a)
    l2 = float(max(w[1], 0.0))
    cols = [i for i in range(1, len(w)) if abs(w[i] - w[1]) <= 1e-9 * max(1.0, abs(w[1]))]
    rows = np.linalg.norm(vecs[:, cols], axis=1)
    top = float(rows.max()) or 1.0
    return l2, {n: float(r / top) for n, r in zip(nodes, rows, strict=True)}


def components(result: Result) -> list[tuple[list[int], float]]:
    """(robots, λ2 of their component) for each connected component of the true graph at the last tick."""
    rec, severed = result.last_state()
    g = result.graph_at(rec["t"], rec=rec, severed=severed)
    return [(sorted(c), laplacian_lambda2(g.subgraph(c))) for c in nx.connected_components(g)]


def _median(values: list) -> float | None:
    vals = [v for v in values if v is not None and math.isfinite(v)]
    return float(np.median(vals)) if vals else None


def error_series(reports: dict[int, dict], robots: list[int], truth: float) -> list[float]:
    """e(k) in percent of the median estimate of ``robots`` at every iteration (inf without one)."""
    series = [reports[r]["estimates"] for r in robots if r in reports]
    n = min((len(s) for s in series), default=0)
    out = []
    for k in range(n):
        med = _median([s[k] for s in series])
        out.append(math.inf if med is None or truth <= 0 else abs(med - truth) / (1e-2 * truth))
    return out


def settled(errors: list[float], tol_percent: float) -> int | None:
    """The first iteration (1-based) from which e stays ≤ tol to the end; None if the last one is above."""
    if not errors or errors[-1] > tol_percent:
        return None
    k = len(errors)
    while k > 0 and errors[k - 1] <= tol_percent:
        k -= 1
    return k + 1


def first_within(errors: list[float], tol_percent: float) -> int | None:
    """The first iteration (1-based) with e ≤ tol, or None."""
    return next((k + 1 for k, e in enumerate(errors) if e <= tol_percent), None)


def robot_errors(reports: dict[int, dict], robots: list[int], truth: float) -> dict[int, float]:
    """Each robot's final e in percent (inf without an estimate)."""
    out = {}
    for r in robots:
        est = reports[r]["final"] if r in reports else None
        out[r] = math.inf if est is None or truth <= 0 or not math.isfinite(est) else abs(est - truth) / (1e-2 * truth)
    return out


def distribution(errors: list[float]) -> dict[str, float | None]:
    """Worst, 90th percentile (nearest rank) and median of per-robot errors (None for none)."""
    e = sorted(errors)
    if not e:
        return {"worst": None, "p90": None, "median": None}
    return {"worst": e[-1], "p90": e[min(len(e) - 1, math.ceil(0.9 * len(e)) - 1)],
            "median": float(np.median(e)) if all(map(math.isfinite, e)) else e[len(e) // 2]}


def per_robot_iterations(reports: dict[int, dict], truth: float, tol_percent: float = 1.0) -> dict[int, int | None]:
    """For each robot: the iteration from which its own estimate stays within tol (None: never)."""
    out = {}
    for rid, rep in reports.items():
        errs = [math.inf if e is None or truth <= 0 else abs(e - truth) / (1e-2 * truth) for e in rep["estimates"]]
        out[rid] = settled(errs, tol_percent)
    return out


def accurate(result: Result, tol: float = 1.0, within: int | None = None, zero: float = 0.1,
             name: str = "lambda2") -> list[Outcome]:
    """Every robot's final estimate is within ``tol`` percent of its component's λ2 (numpy eigh).

    Robots at a zero of the Fiedler vector (row norm < ``zero`` × the largest, see the module) are named and
    not judged. With ``within``: every judged robot's e also stays ≤ tol from iteration ``within`` on. The
    outcome's value is the worst judged robot's error in percent (the largest over components); the detail
    gives per component λ2, the worst, 90th percentile and median per-robot error, and the robots excluded.
    """
    reports = result.reports(name)
    rec, severed = result.last_state()
    g = result.graph_at(rec["t"], rec=rec, severed=severed)
    comps = [sorted(c) for c in nx.connected_components(g)]
    worst, details, ok, first_bad = 0.0, [], True, None
    for comp in comps:
        members = [r for r in comp if r in reports]
        if len(members) < 2:
            continue
        l2, weight = fiedler_weights(g.subgraph(comp))
        errs = robot_errors(reports, members, l2)
        excluded = [r for r in members if weight[r] < zero]
        judged = [r for r in members if weight[r] >= zero]
        dist = distribution([errs[r] for r in judged])
        bad = [r for r in judged if errs[r] > tol]
        at = None
        if within is not None:
            settle = per_robot_iterations({r: reports[r] for r in judged}, l2, tol)
            late = [r for r in judged if settle[r] is None or settle[r] > within]
            bad = sorted(set(bad) | set(late))
            at = max((settle[r] for r in judged if settle[r] is not None), default=None)
        if bad or not judged:
            ok = False
            first_bad = first_bad if first_bad is not None else at
        w = dist["worst"] if dist["worst"] is not None else math.inf
        worst = max(worst, w)
        text = (f"{len(members)} robots: λ2 = {l2:.6g}, per-robot e worst {_fmt(dist['worst'])} %, "
                f"90th percentile {_fmt(dist['p90'])} %, median {_fmt(dist['median'])} %")
        if bad:
            text += f"; above {tol} %: robots {bad[:10]}"
        if within is not None:
            text += f"; every judged robot within {tol} % from iteration {at if not bad else None}"
        if excluded:
            text += (f"; at a zero of the Fiedler vector (row < {zero}·max), not judged: "
                     + ", ".join(f"robot {r} (e {_fmt(errs[r])} %)" for r in excluded))
        details.append(text)
    disconnected = len(comps) > 1
    head = "disconnected: λ2 = 0; per component: " if disconnected else ""
    return [Outcome("lambda2.accurate", ok and bool(details), value=round(worst, 6) if math.isfinite(worst) else None,
                    bound=tol,
                    detail=head + "; ".join(details) if details else "no component of two robots with estimates",
                    first_tick=None if ok else first_bad)]


def _fmt(e: float | None) -> str:
    return "none" if e is None else f"{e:.3g}"


def robust(result: Result, name: str = "lambda2") -> Outcome:
    """Every robot finished its iterations with a finite (or absent) estimate: nothing bad crashed it."""
    reports = result.reports(name)
    crashed = sorted(int(r) for r, rob in result.robots.items() if rob.get("error"))
    bad = sorted(r for r, rep in reports.items() if rep["final"] is not None and not math.isfinite(rep["final"]))
    refused = sum(sum(rep.get("refused", {}).values()) for rep in reports.values())
    ok = not crashed and not bad
    return Outcome("lambda2.robust", ok, value=refused, bound=None,
                   detail=f"crashed {crashed[:10]} non-finite {bad[:10]}; frames refused {refused}")
