"""CBAA: the consensus-based auction algorithm (Choi, Brunet & How 2009), as neighbour messages.

Swarm Relays (002 Sec. III-D, its reference [26]) allocates free robots to
tasks with CBAA, the single-assignment case of CBBA. Robot i keeps

* c_ij, its score for task j (fixed at the start from its position: a
  positive, decreasing function of the distance, or a scenario matrix);
* x_i, the task it holds (or none);
* y_ij and z_ij, the winning bid and the winner it believes for each task;
* (table consensus only) s_ik, the time of the freshest information it has
  from robot k.

Bids are compared as pairs (bid, -id): the higher bid wins and equal bids go
to the lower robot id. Every tick from ``at`` on, a robot

  A1 (auction, only while it holds no task) takes, among the tasks whose
     (c_ij, -i) beats (y_ij, -z_ij) and whose score is positive, the one with
     the largest c_ij (ties: the lowest task index) and bids on it:
     x_i = J, y_iJ = c_iJ, z_iJ = i;
  A2 broadcasts a BID frame {t: x_i, y: y_i, z: z_i, s: s_i} when its state
     changed since its last frame, and otherwise every ``every`` ticks.

On a BID frame from k (consensus):

  M1 ``max`` rule (the paper's synchronous CBAA): for every task, (y_ij, z_ij)
     becomes the larger pair of its own and the sender's;
  T1 ``table`` rule (asynchronous CBBA, Choi et al. 2009, Table 1): for every
     task, update (copy the sender's y_kj, z_kj), reset (y_ij = 0, z_ij =
     none) or leave, by the receiver's and the sender's beliefs of the winner
     and the freshness of their information on it (table below); then
     s_ik = now and s_im = max(s_im, s_km) for every other m;
  X1 with either rule, if z_iJ is no longer i for the task J it holds, it
     drops J (x_i = none) and bids again in its next auction.

``consensus = "auto"`` (the default) uses M1 in lockstep, where ticks are the
paper's synchronous rounds, and T1 under the realtime clock, where frames
arrive late and out of order. With static scores the pairs of CBAA only grow
(a bid is only ever replaced by a larger one), so M1 is already immune to
stale frames; T1 matters once bids may fall (a task released, scores that
change). Both converge to the sequential greedy assignment on a static
connected network (repeatedly give the largest remaining (c_ij, -i, -j)
pair's task to its robot), and M1 within N_min * D rounds (D the diameter).

Table T1: i the receiver, k the sender, m and n other robots; "k newer on m"
means s_km > s_im; "higher" means (y_kj, -z_kj) > (y_ij, -z_ij).

| sender z_kj | receiver z_ij | action                                               |
|-------------|---------------|------------------------------------------------------|
| k           | i             | update if higher, else leave                         |
| k           | k             | update                                               |
| k           | m             | update if k newer on m or higher, else leave         |
| k           | none          | update                                               |
| i           | i             | leave                                                |
| i           | k             | reset                                                |
| i           | m             | reset if k newer on m, else leave                    |
| i           | none          | leave                                                |
| m           | i             | update if k newer on m and higher, else leave        |
| m           | k             | update if k newer on m, else reset                   |
| m           | m             | update if k newer on m, else leave                   |
| m           | n             | update if k newer on m and on n; update if k newer   |
|             |               | on m and higher; reset if k newer on n and i newer   |
|             |               | on m; else leave                                     |
| m           | none          | update if k newer on m, else leave                   |
| none        | i             | leave                                                |
| none        | k             | update                                               |
| none        | m             | update if k newer on m, else leave                   |
| none        | none          | leave                                                |

Timestamps are ``ctx.now`` (ticks in lockstep, seconds since the run started
in realtime); a robot never heard of has time -inf.

Bad input: a BID whose y or z table does not have one entry per task
(``wrong_length``), whose own task t is not a task index (``unknown_task``),
or that is otherwise malformed (non-numeric or negative bids, winners that are
not robot ids, a bid without a winner, t not matching z) is dropped and counted
in ``dropped`` by reason.

Parameters: ``tasks`` = [[x, y], ...] (a task's id is its index), ``at``
(first tick), ``score`` (``inverse`` 1/(1 + d/scale), ``exp`` exp(-d/scale),
``linear`` max(0, scale - d), or ``module:function`` f(robot_pos, task_pos)),
``scale``, ``scores`` (an explicit matrix, one row per robot id, overriding
``score``), ``consensus`` (``auto`` | ``max`` | ``table``), ``every``
(rebroadcast period in ticks while nothing changes), ``quiet_after`` (stop
rebroadcasting after that many unchanged ticks; none = never).
"""

