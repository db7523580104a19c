"""λ2 estimation: oracle checks against numpy's eigenvalues of the true Laplacian (tests and suites only).

The truth is λ2 of the Laplacian of the world's radio graph (``Result.graph_at``, mutual links) at the last
tick, by ``numpy.linalg.eigvalsh``. The swarm's estimate at iteration k is the median over the robots of
their own estimates (the authors' Octave code takes the median too); the paper's error is
e = |λ̂2 − λ2| / (10⁻²·λ2), in percent. A disconnected graph has λ2 = 0: the oracle says so and judges
each component against its own λ2, the only value a robot can learn by talking to its neighbours.
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


def per_robot_iterations(reports: dict[int, dict], truth: float, tol_percent: float = 1.0) -> dict[int, int | None]:
    """For each robot: the iteration from which its own estimate stays within tol (None: never)."""
    out = {}
    for rid, rep in reports.items():
        errs = [math.inf if e is None or truth <= 0 else abs(e - truth) / (1e-2 * truth) for e in rep["estimates"]]
        out[rid] = settled(errs, tol_percent)
    return out


def accurate(result: Result, tol: float = 1.0, within: int | None = None, name: str = "lambda2") -> list[Outcome]:
    """The median final estimate of each component is within ``tol`` percent of its λ2 (numpy eigvalsh).

    With ``within``: e also stays ≤ tol from iteration ``within`` on. The outcome's value is the error in
    percent (the largest over components), its detail the iteration from which e stays ≤ tol.
    """
    reports = result.reports(name)
    comps = [(rs, l2) for rs, l2 in components(result) if any(r in reports for r in rs)]
    worst, details, ok, first_bad = 0.0, [], True, None
    for robots, l2 in comps:
        members = [r for r in robots if r in reports]
        if len(members) < 2:
            continue
        errors = error_series(reports, members, l2)
        final = errors[-1] if errors else math.inf
        at = settled(errors, tol)
        good = final <= tol and (within is None or (at is not None and at <= within))
        if not good:
            ok = False
            first_bad = first_bad if first_bad is not None else at
        worst = max(worst, final)
        details.append(f"{len(members)} robots: λ2 = {l2:.6g}, median estimate "
                       f"{_median([reports[r]['final'] for r in members])}, e = {final:.3g} %, "
                       f"within {tol} % from iteration {at}")
    disconnected = len(components(result)) > 1
    head = "disconnected: λ2 = 0; per component: " if disconnected else ""
    return [Outcome("lambda2.accurate", ok and bool(details), value=round(worst, 6) if math.isfinite(worst) else None,
                    bound=tol,
                    detail=head + "; ".join(details) if details else "no component of two robots with estimates",
                    first_tick=None if ok else first_bad)]


def robust(result: Result, name: str = "lambda2") -> Outcome:
    """Every robot finished its iterations with a finite (or absent) estimate: nothing bad crashed it."""
    reports = result.reports(name)
    crashed = sorted(int(r) for r, rob in result.robots.items() if rob.get("error"))
    bad = sorted(r for r, rep in reports.items() if rep["final"] is not None and not math.isfinite(rep["final"]))
    refused = sum(sum(rep.get("refused", {}).values()) for rep in reports.values())
    ok = not crashed and not bad
    return Outcome("lambda2.robust", ok, value=refused, bound=None,
                   detail=f"crashed {crashed[:10]} non-finite {bad[:10]}; frames refused {refused}")
