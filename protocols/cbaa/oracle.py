"""CBAA: oracle checks (tests and suites only)."""

from __future__ import annotations

import math
from collections import Counter

import networkx as nx
import numpy as np
from scipy.optimize import linear_sum_assignment

from protocols.cbaa.rules import score_row
from swarmactors import Outcome, Result


def _params(result: Result) -> dict:
    return result.behavior_params("cbaa")


def _start_tick(result: Result, at: int) -> int:
    return result.first_tick(at)


def oracle_scores(result: Result) -> dict[int, list[float]]:
    """c_ij from the true positions at the start tick and the scenario's score function."""
    p = _params(result)
    tasks = [list(map(float, t)) for t in p["tasks"]]
    rec = result.record(_start_tick(result, p["at"]))
    out = {}
    for row in rec["pos"]:
        rid = row[0]
        if p["scores"] is not None:
            out[rid] = [float(v) for v in p["scores"][rid]] if rid < len(p["scores"]) else [0.0] * len(tasks)
        else:
            out[rid] = score_row(row[1:], tasks, p["score"], float(p["scale"]))
    return out


def sequential_greedy(scores: dict[int, list[float]], robots: list[int] | None = None) -> dict[int, int]:
    """Task -> robot: repeatedly assign the largest remaining (c_ij, -i, -j) with c_ij > 0."""
    robots = sorted(scores) if robots is None else sorted(robots)
    cand = sorted(((-c, i, j) for i in robots for j, c in enumerate(scores[i]) if c > 0))
    taken_r: set[int] = set()
    out: dict[int, int] = {}
    for _negc, i, j in cand:
        if i not in taken_r and j not in out:
            out[j] = i
            taken_r.add(i)
    return out


def optimum(scores: dict[int, list[float]], robots: list[int]) -> float:
    """Best total score of a single assignment (scipy's linear_sum_assignment), positive scores only."""
    if not robots:
        return 0.0
    mat = np.array([[max(0.0, c) for c in scores[r]] for r in sorted(robots)])
    rows, cols = linear_sum_assignment(mat, maximize=True)
    return float(mat[rows, cols].sum())


def _components(result: Result) -> list[set[int]]:
    p = _params(result)
    g = result.graph_at(_start_tick(result, p["at"]))
    return [set(c) for c in nx.connected_components(g)]


def conflict_free(result: Result) -> Outcome:
    """In each connected component, no task is held by two robots (a robot holds at most one by construction)."""
    reports = result.reports("cbaa")
    bad = []
    for comp in _components(result):
        held = Counter(reports[r]["task"] for r in comp if r in reports and reports[r]["task"] is not None)
        bad += [j for j, n in held.items() if n > 1]
    return Outcome("cbaa.conflict_free", not bad, value=len(bad), bound=0,
                   detail="" if not bad else f"tasks held by several robots: {sorted(bad)[:10]}")


def greedy(result: Result) -> Outcome:
    """Each component's assignment and every robot's winner table equal the sequential greedy assignment."""
    reports = result.reports("cbaa")
    scores = oracle_scores(result)
    m = len(_params(result)["tasks"])
    wrong_task, wrong_table = [], []
    for comp in _components(result):
        members = [r for r in comp if r in reports]
        g = sequential_greedy(scores, members)
        robot_task = {r: j for j, r in g.items()}
        winners = [g.get(j) for j in range(m)]
        wrong_task += [r for r in members if reports[r]["task"] != robot_task.get(r)]
        wrong_table += [r for r in members if reports[r]["winners"] != winners]
    ok = not wrong_task and not wrong_table
    return Outcome("cbaa.greedy", ok, value=len(reports) - len(set(wrong_task) | set(wrong_table)),
                   bound=len(reports),
                   detail="" if ok else f"robots with a task != greedy {sorted(wrong_task)[:10]}, "
                                        f"with a winner table != greedy {sorted(wrong_table)[:10]}")


def rounds(result: Result) -> Outcome:
    """Lockstep: every component settles within N_min * D rounds (a round = radio.latency ticks).

    Rounds are not defined under the realtime clock: there the check reports itself not applicable (passed,
    value None).
    """
    if result["clock"] != "lockstep":
        return Outcome("cbaa.rounds", True, value=None, bound=None, detail="realtime clock: rounds not defined")
    p = _params(result)
    c = result["scenario"]["radio"]["latency"]
    reports = result.reports("cbaa")
    start = _start_tick(result, p["at"])
    g = result.graph_at(start)
    worst: tuple[int, int] | None = None  # (rounds used, N_min * D) of the slowest component
    over = []
    for comp in _components(result):
        members = [r for r in comp if r in reports]
        d = nx.diameter(g.subgraph(comp)) if len(comp) > 1 else 0
        bound = min(len(members), len(p["tasks"])) * d
        last = max((reports[r]["changed_at"] for r in members if reports[r]["changed_at"] is not None),
                   default=start)
        used = math.ceil((last - start) / c)
        if worst is None or used - bound > worst[0] - worst[1]:
            worst = (used, bound)
        if used > bound:
            over.append((sorted(comp)[0], used, bound))
    return Outcome("cbaa.rounds", not over, value=worst[0] if worst else 0, bound=worst[1] if worst else 0,
                   detail="rounds to the last change vs N_min*D of the tightest component" if not over
                   else f"(component of, rounds, N_min*D): {over[:5]}")


def optimality(result: Result, ratio: float = 0.5) -> Outcome:
    """Total score of the assignment >= ``ratio`` x the optimum (sum over components)."""
    reports = result.reports("cbaa")
    scores = oracle_scores(result)
    total = sum(scores[r][rep["task"]] for r, rep in reports.items() if rep["task"] is not None and r in scores)
    best = sum(optimum(scores, [r for r in comp if r in reports]) for comp in _components(result))
    got = total / best if best > 0 else 1.0
    return Outcome("cbaa.optimality", got >= ratio - 1e-12, value=round(got, 6), bound=ratio,
                   detail=f"total {total:.6g}, optimum {best:.6g}")


# ------------------------------------------------------------------ conformance suite