from __future__ import annotations

import importlib
import math
from collections import Counter
from collections.abc import Callable
from typing import Any

import networkx as nx
import numpy as np
from scipy.optimize import linear_sum_assignment

from swarmactors import Behavior, Context, Frame, Outcome, Result
from swarmactors.conformance import Case, Family, comb, ladder, line, random_geometric, ring

KIND = "BID"
NEG_INF = float("-inf")


# ------------------------------------------------------------------ scores
def _inverse(d: float, scale: float) -> float:
    return 1.0 / (1.0 + d / scale)


def _exp(d: float, scale: float) -> float:
    return math.exp(-d / scale)


def _linear(d: float, scale: float) -> float:
    return max(0.0, scale - d)


SCORES: dict[str, Callable[[float, float], float]] = {"inverse": _inverse, "exp": _exp, "linear": _linear}


def _pad(p: list[float], dims: int) -> list[float]:
    return (list(p) + [0.0] * dims)[:dims]


def score_row(pos: list[float], tasks: list[list[float]], score: str = "inverse", scale: float = 1.0) -> list[float]:
    """c_ij for one robot at ``pos`` (the robots and the oracle share this function)."""
    pos = [float(v) for v in pos]
    if score in SCORES:
        fn = SCORES[score]
        return [float(fn(math.dist(pos, _pad(t, len(pos))), scale)) for t in tasks]
    module, _, attr = score.partition(":")
    custom = getattr(importlib.import_module(module), attr)
    return [float(custom(list(pos), _pad(t, len(pos)))) for t in tasks]


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


