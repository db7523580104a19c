"""Biconnectivity by stamped messages (Ahmadi & Stone, "Keeping in Touch", AAAI 2006).

The paper's rules are the specification; what it defers to its companion paper
(Ahmadi & Stone 2006a: when the initiating messages are sent, when the lists are
reset) is chosen here so that its stated bounds hold, and marked *(choice)*.

Messages and lists
==================

A message is ``(T, S)``: a type T and the ordered list S of robot stamps; a robot
stamps by appending its id. Every CR/DCR frame also carries a *period* number p
(a documented extension, issue 3): body ``[p, S]``.

* **R1 - relay (Algorithm 1).** On ``("CR", S)`` with own id not in S, a robot
  broadcasts ``("CR", S + [id])``; a message that already carries its id is
  received but never relayed. ``DCR`` frames are relayed the same way. There is
  no other suppression: a robot relays every copy, so the relay enumerates the
  simple paths of the graph. Per period, robot R *sends* one frame per simple
  path ending at R, and *receives* one per simple path ending at a neighbour of
  R (the ``biconnectivity.paths`` check counts them against the oracle).
* **R2 - CR-FILL.** Each robot starts a period by broadcasting ``("CR", [id])``.
  CR_R collects every id seen in the stamps R receives in the period (own id
  excluded). Complete within 3Nc.
* **R3 - DCR-FILL (Algorithm 2).** Each robot broadcasts ``("DCR", [id])``; on
  ``("DCR", S)`` containing its own id, it splits S = (S1, id, S2) and, if
  |S2| > 1, adds S2's ids to DCR_R (R, S2 and the sender, a neighbour, close a
  cycle). DCR_R is the set of robots sharing a cycle with R, i.e. a biconnected
  block of at least three robots. Complete within nc.
* **R4 - periods** *(choice)*. A period is numbered by the tick at which it was
  started. A robot *joins* period p on the first frame of p it hears (CR, DCR,
  CHECK-REQUEST, BUDGET) or when it starts p itself: it resets CR and DCR (the
  "first DCR message" reset of Algorithm 2) and broadcasts its two initiating
  messages, once per period. Frames of an older period are counted ``stale`` and
  neither relayed nor used; a newer period supersedes the current one. The join
  wave spreads at most c per hop, and every initiating message travels at most
  n-1 hops, so every CR/DCR frame of a period arrives within 2(n-1)c of the
  period's start, inside the paper's 3Nc.

The check (Algorithm 3)
=======================

* **R5.** An initiator (parameters ``initiator``, ``at``, optionally ``every``)
  starts a new period - or reuses its current one while that is younger than
  3Nc *(choice: concurrent initiators share a fill)* - and at once broadcasts
  ``("CHECK-REQUEST", [p, t_request, initiator])`` *(choice: the request goes out
  when the fills start, not after line 1's wait; the neighbours' fills are the
  same period's wave, so every decision still lands within 6Nc + 2c - within
  3Nc + 2c for a lone initiator)*. The initiator and every robot that hears a
  request run the check; one already running it ignores the request, one that
  already evaluated the period repeats its DC answer.
* **R6.** A check-running robot evaluates 3Nc after it joined the period: it
  broadcasts ``("DC-TRUE", [p])`` if |DCR| = |CR|, else ``("DC-FALSE", [p])`` and
  concludes false (line 7). Then, with DC answers of the period heard from
  neighbours (before or after its own evaluation): DC-FALSE -> false (line 9);
  DC-TRUE and |DCR| = |CR| -> true (lines 10-11; Theorem 1: two distinct robots
  doubly connected to all). *(choices)* A robot with an empty CR list concludes
  false at once (``reason = "alone"``; Theorem 1 needs two robots); an evaluated
  robot still undecided 6Nc + 2c after the request concludes ``null`` with
  ``reason = "timeout"`` (only possible with loss or failures).
* The verdict is the paper's biconnectivity of the robot's component as its CR
  list knows it: every pair doubly connected (Lemma 1), so a component of one
  or two robots is *not* biconnected (networkx says a single edge is).
* **R7 - budget** *(choice)*. A robot relays at most ``budget`` CR+DCR frames
  per period. The one that would exceed it stops relaying the period and floods
  ``("BUDGET", [p])`` (forward once); every robot that learns it stops relaying
  the period too, and a check-running robot concludes ``null`` with
  ``reason = "budget"`` at its evaluation time, so the run never hangs on the
  (n-1)! worst case.
* **R8 - verdict flood** (``flood_verdict``, beyond the paper). The initiator
  floods ``("VERDICT", [p, initiator, value, reason])`` once decided; robots
  without a verdict for the period adopt it (``reason = "flooded"``).
* **R9 - bad input.** A CR/DCR body that is not ``[p, S]`` with p a
  non-negative integer and S a non-empty list of at most N distinct integers
  whose last stamp is the sender is dropped, counted in ``malformed`` (by
  reason), and never relayed or joined.

Maintaining the structure (add and remove)
==========================================

Robots sit at the centres of their circular regions (radius ``region``). Two
robots are *structure neighbours* when they can talk from anywhere in their
regions: distance between centres + 2·region <= range (the robot's radio range,
``ctx.range``, from its robot group), and a safety ``margin`` (fraction of that
distance) is kept so that rounding never breaks a link.

* **R10 - positions** *(choice)*. Every ``hello`` ticks each robot broadcasts
  ``("HELLO", table)``: its table of (id, centre, stamp tick, neighbour ids) for
  every robot it knows, merged by newest stamp. Robots thus learn neighbours,
  neighbours of neighbours and (approximate, delayed) centres of everybody,
  the knowledge the paper assumes.
* **R11 - add (Theorem 3).** A ``joiner`` broadcasts ``("POS-REQUEST")``; robots
  answer ``("POS-REPLY", table)``. It picks the candidate position within the
  neighbour distance of at least two robots that maximises the sum of the
  distances to its two closest region centres (``placement = "heuristic"``; or
  the minimum total intersection with the other regions,
  ``"min_intersection"``), goes towards the first of these two robots, asks
  again from there, re-optimises under the constraint of being a neighbour of
  both, goes there and settles (starts its HELLOs).
* **R12 - remove (Theorem 4).** A robot whose neighbour r has not been heard
  for ``silence`` ticks, or which hears ``("LEAVE")`` from it, takes r as
  removed. The lowest-id neighbour of r (from r's last advertised neighbour
  list) leads: it steps d = 0, d_step, 2·d_step, ... until its model of r's
  ex-neighbours, each moved d towards r's ex-position (clamped at it), is
  biconnected (two robots: adjacent, which the proof of Theorem 4 needs;
  *choice*); it floods ``("MOVE", [leader, round, r, pos, d, start, speed])``
  (forward once) with start = now + N·c + 1 tick, the flood's worst delivery
  time, so that every robot starts moving at the same tick, at the common
  ``speed``, d towards pos (clamped at pos). The positions at every instant are
  the proximal map x -> pos + (x-pos)·max(0, 1 - s/|x-pos|), which is
  1-Lipschitz: no link is ever lengthened. After the move the leader runs the
  check; while it says false it floods further moves of ``d_more``, at most
  ``max_rounds`` rounds.

Units: ``at``, ``every``, ``hello``, ``silence`` are ticks; ``c`` is the per-hop
bound in the clock's unit (ticks in lockstep, seconds in realtime); lengths in
world units; ``speed`` in units per second. The radio range and the seconds per
tick are the scenario's, read from the context (``ctx.range``, ``ctx.dt``), never
parameters: the structure-neighbour distance and the default ``d_step`` and
``d_more`` are derived from them in ``on_start``.
"""

