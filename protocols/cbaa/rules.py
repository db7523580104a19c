"""CBAA's pure rules: scores, the bid order and the conflict table (Table 1). Robot side, no I/O."""

from __future__ import annotations

import math

from swarmactors.robot.plugins import Rules

KIND = "BID"
NEG_INF = float("-inf")


# ------------------------------------------------------------------ scores
def _pad(p: list[float], dims: int) -> list[float]:
    return (list(p) + [0.0] * dims)[:dims]


def inverse(pos: list[float], task: list[float], scale: float) -> float:
    """c_ij = 1 / (1 + d_ij / scale): positive and decreasing in the distance."""
    return 1.0 / (1.0 + math.dist(pos, task) / scale)


def exponential(pos: list[float], task: list[float], scale: float) -> float:
    """Score c_ij = exp(-d_ij / scale)."""
    return math.exp(-math.dist(pos, task) / scale)


def linear(pos: list[float], task: list[float], scale: float) -> float:
    """c_ij = max(0, scale - d_ij): a task beyond ``scale`` gets no bid."""
    return max(0.0, scale - math.dist(pos, task))


SCORES = Rules("score", "swarmactors.cbaa.scores", {"inverse": inverse, "exp": exponential, "linear": linear})
"""Scores by name; a third-party score ``fn(robot_pos, task_pos, scale) -> float`` registers under the group."""


def score_row(pos: list[float], tasks: list[list[float]], score: str = "inverse", scale: float = 1.0) -> list[float]:
    """c_ij for one robot at ``pos`` (the robots and the oracle share this function)."""
    pos = [float(v) for v in pos]
    fn = SCORES.get(score)
    return [float(fn(pos, _pad(t, len(pos)), scale)) for t in tasks]


def pair(bid: float, winner: int | None) -> tuple[float, float]:
    """Return the sort key of a bid: higher bid first, then lower robot id; no winner is lowest."""
    return (bid, NEG_INF if winner is None else -winner)


# ------------------------------------------------------------------ table T1
UPDATE, RESET, LEAVE = "update", "reset", "leave"


def decide(i: int, k: int, yk: float, zk: int | None, yi: float, zi: int | None,
           s_i: dict[int, float], s_k: dict[int, float]) -> str:
    """Return the T1 action of receiver i for one task, from sender k's belief (yk, zk) and its own (yi, zi)."""

    def k_newer(m: int) -> bool:
        return s_k.get(m, NEG_INF) > s_i.get(m, NEG_INF)

    higher = pair(yk, zk) > pair(yi, zi)
    if zk == k:  # sender thinks it wins
        if zi == i:
            return UPDATE if higher else LEAVE
        if zi == k or zi is None:
            return UPDATE
        return UPDATE if k_newer(zi) or higher else LEAVE
    if zk == i:  # sender thinks the receiver wins
        if zi == k:
            return RESET
        if zi == i or zi is None:
            return LEAVE
        return RESET if k_newer(zi) else LEAVE
    if zk is None:  # sender thinks nobody wins
        if zi == k:
            return UPDATE
        if zi == i or zi is None:
            return LEAVE
        return UPDATE if k_newer(zi) else LEAVE
    m = zk  # sender thinks a third robot m wins
    if zi == i:
        return UPDATE if k_newer(m) and higher else LEAVE
    if zi == k:
        return UPDATE if k_newer(m) else RESET
    if zi == m or zi is None:
        return UPDATE if k_newer(m) else LEAVE
    n = zi
    if k_newer(m) and (k_newer(n) or higher):
        return UPDATE
    if k_newer(n) and s_i.get(m, NEG_INF) > s_k.get(m, NEG_INF):
        return RESET
    return LEAVE