# ------------------------------------------------------------------ the behaviour
def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_num(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


class CBAA(Behavior):
    """Consensus-based auction: one task per robot, one robot per task."""

    name = "cbaa"
    kinds = (KIND,)
    plot_field = "task"

    def __init__(self, tasks: list, at: int = 0, score: str = "inverse", scale: float = 1.0,
                 scores: list | None = None, consensus: str = "auto", every: int = 1,
                 quiet_after: int | None = None):
        self.tasks = [list(map(float, t)) for t in tasks]
        self.m = len(self.tasks)
        self.at, self.score_name, self.scale, self.matrix = at, score, float(scale), scores
        self.consensus, self.every, self.quiet_after = consensus, every, quiet_after
        self.mode = "max"
        self.id = -1
        self.started = False
        self.c: list[float] = [0.0] * self.m
        self.x: int | None = None
        self.y: list[float] = [0.0] * self.m
        self.z: list[int | None] = [None] * self.m
        self.s: dict[int, float] = {}
        self.changed_at: int | None = None
        self.changed_time: float | None = None
        self.last_sent: int | None = None
        self.dirty = False
        self.sent = 0
        self.received = 0
        self.dropped: Counter = Counter()
        self.bids_made = 0
        self.actions: Counter = Counter()

    @staticmethod
    def validate(params: dict) -> str | None:
        tasks = params.get("tasks")
        if not isinstance(tasks, list) or not tasks:
            return "tasks must be a non-empty list of [x, y] points"
        for i, t in enumerate(tasks):
            if not isinstance(t, list) or len(t) not in (2, 3) or not all(_is_num(v) for v in t):
                return f"tasks[{i}] = {t!r} must be [x, y] or [x, y, z]"
        score = params.get("score", "inverse")
        if not isinstance(score, str) or (score not in SCORES and ":" not in score):
            return f"score = {score!r} must be one of {', '.join(SCORES)} or module:function"
        scale = params.get("scale", 1.0)
        if not _is_num(scale) or scale <= 0:
            return f"scale = {scale!r} must be a positive number"
        scores = params.get("scores")
        if scores is not None:
            if not isinstance(scores, list) or not all(
                isinstance(r, list) and len(r) == len(tasks) and all(_is_num(v) for v in r) for r in scores
            ):
                return f"scores must be a list of rows (one per robot id) of {len(tasks)} numbers"
        if params.get("consensus", "auto") not in ("auto", "max", "table"):
            return "consensus must be auto, max or table"
        for key in ("at", "every"):
            v = params.get(key, 1)
            if not _is_int(v) or v < (1 if key == "every" else 0):
                return f"{key} = {v!r} must be an integer >= {1 if key == 'every' else 0}"
        q = params.get("quiet_after")
        if q is not None and (not _is_int(q) or q < 1):
            return f"quiet_after = {q!r} must be a positive integer (or absent)"
        return None

    # -- hooks
    def on_start(self, ctx: Context) -> None:
        self.id = ctx.id
        self.mode = self.consensus if self.consensus != "auto" else ("table" if ctx.clock == "realtime" else "max")
        ctx.set_status(task=None)

    def _begin(self, ctx: Context) -> None:
        self.started = True
        if self.matrix is not None:
            row = self.matrix[ctx.id] if ctx.id < len(self.matrix) else [0.0] * self.m
            self.c = [float(v) for v in row]
        else:
            self.c = score_row(list(ctx.position), self.tasks, self.score_name, self.scale)

    def on_tick(self, ctx: Context, sensed) -> None:
        if ctx.tick < self.at:
            return
        if not self.started:
            self._begin(ctx)
        before = self._state()
        if self.x is None:
            self._auction()
        self._note(ctx, before)
        quiet = self.quiet_after is not None and self.changed_at is not None and \
            ctx.tick - self.changed_at > self.quiet_after
        due = self.last_sent is None or ctx.tick - self.last_sent >= self.every
        if self.dirty or (due and not quiet):  # A2
            body = {"t": self.x, "y": self.y, "z": self.z}
            if self.mode == "table":
                body["s"] = [[k, v] for k, v in self.s.items()]
            ctx.broadcast(KIND, body)
            self.sent += 1
            self.last_sent = ctx.tick
            self.dirty = False
        ctx.set_status(task=self.x)

    def _auction(self) -> None:
        best = None
        for j in range(self.m):
            if self.c[j] > 0 and pair(self.c[j], self.id) > pair(self.y[j], self.z[j]):
                if best is None or self.c[j] > self.c[best]:
                    best = j
        if best is not None:  # A1: bid on the best task this robot can still win
            self.x, self.y[best], self.z[best] = best, self.c[best], self.id
            self.bids_made += 1

    def _state(self) -> tuple:
        return (self.x, tuple(self.y), tuple(self.z))

    def _note(self, ctx: Context, before: tuple) -> None:
        if self._state() != before:
            self.changed_at, self.changed_time = ctx.tick, ctx.now
            self.dirty = True

    def _parse(self, frame: Frame) -> tuple | None:
        b = frame.body
        if not isinstance(b, dict) or "y" not in b or "z" not in b:
            self.dropped["malformed"] += 1
            return None
        y, z, t = b["y"], b["z"], b.get("t")
        if not isinstance(y, list) or not isinstance(z, list):
            self.dropped["malformed"] += 1
            return None
        if len(y) != self.m or len(z) != self.m:
            self.dropped["wrong_length"] += 1
            return None
        if t is not None and (not _is_int(t) or not 0 <= t < self.m):
            self.dropped["unknown_task"] += 1
            return None
        if not all(_is_num(v) and v >= 0 for v in y) or not all(w is None or (_is_int(w) and w >= 0) for w in z):
            self.dropped["malformed"] += 1
            return None
        if any((w is None) != (v == 0) for v, w in zip(y, z, strict=True)) or (t is not None and z[t] != frame.src):
            self.dropped["malformed"] += 1
            return None
        s: dict[int, float] = {}
        raw = b.get("s", [])
        if not isinstance(raw, list) or not all(
            isinstance(e, list) and len(e) == 2 and _is_int(e[0]) and _is_num(e[1]) for e in raw
        ):
            self.dropped["malformed"] += 1
            return None
        for k, v in raw:
            s[k] = float(v)
        return [float(v) for v in y], z, s

    def on_frame(self, ctx: Context, frame: Frame) -> None:
        parsed = self._parse(frame)
        if parsed is None:
            return
        self.received += 1
        yk, zk, sk = parsed
        k, i = frame.src, self.id
        before = self._state()
        if self.mode == "max":
            for j in range(self.m):
                if pair(yk[j], zk[j]) > pair(self.y[j], self.z[j]):  # M1: keep the larger (bid, -id) pair
                    self.y[j], self.z[j] = yk[j], zk[j]
        else:
            for j in range(self.m):
                action = decide(i, k, yk[j], zk[j], self.y[j], self.z[j], self.s, sk)  # T1
                self.actions[action] += 1
                if action == UPDATE:
                    self.y[j], self.z[j] = yk[j], zk[j]
                elif action == RESET:
                    self.y[j], self.z[j] = 0.0, None
            self.s[k] = float(ctx.now)  # T1: direct information from k is as fresh as now
            for m, t in sk.items():
                if m != i and m != k and t > self.s.get(m, NEG_INF):  # T1: relayed freshness
                    self.s[m] = t
        if self.x is not None and self.z[self.x] != i:  # X1: outbid on its task: drop it
            self.x = None
        self._note(ctx, before)

    def report(self) -> dict:
        return {
            "task": self.x,
            "bids": self.y,
            "winners": self.z,
            "changed_at": self.changed_at,
            "changed_time": self.changed_time,
            "scores": self.c,
            "score": self.c[self.x] if self.x is not None else 0.0,
            "sent": self.sent,
            "received": self.received,
            "dropped": dict(self.dropped),
            "bids_made": self.bids_made,
            "actions": dict(self.actions),
            "mode": self.mode,
        }

    @classmethod
    def metrics(cls, reports: dict[int, dict]) -> dict:
        held = Counter(r["task"] for r in reports.values() if r.get("task") is not None)
        tables = {tuple(r.get("winners", [])) for r in reports.values()}
        changes = [r["changed_at"] for r in reports.values() if r.get("changed_at") is not None]
        n = len(reports)
        sent = sum(r.get("sent", 0) for r in reports.values())
        dropped: Counter = Counter()
        for r in reports.values():
            dropped.update(r.get("dropped", {}))
        return {
            "robots": n,
            "assigned": sum(held.values()),
            "conflicts": sum(1 for c in held.values() if c > 1),
            "total_score": sum(r.get("score", 0.0) for r in reports.values()),
            "agreed": len(tables) == 1,
            "last_change": max(changes, default=None),
            "messages": sent,
            "messages_per_robot": sent / n if n else 0.0,
            "dropped": dict(dropped),
        }


# ------------------------------------------------------------------ oracle
def _params(result: Result) -> dict:
    return result.behavior_params("cbaa")


def _start_tick(result: Result, at: int) -> int:
    return min(rec["t"] for rec in result.trace if rec["t"] >= at)


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
def _cbaa_case(name: str, positions: list, tasks: list, *, clock="lockstep", loss=0.0, seed=1,
               checks=("cbaa.conflict_free", "cbaa.greedy", "cbaa.rounds", "cbaa.optimality")) -> Case:
    run = {"seed": seed, "clock": clock, "ticks": 60}
    radio = {"range": 1.0, "latency": 1, "loss": loss}
    if clock == "realtime":
        run.update(dt=0.05, ticks=60)
        radio.update(latency_s=0.02, latency_min_s=0.005)
    scenario = {"run": run, "radio": radio,
                "robots": [{"positions": positions, "behaviors": [{"use": "cbaa", "at": 1, "tasks": tasks}]}]}
    return Case(f"cbaa/{name}", scenario, [{"use": c} for c in checks])


def _tasks(n: int, seed: int, spread: float) -> list[list[float]]:
    rng = np.random.default_rng([seed, n, 7])
    return np.round(rng.random((n, 2)) * spread, 4).tolist()


def suite(mode: str) -> list[Case]:
    """Static networks of several shapes, fewer and more tasks than robots, both clocks, loss."""
    ties = [[0.4 + 0.8 * i, 0.0] for i in range(5)]  # each task equidistant from two robots: equal bids
    cases = [
        _cbaa_case("line-6-tied-tasks-5", line(6), ties),
        _cbaa_case("line-6-tasks-4", line(6), _tasks(4, 1, 4.0)),
        _cbaa_case("ring-8-tasks-10", ring(8), _tasks(10, 2, 2.5)),
        _cbaa_case("rgg-15-s1-tasks-8", random_geometric(15, 1), _tasks(8, 3, 3.5)),
        _cbaa_case("rgg-10-s2-realtime-loss-0.1", random_geometric(10, 2), _tasks(6, 4, 3.0), clock="realtime",
                   loss=0.1, checks=("cbaa.conflict_free", "cbaa.greedy")),
    ]
    if mode == "full":
        for n, seed in ((10, 1), (20, 2), (30, 3)):
            for k in (n // 2, n, 2 * n):
                cases.append(_cbaa_case(f"rgg-{n}-s{seed}-tasks-{k}", random_geometric(n, seed),
                                        _tasks(k, seed, math.sqrt(n) * 1.2), seed=seed))
        cases.append(_cbaa_case("comb-13-tasks-7", comb(13), _tasks(7, 5, 5.0)))
        cases.append(_cbaa_case("ladder-12-tasks-12", ladder(12), _tasks(12, 6, 4.0)))
        for seed in (3, 4):
            cases.append(_cbaa_case(f"rgg-14-s{seed}-realtime-loss-0.1", random_geometric(14, seed),
                                    _tasks(9, seed, 3.5), clock="realtime", loss=0.1,
                                    checks=("cbaa.conflict_free", "cbaa.greedy")))
    return cases


FAMILY = Family(name="cbaa", behavior="cbaa",
                report={"task": (int, type(None)), "bids": list, "winners": list, "changed_at": (int, type(None))},
                suite=suite)