from __future__ import annotations

import math
from collections import Counter, defaultdict
from itertools import combinations

import networkx as nx
import numpy as np

from swarmactors import Behavior, Context, Frame, Outcome, Result
from swarmactors.conformance import Case, Family, comb, ladder, line, random_geometric, ring

CR, DCR = "CR", "DCR"
CHECK_REQUEST, DC_TRUE, DC_FALSE = "CHECK-REQUEST", "DC-TRUE", "DC-FALSE"
BUDGET, VERDICT = "BUDGET", "VERDICT"
HELLO, LEAVE, POS_REQUEST, POS_REPLY, MOVE = "HELLO", "LEAVE", "POS-REQUEST", "POS-REPLY", "MOVE"
KINDS = (CR, DCR, CHECK_REQUEST, DC_TRUE, DC_FALSE, BUDGET, VERDICT, HELLO, LEAVE, POS_REQUEST, POS_REPLY, MOVE)
TOL = 1e-9


# ================================================================ pure geometry and graphs (robot side)
def prox(points: np.ndarray, pos: np.ndarray, s: float) -> np.ndarray:
    """Move each point ``s`` towards ``pos``, stopping at ``pos`` (the proximal map of s·|x - pos|)."""
    points = np.asarray(points, dtype=float)
    v = points - pos
    dist = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        k = np.where(dist > 0, np.maximum(0.0, 1.0 - s / np.where(dist > 0, dist, 1.0)), 0.0)
    return pos + v * k


def adjacency(points: np.ndarray, reach: float) -> list[set[int]]:
    """Index adjacency of points closer than ``reach`` (inclusive, with a relative tolerance)."""
    p = np.asarray(points, dtype=float)
    n = len(p)
    if n == 0:
        return []
    d = np.linalg.norm(p[:, None, :] - p[None, :, :], axis=-1)
    lim = reach * (1 + TOL)
    return [{j for j in range(n) if j != i and d[i, j] <= lim} for i in range(n)]


def _connected(adj: list[set[int]], skip: int = -1) -> bool:
    nodes = [i for i in range(len(adj)) if i != skip]
    if not nodes:
        return True
    seen = {nodes[0]}
    stack = [nodes[0]]
    while stack:
        u = stack.pop()
        for v in adj[u]:
            if v != skip and v not in seen:
                seen.add(v)
                stack.append(v)
    return len(seen) == len(nodes)


def biconnected(adj: list[set[int]]) -> bool:
    """The paper's biconnectivity (Definition 2 with Lemma 1): at least 3 robots, connected, no cut robot."""
    n = len(adj)
    return n >= 3 and _connected(adj) and all(_connected(adj, skip=v) for v in range(n))


def structure_ok(adj: list[set[int]]) -> bool:
    """What the removal leader wants of r's ex-neighbours (Theorem 4): biconnected; two robots adjacent."""
    n = len(adj)
    if n <= 1:
        return True
    if n == 2:
        return 1 in adj[0]
    return biconnected(adj)


def removal_distance(points: np.ndarray, pos: np.ndarray, reach: float, step: float) -> float:
    """Smallest d in {0, step, 2·step, ...} after which the moved ex-neighbours satisfy ``structure_ok``."""
    points = np.asarray(points, dtype=float)
    if len(points) <= 1:
        return 0.0
    dmax = float(np.max(np.linalg.norm(points - pos, axis=1)))
    k = 0
    while True:
        d = k * step
        if structure_ok(adjacency(prox(points, pos, d), reach)) or d >= dmax:
            return float(d)
        k += 1


def two_closest_sum(points: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """The paper's heuristic value: sum of the distances to the two closest region centres."""
    points = np.atleast_2d(points)
    d = np.linalg.norm(points[:, None, :] - centres[None, :, :], axis=-1)
    if d.shape[1] == 1:
        return d[:, 0]
    return np.partition(d, 1, axis=1)[:, :2].sum(axis=1)


def lens_area(d: np.ndarray, rho: float) -> np.ndarray:
    """Intersection area of two disks of radius ``rho`` whose centres are ``d`` apart."""
    d = np.asarray(d, dtype=float)
    if rho <= 0:
        return np.zeros_like(d)
    x = np.clip(d / (2 * rho), 0.0, 1.0)
    lens = 2 * rho * rho * np.arccos(x) - d / 2 * np.sqrt(np.maximum(0.0, 4 * rho * rho - d * d))
    return np.where(d < 2 * rho, lens, 0.0)


def overlap(points: np.ndarray, centres: np.ndarray, rho: float) -> np.ndarray:
    """Total intersection area of a region at each point with the regions at ``centres``."""
    points = np.atleast_2d(points)
    d = np.linalg.norm(points[:, None, :] - centres[None, :, :], axis=-1)
    return lens_area(d, rho).sum(axis=1)


def feasible(points: np.ndarray, centres: np.ndarray, reach: float, need: int, must=()) -> np.ndarray:
    """Points within ``reach`` of at least ``need`` centres, and of every centre index in ``must``."""
    points = np.atleast_2d(points)
    d = np.linalg.norm(points[:, None, :] - centres[None, :, :], axis=-1)
    lim = reach * (1 + TOL)
    ok = (d <= lim).sum(axis=1) >= need
    for i in must:
        ok &= d[:, i] <= lim
    return ok


def _candidates(centres: np.ndarray, reach: float, grid: int = 60, ring: int = 720) -> np.ndarray:
    """Candidate positions: circles of radius ``reach`` around the centres, their intersections, a grid."""
    pts = []
    ang = np.linspace(0.0, 2 * math.pi, ring, endpoint=False)
    circle = np.stack([np.cos(ang), np.sin(ang)], axis=1) * reach
    for c in centres:
        pts.append(c + circle)
    for i, j in combinations(range(len(centres)), 2):
        a, b = centres[i], centres[j]
        dv = b - a
        d = float(np.linalg.norm(dv))
        if 0 < d <= 2 * reach:
            mid = a + dv / 2
            h = math.sqrt(max(0.0, reach * reach - d * d / 4))
            perp = np.array([-dv[1], dv[0]]) / d
            pts.append(np.stack([mid + perp * h, mid - perp * h]))
    lo = centres.min(axis=0) - reach
    hi = centres.max(axis=0) + reach
    span = float(np.max(hi - lo))
    k = max(2, int(grid * span / max(reach, 1e-12)))
    k = min(k, 400)
    xs = np.linspace(lo[0], hi[0], k)
    ys = np.linspace(lo[1], hi[1], k)
    gx, gy = np.meshgrid(xs, ys)
    pts.append(np.stack([gx.ravel(), gy.ravel()], axis=1))
    return np.vstack(pts)


def _refine(p: np.ndarray, score, ok, reach: float) -> np.ndarray:
    """Pattern search: move while the score improves and the point stays feasible."""
    best = p.copy()
    best_v = float(score(best[None])[0])
    step = reach / 40
    dirs = np.array([[math.cos(a), math.sin(a)] for a in np.linspace(0, 2 * math.pi, 16, endpoint=False)])
    while step > reach * 1e-7:
        trial = best + dirs * step
        good = ok(trial)
        if good.any():
            vals = np.where(good, score(trial), -np.inf)
            k = int(np.argmax(vals))
            if vals[k] > best_v + 1e-12:
                best, best_v = trial[k], float(vals[k])
                continue
        step /= 2
    return best


def join_position(centres: np.ndarray, reach: float, must=(), method: str = "heuristic", rho: float = 0.0,
                  rng: np.random.Generator | None = None) -> tuple[np.ndarray, float, list[int]] | None:
    """Best position of a new region (Theorem 3 and the paper's heuristic).

    Feasible: within ``reach`` of at least min(2, k) centres, and of each index in ``must``.
    ``heuristic``: maximise the sum of the distances to the two closest centres.
    ``min_intersection``: minimise the total intersection with the other regions (ties: at random).
    Returns (position, heuristic value, indices of the two closest centres), or None.
    """
    centres = np.asarray(centres, dtype=float).reshape(-1, 2)
    k = len(centres)
    if k == 0:
        return None
    need = min(2, k)
    cand = _candidates(centres, reach)
    ok_mask = feasible(cand, centres, reach, need, must)
    cand = cand[ok_mask]
    if len(cand) == 0:
        return None

    def ok(pts):
        return feasible(pts, centres, reach, need, must)

    if method == "heuristic":
        vals = two_closest_sum(cand, centres)
        top = np.argsort(-vals)[:8]
        refined = [_refine(cand[i], lambda q: two_closest_sum(q, centres), ok, reach) for i in top]
        refined_vals = two_closest_sum(np.array(refined), centres)
        best = refined[int(np.argmax(refined_vals))]
    elif method == "min_intersection":
        ov = overlap(cand, centres, rho)
        low = np.flatnonzero(ov <= ov.min() + 1e-9 * max(rho * rho, 1e-12))
        pick = low[int((rng or np.random.default_rng(0)).integers(len(low)))]
        best = cand[pick]
    else:
        raise ValueError(f"unknown placement method {method!r}")
    d = np.linalg.norm(centres - best, axis=1)
    closest = [int(i) for i in np.argsort(d)[:2]]
    return best, float(two_closest_sum(best[None], centres)[0]), closest


def _region_problem(radio_range: float, region: float) -> str | None:
    """Why regions of radius ``region`` cannot work with this radio range (two must fit in it), or None."""
    if radio_range - 2 * region <= 0:
        return (f"region = {region!r} too large for the radio range {radio_range!r}: two regions must fit in "
                "range (range - 2·region > 0)")
    return None


# ================================================================ the behaviour
class Biconnectivity(Behavior):
    """CR-FILL, DCR-FILL and the check of Ahmadi & Stone, with adding and removing robots."""

    name = "biconnectivity"
    kinds = KINDS
    plot_field = "biconnected"

    def __init__(self, N: int = 16, c: float = 1, initiator: int | list[int] | None = None, at: int | list[int] = 0,
                 every: int | None = None, budget: int = 20000, flood_verdict: bool = False,
                 hello: int = 2, silence: int = 6, region: float = 0.0, margin: float = 0.02,
                 speed: float = 0.05, d_step: float | None = None, d_more: float | None = None,
                 max_rounds: int = 10, joiner: bool = False,
                 placement: str = "heuristic", leave: list | None = None, maintain: bool = True):
        self.N, self.c = int(N), float(c)
        ids = [] if initiator is None else ([initiator] if isinstance(initiator, int) else list(initiator))
        ats = at if isinstance(at, list) else [at] * len(ids)
        self.start_at = dict(zip(ids, ats, strict=True))  # initiator id -> tick of its first check
        self.every = every
        self.budget, self.flood_verdict = budget, flood_verdict
        self.hello, self.silence = hello, silence
        self.region, self.margin, self.speed = float(region), float(margin), float(speed)
        self.d_step_param, self.d_more_param = d_step, d_more
        # derived from the robot's radio range (ctx.range) in on_start (_configure)
        self.reach: float | None = None  # structure-neighbour distance between centres
        self.safe: float | None = None  # what placement and the leader's model use
        self.d_step: float | None = None
        self.d_more: float | None = None
        self.max_rounds, self.joiner, self.placement, self.maintain = max_rounds, joiner, placement, maintain
        self.leave = {int(r): int(t) for r, t in (leave or [])}
        self.W = 3 * self.N * self.c  # the fills' wait (3Nc)
        self.bound = 6 * self.N * self.c + 2 * self.c  # the check's bound (6Nc + 2c)
        # fills
        self.period = -1
        self.joined: float | None = None
        self.cr: set[int] = set()
        self.dcr: set[int] = set()
        self.periods: dict[int, dict] = {}
        self.poisoned: set[int] = set()  # periods over budget
        self.budget_flooded: set[int] = set()
        self.malformed: Counter = Counter()
        self.stale: Counter = Counter()
        self.other: Counter = Counter()  # frames of the other kinds received
        # check
        self.check: dict | None = None
        self.checks: list[dict] = []
        self.dc_heard: dict[int, dict[str, set[int]]] = defaultdict(lambda: {"true": set(), "false": set()})
        self.evaluated: dict[int, bool] = {}  # period -> own DC answer, once evaluated
        self.next_check: int | None = None
        self.biconnected: bool | None = None
        self.reason: str | None = None
        self.decided_at: int | None = None
        self.verdicts_seen: set[tuple] = set()
        # structure maintenance
        self.table: dict[int, list] = {}  # id -> [x, y, stamp tick, neighbour ids]
        self.heard: dict[int, int] = {}  # neighbour id -> tick of its last HELLO
        self.removed: set[int] = set()
        self.moves_seen: set[tuple] = set()
        self.motion: dict | None = None
        self.move_queue: list[dict] = []
        self.removals: list[dict] = []
        self.leading: dict | None = None
        self.join: dict | None = None
        self.jstate: dict | None = None
        self.left = False
        self.settled = not joiner

    # ------------------------------------------------------------ parameters
    @staticmethod
    def validate(params: dict, group: dict | None = None) -> str | None:
        """Why ``params`` cannot run, or None.

        ``group`` is the robot group as the scenario resolved it (its ``range`` is the robots' radio range):
        two regions must fit in it.
        """

        def is_int(v):
            return isinstance(v, int) and not isinstance(v, bool)

        def is_num(v):
            return isinstance(v, (int, float)) and not isinstance(v, bool)

        for key in ("N", "budget"):
            if key in params and (not is_int(params[key]) or params[key] < 1):
                return f"{key} = {params[key]!r} must be an integer >= 1"
        at = params.get("at", 0)
        ini = params.get("initiator")
        if isinstance(at, list):
            if not all(is_int(a) and a >= 0 for a in at):
                return f"at = {at!r} must be a tick or a list of ticks"
            if not isinstance(ini, list) or len(ini) != len(at):
                return "a list of ticks in 'at' needs a list of initiators of the same length"
        elif not is_int(at) or at < 0:
            return f"at = {at!r} must be an integer >= 0 (a tick)"
        for key in ("hello", "silence", "max_rounds"):
            if key in params and (not is_int(params[key]) or params[key] < 0):
                return f"{key} = {params[key]!r} must be an integer >= 0"
        if params.get("every") is not None and (not is_int(params["every"]) or params["every"] < 1):
            return f"every = {params['every']!r} must be an integer >= 1 (ticks)"
        for key in ("c", "speed"):
            if key in params and (not is_num(params[key]) or params[key] <= 0):
                return f"{key} = {params[key]!r} must be a number > 0"
        for key in ("region", "margin"):
            if key in params and (not is_num(params[key]) or params[key] < 0):
                return f"{key} = {params[key]!r} must be a number >= 0"
        if is_num(params.get("margin", 0)) and params.get("margin", 0) >= 1:
            return "margin must be < 1"
        for key in ("d_step", "d_more"):
            if params.get(key) is not None and (not is_num(params[key]) or params[key] <= 0):
                return f"{key} = {params[key]!r} must be a number > 0"
        region = params.get("region", 0.0)
        if group is not None and is_num(region):
            problem = _region_problem(float(group["range"]), region)
            if problem:
                return problem
        if ini is not None and not (is_int(ini) or (isinstance(ini, list) and all(is_int(i) for i in ini))):
            return f"initiator = {ini!r} must be a robot id or a list of ids"
        if params.get("placement", "heuristic") not in ("heuristic", "min_intersection"):
            return "placement must be 'heuristic' or 'min_intersection'"
        lv = params.get("leave")
        if lv is not None and not (isinstance(lv, list) and all(
                isinstance(e, list) and len(e) == 2 and all(is_int(x) for x in e) for e in lv)):
            return "leave must be a list of [robot id, tick] pairs"
        if params.get("joiner") and params.get("hello", 2) == 0:
            return "a joiner needs hello > 0 (positions travel in HELLO tables)"
        return None

    # ------------------------------------------------------------ helpers
    def _configure(self, ctx: Context) -> None:
        """Derive the structure's distances from the robot's radio range (the scenario's, ``ctx.range``)."""
        problem = _region_problem(ctx.range, self.region)
        if problem:
            raise ValueError(f"biconnectivity: {problem}")
        self.reach = max(0.0, ctx.range - 2 * self.region)
        self.safe = self.reach * (1 - self.margin)
        self.d_step = self.d_step_param if self.d_step_param is not None else self.reach / 100
        self.d_more = self.d_more_param if self.d_more_param is not None else self.reach / 20

    def _tick_len(self, ctx: Context) -> float:
        """Clock units per tick: 1 in lockstep (c in ticks), dt seconds in realtime."""
        return 1.0 if ctx.clock == "lockstep" else ctx.dt

    def _stats(self, p: int) -> dict:
        st = self.periods.get(p)
        if st is None:
            st = self.periods[p] = {"joined": None, "joined_tick": None, "received": Counter(),
                                    "relayed": Counter(), "sent": Counter(), "over_budget": False}
        return st

    def _set_verdict(self, ctx: Context, value: bool | None, reason: str | None) -> None:
        self.biconnected, self.reason, self.decided_at = value, reason, ctx.tick
        ctx.set_status(biconnected=value, reason=reason)

    # ------------------------------------------------------------ fills (R1-R4)
    def _join_period(self, ctx: Context, p: int) -> None:
        self.period = p
        self.joined = ctx.now
        self.cr, self.dcr = set(), set()
        st = self._stats(p)
        st["joined"], st["joined_tick"] = ctx.now, ctx.tick
        ck = self.check
        if ck is not None and not ck["evaluated"]:
            ck["period"] = p  # a newer fill supersedes: the check evaluates on it
        ctx.set_status(period=p)
        for kind in (CR, DCR):
            ctx.broadcast(kind, [p, [ctx.id]])
            st["sent"][kind] += 1

    def _see_period(self, ctx: Context, p: int, kind: str) -> bool:
        """Join a newer period; False (and counted stale) for an older one."""
        if p < self.period:
            self.stale[kind] += 1
            return False
        if p > self.period:
            self._join_period(ctx, p)
        return True

    def _stamps(self, frame: Frame) -> tuple[int, list[int]] | str:
        body = frame.body
        if not (isinstance(body, list) and len(body) == 2):
            return "body"
        p, s = body
        if not (isinstance(p, int) and not isinstance(p, bool) and p >= 0):
            return "period"
        if not isinstance(s, list) or not s:
            return "stamps"
        if not all(isinstance(x, int) and not isinstance(x, bool) for x in s):
            return "non-integer stamp"
        if len(s) > self.N:
            return "more than N stamps"
        if len(set(s)) != len(s):
            return "repeated stamp"
        if s[-1] != frame.src:
            return "last stamp is not the sender"
        return p, s

    def _on_stamped(self, ctx: Context, frame: Frame) -> None:
        got = self._stamps(frame)
        if isinstance(got, str):
            self.malformed[got] += 1
            return
        p, s = got
        if not self._see_period(ctx, p, frame.kind):
            return
        st = self.periods[p]
        st["received"][frame.kind] += 1
        me = ctx.id
        if frame.kind == CR:
            self.cr.update(x for x in s if x != me)  # R2
        elif me in s:  # R3 (Algorithm 2, lines 6-8)
            s2 = s[s.index(me) + 1:]
            if len(s2) > 1:
                self.dcr.update(s2)
        if me in s or p in self.poisoned:  # R1: never relay own-stamped; R7: a poisoned period is not relayed
            return
        if sum(st["relayed"].values()) >= self.budget:
            self._poison(ctx, p)
            return
        ctx.broadcast(frame.kind, [p, s + [me]])
        st["relayed"][frame.kind] += 1
        st["sent"][frame.kind] += 1

    def _poison(self, ctx: Context, p: int) -> None:
        self.poisoned.add(p)
        self._stats(p)["over_budget"] = True
        if p not in self.budget_flooded:
            self.budget_flooded.add(p)
            ctx.broadcast(BUDGET, [p])
        if self.check is None or self.check["period"] != p:
            if self.biconnected is None:
                self.reason = "budget"

    # ------------------------------------------------------------ the check (R5-R8)
    def _start_check(self, ctx: Context, initiator: bool, p: int, t_request: float) -> None:
        old = self.check
        if old is not None and not old["done"]:  # a new check replaces one still waiting
            old.update(done=True, reason="superseded", decided=ctx.now, decided_at=ctx.tick)
        self.check = {"period": p, "initiator": initiator, "requested": t_request, "started": ctx.now,
                      "started_tick": ctx.tick, "evaluated": False, "own": None, "verdict": None,
                      "reason": None, "decided": None, "decided_at": None, "done": False}
        self.checks.append(self.check)
        self.biconnected, self.reason, self.decided_at = None, None, None
        ctx.set_status(biconnected=None, reason=None)

    def _initiate(self, ctx: Context) -> None:
        fresh = self.joined is not None and ctx.now - self.joined < self.W
        if not fresh:
            self._join_period(ctx, max(ctx.tick, self.period + 1))
        p = self.period
        self._start_check(ctx, True, p, ctx.now)
        ctx.set_status(role="initiator")
        ctx.broadcast(CHECK_REQUEST, [p, ctx.now, ctx.id])

    def _on_request(self, ctx: Context, frame: Frame) -> None:
        body = frame.body
        if not (isinstance(body, list) and len(body) == 3 and isinstance(body[0], int)
                and not isinstance(body[0], bool) and body[0] >= 0 and isinstance(body[1], (int, float))):
            self.malformed["request"] += 1
            return
        p, t_req, _ = body
        if p > self.period:
            self._join_period(ctx, p)
        p = self.period  # an older request runs on the current fill
        if p in self.evaluated:  # already answered this period: repeat the answer for the new asker
            ctx.broadcast(DC_TRUE if self.evaluated[p] else DC_FALSE, [p])
            return
        ck = self.check
        if ck is not None and not ck["done"] and ck["period"] == p:
            return  # already running it
        self._start_check(ctx, False, p, float(t_req))

    def _evaluate(self, ctx: Context) -> None:
        ck = self.check
        p = ck["period"]
        ck["evaluated"] = True
        ck["evaluated_at"] = ctx.now
        ck["cr"], ck["dcr"] = sorted(self.cr), sorted(self.dcr)
        if p in self.poisoned:
            self._decide(ctx, None, "budget")
            return
        own = len(self.dcr) == len(self.cr)  # Algorithm 3, line 3
        ck["own"] = own
        self.evaluated[p] = own
        ctx.broadcast(DC_TRUE if own else DC_FALSE, [p])
        if not own:
            self._decide(ctx, False, "not doubly connected to all")  # line 7
        elif not self.cr:
            self._decide(ctx, False, "alone")
        else:
            self._try_decide(ctx)

    def _try_decide(self, ctx: Context) -> None:
        ck = self.check
        if ck is None or ck["done"] or not ck["evaluated"]:
            return
        heard = self.dc_heard[ck["period"]]
        if heard["false"]:
            self._decide(ctx, False, "a neighbour is not doubly connected to all")  # line 9
        elif heard["true"] and ck["own"]:
            self._decide(ctx, True, "this robot and a neighbour are doubly connected to all")  # lines 10-11

    def _decide(self, ctx: Context, value: bool | None, reason: str) -> None:
        ck = self.check
        ck.update(done=True, verdict=value, reason=reason, decided=ctx.now, decided_at=ctx.tick)
        self._set_verdict(ctx, value, reason)
        if ck["initiator"] and self.flood_verdict and value is not None:
            key = (ck["period"], ctx.id)
            self.verdicts_seen.add(key)
            ctx.broadcast(VERDICT, [ck["period"], ctx.id, value, reason])
        lead = self.leading
        if lead is not None and lead.get("checking") and ck["initiator"]:
            self._leader_verdict(ctx, value)

    def _on_dc(self, ctx: Context, frame: Frame) -> None:
        body = frame.body
        if not (isinstance(body, list) and len(body) == 1 and isinstance(body[0], int)
                and not isinstance(body[0], bool)):
            self.malformed["dc"] += 1
            return
        self.dc_heard[body[0]]["true" if frame.kind == DC_TRUE else "false"].add(frame.src)
        self._try_decide(ctx)

    def _on_verdict(self, ctx: Context, frame: Frame) -> None:
        body = frame.body
        if not (isinstance(body, list) and len(body) == 4 and isinstance(body[0], int) and isinstance(body[1], int)):
            self.malformed["verdict"] += 1
            return
        p, who, value, _ = body
        key = (p, who)
        if key in self.verdicts_seen:
            return
        self.verdicts_seen.add(key)
        ctx.broadcast(VERDICT, body)
        running = self.check is not None and not self.check["done"] and self.check["period"] == p
        if self.biconnected is None and not running and value in (True, False):
            self._set_verdict(ctx, bool(value), "flooded")

    def _on_budget(self, ctx: Context, frame: Frame) -> None:
        body = frame.body
        if not (isinstance(body, list) and len(body) == 1 and isinstance(body[0], int) and not isinstance(body[0], bool)
                and body[0] >= 0):
            self.malformed["budget"] += 1
            return
        p = body[0]
        if not self._see_period(ctx, p, BUDGET):
            return
        if p not in self.poisoned:
            self._poison(ctx, p)

    # ------------------------------------------------------------ hooks
    def on_start(self, ctx: Context) -> None:
        self._configure(ctx)
        if ctx.id in self.start_at:
            self.next_check = self.start_at[ctx.id]
        if self.joiner:
            self.jstate = {"phase": "ask", "until": None, "asked": 0}
            ctx.set_status(role="joiner")

    def on_frame(self, ctx: Context, frame: Frame) -> None:
        if self.left:
            return
        kind = frame.kind
        if kind in (CR, DCR):
            self._on_stamped(ctx, frame)
            return
        self.other[kind] += 1
        if kind == CHECK_REQUEST:
            self._on_request(ctx, frame)
        elif kind in (DC_TRUE, DC_FALSE):
            self._on_dc(ctx, frame)
        elif kind == BUDGET:
            self._on_budget(ctx, frame)
        elif kind == VERDICT:
            self._on_verdict(ctx, frame)
        elif kind == HELLO:
            self._on_hello(ctx, frame)
        elif kind == POS_REQUEST:
            if self.settled:
                ctx.send(frame.src, POS_REPLY, self._table_rows(ctx))
        elif kind == POS_REPLY:
            self._merge(ctx, frame.body)
        elif kind == LEAVE:
            if self.maintain and self.settled:
                self._lost(ctx, frame.src, "leave")
        elif kind == MOVE:
            self._on_move(ctx, frame)

    def on_tick(self, ctx: Context, sensed) -> None:
        if self.left:
            return
        if self.leave.get(ctx.id) == ctx.tick:
            ctx.broadcast(LEAVE, [ctx.id])
            self.left = True
            ctx.move([0.0, 0.0])
            ctx.set_status(role="left")
            return
        ck = self.check
        if ck is not None and not ck["done"]:
            if not ck["evaluated"] and self.joined is not None and ctx.now >= self.joined + self.W:
                self._evaluate(ctx)
            elif ck["evaluated"] and ctx.now - ck["requested"] >= self.bound:
                self._decide(ctx, None, "timeout")
        if self.next_check is not None and ctx.tick >= self.next_check:
            self.next_check = None if self.every is None else self.next_check + self.every
            self._initiate(ctx)
        self._motion_tick(ctx)
        if self.jstate is not None:
            self._joiner_tick(ctx)
        if self.hello and self.settled and ctx.tick % self.hello == 0:
            self._send_hello(ctx)
        if self.maintain and self.hello and self.settled:
            for r, t in list(self.heard.items()):
                if ctx.tick - t > self.silence and r not in self.removed:
                    self._lost(ctx, r, "silence")
        if self.leading is not None:
            self._leader_tick(ctx)

    # ------------------------------------------------------------ positions (R10)
    def _neighbours(self, ctx: Context) -> list[int]:
        return sorted(r for r, t in self.heard.items() if ctx.tick - t <= self.silence and r not in self.removed)

    def _table_rows(self, ctx: Context) -> list[list]:
        x, y = (float(v) for v in ctx.position[:2])
        self.table[ctx.id] = [x, y, ctx.tick, self._neighbours(ctx)]
        return [[rid, *row] for rid, row in sorted(self.table.items()) if rid not in self.removed]

    def _send_hello(self, ctx: Context) -> None:
        ctx.broadcast(HELLO, self._table_rows(ctx))

    def _merge(self, ctx: Context, rows) -> bool:
        if not isinstance(rows, list):
            self.malformed["table"] += 1
            return False
        for row in rows:
            if not (isinstance(row, list) and len(row) == 5 and isinstance(row[0], int)
                    and all(isinstance(v, (int, float)) for v in row[1:4]) and isinstance(row[4], list)):
                self.malformed["table"] += 1
                return False
            rid = row[0]
            if rid == ctx.id or rid in self.removed:
                continue
            old = self.table.get(rid)
            if old is None or row[3] > old[2]:
                self.table[rid] = [float(row[1]), float(row[2]), row[3], list(row[4])]
        return True

    def _on_hello(self, ctx: Context, frame: Frame) -> None:
        if frame.src in self.removed:
            return
        if self._merge(ctx, frame.body) and self.settled:
            self.heard[frame.src] = ctx.tick

    # ------------------------------------------------------------ removal (R12)
    def _lost(self, ctx: Context, r: int, how: str) -> None:
        if r in self.removed:
            return
        self.removed.add(r)
        self.heard.pop(r, None)
        entry = self.table.pop(r, None)
        nbrs = set(entry[3]) if entry else set()
        nbrs.add(ctx.id)
        nbrs = {v for v in nbrs if v != r and v not in self.removed}
        if min(nbrs) != ctx.id or (self.leading is not None and self.leading["ended"] is None):
            return
        if entry is None:
            return
        pos = np.array(entry[:2])
        ids = sorted(nbrs)
        pts = []
        for v in ids:
            if v == ctx.id:
                pts.append([float(x) for x in ctx.position[:2]])
            elif v in self.table:
                pts.append(self.table[v][:2])
        d = removal_distance(np.array(pts), pos, self.safe, self.d_step)
        self.leading = {"removed": r, "how": how, "pos": pos.tolist(), "neighbours": ids, "d": [], "rounds": 0,
                        "started": ctx.tick, "verdict": None, "ended": None, "checking": False, "check_at": None}
        self.removals.append(self.leading)
        ctx.set_status(role="leader")
        ctx.log(f"leading the removal of {r} ({how}); d = {d:.4f}")
        self._flood_move(ctx, d)

    def _flood_move(self, ctx: Context, d: float) -> None:
        lead = self.leading
        lead["rounds"] += 1
        lead["d"].append(d)
        c_ticks = math.ceil(self.N * self.c / self._tick_len(ctx) - 1e-9)
        start = ctx.tick + c_ticks + 1
        body = [ctx.id, lead["rounds"], lead["removed"], lead["pos"], d, start, self.speed]
        move_ticks = math.ceil(d / (self.speed * ctx.dt) - 1e-9) if d > 0 else 0
        lead["check_at"] = start + move_ticks + 1
        self._accept_move(ctx, body)

    def _accept_move(self, ctx: Context, body: list) -> None:
        leader, rnd, removed, pos, d, start, speed = body
        key = (leader, rnd, removed)
        if key in self.moves_seen:
            return
        self.moves_seen.add(key)
        ctx.broadcast(MOVE, body)  # forward once
        if removed not in self.removed:
            self.removed.add(removed)
            self.heard.pop(removed, None)
            self.table.pop(removed, None)
        if d > 0 and self.settled:
            self.move_queue.append({"pos": np.array(pos, dtype=float), "d": float(d), "start": int(start),
                                    "speed": float(speed), "x0": None})

    def _on_move(self, ctx: Context, frame: Frame) -> None:
        b = frame.body
        if not (isinstance(b, list) and len(b) == 7 and all(isinstance(v, int) for v in b[:3])
                and isinstance(b[3], list) and len(b[3]) == 2 and all(isinstance(v, (int, float)) for v in b[3])
                and isinstance(b[4], (int, float)) and b[4] >= 0 and isinstance(b[5], int)
                and isinstance(b[6], (int, float)) and b[6] > 0):
            self.malformed["move"] += 1
            return
        self._accept_move(ctx, b)

    def _motion_tick(self, ctx: Context) -> None:
        """Follow the current MOVE: after k ticks the robot is at prox(x0, pos, min(k·speed·dt, d))."""
        m = self.motion
        if m is not None and m.get("arrived"):
            ctx.move([0.0, 0.0])
            self.motion = m = None
            ctx.set_status(moving=False)
        if m is None and self.move_queue and ctx.tick >= self.move_queue[0]["start"]:
            self.motion = m = self.move_queue.pop(0)
            ctx.set_status(moving=True)
        if m is None:
            return
        if m["x0"] is None:
            m["x0"] = np.array(ctx.position[:2], dtype=float)
            m["dist0"] = float(np.linalg.norm(m["x0"] - m["pos"]))
            m["goal"] = min(m["d"], m["dist0"])
        s = min((ctx.tick - m["start"] + 1) * m["speed"] * ctx.dt, m["goal"])
        target = prox(m["x0"], m["pos"], s)
        here = np.array(ctx.position[:2], dtype=float)
        ctx.move(((target - here) / ctx.dt).tolist())
        if s >= m["goal"]:
            m["arrived"] = True

    def _leader_tick(self, ctx: Context) -> None:
        lead = self.leading
        if lead["ended"] is not None:
            return
        if not lead["checking"] and lead["check_at"] is not None and ctx.tick >= lead["check_at"]:
            lead["checking"] = True
            self._initiate(ctx)

    def _leader_verdict(self, ctx: Context, value: bool | None) -> None:
        lead = self.leading
        lead["checking"] = False
        lead["verdict"] = value
        if value is True or value is None or lead["rounds"] >= self.max_rounds:
            lead["ended"] = ctx.tick
            ctx.set_status(role="leader-done")
            return
        self._flood_move(ctx, self.d_more)

    # ------------------------------------------------------------ joining (R11)
    def _known_centres(self, ctx: Context) -> tuple[list[int], np.ndarray]:
        ids = sorted(r for r in self.table if r != ctx.id and r not in self.removed)
        return ids, np.array([self.table[r][:2] for r in ids], dtype=float).reshape(-1, 2)

    def _go(self, ctx: Context, target: np.ndarray) -> bool:
        """Command a step towards ``target``; True once there."""
        here = np.array(ctx.position[:2], dtype=float)
        delta = target - here
        dist = float(np.linalg.norm(delta))
        if dist < 1e-5:  # poses come rounded to 1e-6
            ctx.move([0.0, 0.0])
            return True
        step = min(dist, self.speed * ctx.dt)
        ctx.move((delta / dist * step / ctx.dt).tolist())
        return False

    def _joiner_tick(self, ctx: Context) -> None:
        js = self.jstate
        wait = 2 * self.c + self._tick_len(ctx)
        phase = js["phase"]
        if phase in ("ask", "ask2"):
            if js["until"] is None:
                ctx.broadcast(POS_REQUEST, [ctx.id])
                js["asked"] += 1
                js["until"] = ctx.now + wait
                return
            if ctx.now < js["until"]:
                return
            js["until"] = None
            ids, centres = self._known_centres(ctx)
            if not ids:
                return  # nobody answered: ask again
            if phase == "ask":
                got = join_position(centres, self.safe, method=self.placement, rho=self.region, rng=ctx.rng)
                if got is None:
                    return
                pos, value, closest = got
                js.update(first=pos.tolist(), first_value=value, nr=[ids[i] for i in closest])
                js["phase"] = "approach"
            else:
                nr = [r for r in js["nr"] if r in ids]
                must = [ids.index(r) for r in nr]
                got = join_position(centres, self.safe, must=must, method=self.placement, rho=self.region,
                                    rng=ctx.rng) or join_position(centres, self.safe, method=self.placement,
                                                                  rho=self.region, rng=ctx.rng)
                if got is None:
                    return
                pos, value, closest = got
                js.update(final=pos.tolist(), value=value, phase="go")
        elif phase == "approach":
            nr1 = js["nr"][0]
            if nr1 not in self.table:
                js["phase"] = "ask2"
                return
            c1 = np.array(self.table[nr1][:2])
            here = np.array(ctx.position[:2], dtype=float)
            if np.linalg.norm(here - c1) <= self.safe / 2:
                ctx.move([0.0, 0.0])
                js["phase"] = "ask2"
                return
            # head for nr1, stopping half the neighbour distance short of its centre
            d = np.linalg.norm(here - c1)
            self._go(ctx, c1 + (here - c1) / d * (self.safe / 2) * 0.999)
        elif phase == "go":
            if self._go(ctx, np.array(js["final"])):
                js["phase"] = "settled"
                self.settled = True
                self.heard = {}
                ids, centres = self._known_centres(ctx)
                self.join = {"position": js["final"], "value": js["value"], "nr": js["nr"],
                             "first_target": js["first"], "first_value": js["first_value"],
                             "requests": js["asked"], "settled_at": ctx.tick, "placement": self.placement}
                ctx.set_status(role="joined")
                self._send_hello(ctx)
                self.jstate = None

    # ------------------------------------------------------------ report and metrics
    def report(self) -> dict:
        periods = {str(p): {"joined": st["joined"], "joined_tick": st["joined_tick"],
                            "received": dict(st["received"]), "relayed": dict(st["relayed"]),
                            "sent": dict(st["sent"]), "over_budget": st["over_budget"]}
                   for p, st in sorted(self.periods.items())}
        checks = [{k: v for k, v in ck.items() if k != "done"} for ck in self.checks]
        return {
            "period": self.period if self.period >= 0 else None,
            "cr": sorted(self.cr),
            "dcr": sorted(self.dcr),
            "biconnected": self.biconnected,
            "reason": self.reason,
            "decided_at": self.decided_at,
            "checks": checks,
            "periods": periods,
            "malformed": sum(self.malformed.values()),
            "malformed_reasons": dict(self.malformed),
            "stale": dict(self.stale),
            "other_received": dict(self.other),
            "bounds": {"fill": self.W, "check": self.bound},
            "neighbours": sorted(self.heard),
            "removed": sorted(self.removed),
            "removals": [{k: v for k, v in r.items() if k not in ("checking", "check_at")} for r in self.removals],
            "join": self.join,
        }

    @classmethod
    def metrics(cls, reports: dict[int, dict]) -> dict:
        per = defaultdict(lambda: {"robots": 0, "received": Counter(), "relayed": Counter(), "sent": Counter()})
        for r in reports.values():
            for p, st in r.get("periods", {}).items():
                agg = per[p]
                agg["robots"] += 1
                for key in ("received", "relayed", "sent"):
                    agg[key].update(st[key])
        periods = {}
        for p, agg in sorted(per.items(), key=lambda kv: int(kv[0])):
            n = agg["robots"]
            periods[p] = {"robots": n, **{f"mean_{key}": {k: v / n for k, v in agg[key].items()}
                                          for key in ("received", "relayed", "sent")}}
        decided = [r for r in reports.values() if r.get("decided_at") is not None]
        return {
            "robots": len(reports),
            "periods": periods,
            "decided": len(decided),
            "verdicts": dict(Counter(str(r["biconnected"]) for r in decided)),
            "budget_hits": sum(1 for r in reports.values() if r.get("reason") == "budget"),
            "malformed": sum(r.get("malformed", 0) for r in reports.values()),
            "removals": [dict(r, leader=rid) for rid, rep in reports.items() for r in rep.get("removals", [])],
            "joins": {rid: rep["join"] for rid, rep in reports.items() if rep.get("join")},
        }


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
    last = result.trace[-1]["t"]
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
    ticks = [rec["t"] for rec in result.trace]
    t = min((x for x in ticks if x >= p), default=ticks[-1])
    return result.graph_at(t)


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
    end = result.trace[-1]["t"] * _tick_len(result)
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
    last = result.trace[-1]["t"]
    g_end = result.graph_at(last)
    ok_end = paper_biconnected(g_end)
    broken: list = []
    first = None
    for rec in result.trace:
        for row in rec.get("sent", []):
            if row[2] == MOVE:
                first = rec["t"]
                break
        if first is not None:
            break
    if first is not None:
        g0 = result.graph_at(first)
        alive_end = set(g_end)
        edges0 = {tuple(sorted(e)) for e in g0.edges if e[0] in alive_end and e[1] in alive_end}
        for rec in result.trace:
            if rec["t"] <= first:
                continue
            g = result.graph_at(rec["t"])
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
    last = result.trace[-1]["t"]
    g = result.graph_at(last)
    rec = result.record(last)
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


# ------------------------------------------------------------------ conformance suite
def _bicon_case(name: str, positions: list, *, initiator: int = 0, clock: str = "lockstep", seed: int = 1,
                checks=("biconnectivity.lists", "biconnectivity.verdict", "biconnectivity.paths")) -> Case:
    n = len(positions)
    run = {"seed": seed, "clock": clock, "ticks": 6 * (n + 2) + 10}
    radio = {"range": 1.0, "latency": 1}
    beh = {"use": "biconnectivity", "N": n + 2, "c": 1, "initiator": initiator, "at": 1, "hello": 0}
    if clock == "realtime":
        run.update(dt=0.02, ticks=6 * (n + 2) + 20)
        radio.update(latency_s=0.02, latency_min_s=0.01)
        beh["c"] = 0.02
    scenario = {"run": run, "radio": radio, "robots": [{"positions": positions, "behaviors": [beh]}]}
    return Case(f"biconnectivity/{name}", scenario, [{"use": c} for c in checks])


def suite(mode: str) -> list[Case]:
    """Biconnected and not: rings, ladders, trees, a bow tie, two components; both clocks.

    Graphs stay small: the relay enumerates simple paths.
    """
    bowtie = [[0.0, 0.0], [0.8, 0.4], [0.0, 0.8], [1.6, 0.0], [1.6, 0.8]]  # two triangles sharing robot 1
    two_rings = ring(5) + [[x + 20.0, y] for x, y in ring(5)]
    cases = [
        _bicon_case("ring-6", ring(6)),
        _bicon_case("ladder-8", ladder(8)),
        _bicon_case("comb-7", comb(7)),
        _bicon_case("bowtie-5", bowtie, initiator=1),
        _bicon_case("two-components", two_rings),
        _bicon_case("ring-5-realtime", ring(5), clock="realtime",
                    checks=("biconnectivity.lists", "biconnectivity.verdict")),
    ]
    if mode == "full":
        cases += [_bicon_case("ring-9", ring(9)), _bicon_case("ladder-10", ladder(10)),
                  _bicon_case("line-6", line(6)), _bicon_case("pair", line(2)), _bicon_case("comb-9", comb(9))]
        for seed in (1, 2, 3):
            cases.append(_bicon_case(f"rgg-8-s{seed}", random_geometric(8, seed, degree=3.0), seed=seed))
        cases.append(_bicon_case("ladder-8-realtime", ladder(8), clock="realtime",
                                 checks=("biconnectivity.lists", "biconnectivity.verdict")))
    return cases


FAMILY = Family(name="biconnectivity", behavior="biconnectivity",
                report={"cr": list, "dcr": list, "biconnected": (bool, type(None)), "decided_at": (int, float,
                                                                                                  type(None))},
                suite=suite)
