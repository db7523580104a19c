"""Task Scheduling Controller of Panerati et al. (ICRA 2018, §III-C/D): TCTM and TDSM as MILPs on HiGHS.

TCTM minimises the total completion time Λ = Σ_s z^s (Eq. 4) under Eqs. 5-13; TDSM then minimises the
dislocation of the deployment points plus the arm lengths (Eq. 14) among the schedules of duration ≤ Λ.
Both are solved with ``scipy.optimize.milp`` (HiGHS) under a time limit; a solve that hits it returns its
incumbent with the MIP gap.

The paper omits "a number of additional constraints, as well as the variables domains" (§III-D-2). The ones
added here, each needed for the printed ones to mean what the text says (docs/protocols/tsc.md):

- Y   y_t^{Xs} ≥ ±(σ_t^X − Θ^{Xs}), likewise Y: y is at least the distance from task t to slot s's
      deployment point (Eqs. 7-9 only bound y from above).
- R   r_min ≤ Θ^s ≤ r_max: each deployment point lies in the region R.
- G   ḡ^{Xs} ≥ ±(Θ^{Xs} − Θ^{X,s−1}), likewise Y, for s ∈ S̄ (TDSM only); slot 0 (S_0) is the start Θ_0,
      fixed, so ḡ^1 is the flight from the start to the first deployment point.
- K   capability coverage through τ_tk: in every slot the β_t x_t^s task robots of every task are drawn
      from classes able to do t, no class giving more robots than it has. Written as a transportation
      flow u_{jk}^s ≥ 0 from robot class k to task type j (the tasks demanding the same capability set);
      continuous u is exact because the transportation polytope with integer data is integral.
- B   Σ_s z^s ≤ Λ (TDSM only), Λ from TCTM.
- (11) is used in its tightened form w_t^s ≤ (|N| − 1 − β_t) x_t^s, implied by (10) and (11).
- M   the big-M of Eqs. 7-9 is per task and axis: the largest distance from σ_t to the arena's edge, less the
      reach of an arm of zero robots, so the constraints are exactly void when x_t^s = 0.
"""

from __future__ import annotations

import math
import multiprocessing
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from itertools import product
from typing import Any

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, linear_sum_assignment, milp
from scipy.sparse import csr_array

__all__ = [
    "ARMS",
    "DENSITIES",
    "MAX_ROBOTS",
    "MAX_TASKS",
    "MAX_VARIABLES",
    "Instance",
    "InstanceError",
    "Schedule",
    "Task",
    "arm_cost",
    "arm_reach",
    "assign_robots",
    "check_instance",
    "completion_time",
    "dislocation",
    "min_arms",
    "model_variables",
    "random_instance",
    "solve",
    "solve_tctm",
    "solve_tdsm",
    "used_slots",
]

DENSITIES = (0.005, 0.01, 0.05, 0.1, 0.2, 0.5)  # communication densities D of §IV-B
# Eqs. 7-9 bound the quadrant of the circle of radius Γ(w + Ω)/Ω by x ≤ R, y ≤ R, x + y ≤ √2 R: the
# circumscribed octagon (the paper's "paper" reading), whose corners lie 8.2 % beyond the circle; "inscribed"
# scales R by cos(π/8) so that every admitted point is within the circle (a safe arm length).
ARMS = {"paper": 1.0, "inscribed": math.cos(math.pi / 8)}
# Instance bounds, checked before a model is built (docs/protocols/tsc.md, "Limits"): the paper's instances and
# ours have |N| = 20 and |T| <= 8 (protocols/tsc/experiments/); a MILP far beyond these is not solved in any
# time limit a user would give, and building it alone takes the memory of |T|^2 rows.
MAX_ROBOTS = 1000  # |N|: the robot assignment is a |N| x |N| matrix per slot
MAX_TASKS = 100  # |T|: |T| x |S| of each of x, w, y^X, y^Y, with |S| = |T| by default
MAX_VARIABLES = 100_000  # the model's columns (model_variables): ~10 rows and ~30 nonzeros per (task, slot)
OVERRUN_S = 1.0  # HiGHS may overrun its time limit (its presolve checks the clock rarely): it is stopped after
OVERRUN_SHARE = 0.05  # the limit + OVERRUN_S + OVERRUN_SHARE x the limit, in a child process that is killed


class InstanceError(ValueError):
    """An instance with no schedule at all; ``key`` names the input field (e.g. ``tasks[2].robots``)."""

    def __init__(self, key: str, value, message: str):
        super().__init__(f"{key} = {value!r}: {message}")
        self.key, self.value, self.reason = key, value, message


@dataclass(frozen=True)
class Task:
    """A task t: location σ_t, demanded robots β_t, duration δ_t, demanded capabilities v_t^c, priorities μ."""

    id: str
    position: tuple[float, float]
    robots: int = 1
    duration: float = 1.0
    capabilities: frozenset[str] = frozenset()
    after: tuple[str, ...] = ()  # ids t1 with μ_t^{t1} = 1: t1 must run in an earlier slot than this task


@dataclass(frozen=True)
class Instance:
    """Robots N (one capability set each, ids 0..|N|-1), tasks T, region R, start Θ_0, range Γ and Ω."""

    arena: tuple[tuple[float, float], tuple[float, float]]  # ((r_min^X, r_max^X), (r_min^Y, r_max^Y))
    start: tuple[float, float]
    robots: tuple[frozenset[str], ...]
    tasks: tuple[Task, ...]
    gamma: float = 1.0
    omega: int = 1
    max_slots: int | None = None  # |S| (default |T|: one task per slot is always a candidate)
    arms: str = "paper"  # a key of ARMS

    @property
    def slots(self) -> int:
        return min(self.max_slots or len(self.tasks), len(self.tasks))

    def classes(self) -> dict[frozenset[str], int]:
        """The configuration classes K: robots with the same capability set, and how many each holds."""
        out: dict[frozenset[str], int] = {}
        for caps in self.robots:
            out[caps] = out.get(caps, 0) + 1
        return out

    def to_dict(self) -> dict:
        """Plain JSON-able form (the one ``schedule_check`` reads)."""
        return {
            "arena": {"x": list(self.arena[0]), "y": list(self.arena[1])},
            "start": list(self.start),
            "gamma": self.gamma,
            "omega": self.omega,
            "max_slots": self.max_slots,
            "arms": self.arms,
            "robots": [sorted(c) for c in self.robots],
            "tasks": [{"id": t.id, "position": list(t.position), "robots": t.robots, "duration": t.duration,
                       "capabilities": sorted(t.capabilities), "after": list(t.after)} for t in self.tasks],
        }

    @classmethod
    def from_dict(cls, d: dict) -> Instance:
        return cls(
            arena=(tuple(d["arena"]["x"]), tuple(d["arena"]["y"])),
            start=tuple(d["start"]),
            robots=tuple(frozenset(c) for c in d["robots"]),
            tasks=tuple(Task(t["id"], tuple(t["position"]), t["robots"], t["duration"], frozenset(t["capabilities"]),
                             tuple(t.get("after", ()))) for t in d["tasks"]),
            gamma=d.get("gamma", 1.0), omega=d.get("omega", 1), max_slots=d.get("max_slots"),
            arms=d.get("arms", "paper"),
        )


def check_instance(inst: Instance) -> None:
    """Raise InstanceError unless every task can run alone in a slot, so that a schedule exists.

    With |S| = |T| the instance is then feasible: one task per slot, the deployment point on the task (w = 0),
    in an order respecting the priorities (Eq. 13) when they have no cycle.
    """
    (x0, x1), (y0, y1) = inst.arena
    if not (x0 < x1 and y0 < y1):
        raise InstanceError("arena", [list(inst.arena[0]), list(inst.arena[1])], "needs min < max on both axes")
    if not (x0 <= inst.start[0] <= x1 and y0 <= inst.start[1] <= y1):
        raise InstanceError("start", list(inst.start), "the start Θ_0 must lie inside the arena")
    if inst.gamma <= 0:
        raise InstanceError("gamma", inst.gamma, "the communication range Γ must be > 0")
    if inst.omega < 1:
        raise InstanceError("omega", inst.omega, "Ω (robot-disjoint paths) must be >= 1")
    if inst.arms not in ARMS:
        raise InstanceError("arms", inst.arms, f"must be one of {', '.join(ARMS)}")
    if not inst.tasks:
        raise InstanceError("tasks", [], "there is no task to schedule")
    if len(inst.robots) > MAX_ROBOTS:
        raise InstanceError("robots", len(inst.robots), f"more than the {MAX_ROBOTS} robots a schedule may have")
    if len(inst.tasks) > MAX_TASKS:
        raise InstanceError("tasks", len(inst.tasks), f"more than the {MAX_TASKS} tasks a schedule may have")
    n = len(inst.robots)
    owned = set().union(*inst.robots) if inst.robots else set()
    ids = {}
    for i, t in enumerate(inst.tasks):
        if t.id in ids:
            raise InstanceError(f"tasks[{i}].id", t.id, f"already the id of tasks[{ids[t.id]}]")
        ids[t.id] = i
        if not (x0 <= t.position[0] <= x1 and y0 <= t.position[1] <= y1):
            raise InstanceError(f"tasks[{i}].position", list(t.position), "the task lies outside the arena")
        if t.robots < 1:
            raise InstanceError(f"tasks[{i}].robots", t.robots, "a task demands at least one robot (β_t >= 1)")
        if t.duration <= 0:
            raise InstanceError(f"tasks[{i}].duration", t.duration, "the duration δ_t must be > 0")
        missing = sorted(t.capabilities - owned)
        if missing:
            have = ", ".join(sorted(owned)) or "none"
            raise InstanceError(f"tasks[{i}].capabilities", sorted(t.capabilities),
                                f"no robot has {', '.join(missing)} (robots have: {have})")
        if t.robots > n - 1:
            raise InstanceError(f"tasks[{i}].robots", t.robots,
                                f"more robots than the swarm can give a task: |N| - 1 = {n - 1} "
                                f"(one robot stays at the deployment point as the master)")
        able = sum(1 for c in inst.robots if t.capabilities <= c)
        if t.robots > able:
            raise InstanceError(f"tasks[{i}].robots", t.robots,
                                f"only {able} robots have {', '.join(sorted(t.capabilities))}")
    for i, t in enumerate(inst.tasks):
        for a in t.after:
            if a not in ids:
                raise InstanceError(f"tasks[{i}].after", list(t.after), f"no task has id {a!r}")
            if a == t.id:
                raise InstanceError(f"tasks[{i}].after", list(t.after), "a task cannot come after itself")
    depth = _priority_depth(inst)
    if depth is None:
        cyc = _priority_cycle(inst)
        raise InstanceError(f"tasks[{ids[cyc[0]]}].after", list(inst.tasks[ids[cyc[0]]].after),
                            "the priorities form a cycle: " + " -> ".join(cyc + [cyc[0]]))
    if inst.max_slots is not None and inst.max_slots < 1:
        raise InstanceError("max_slots", inst.max_slots, "must be >= 1")
    if inst.max_slots is not None and inst.max_slots < depth:
        raise InstanceError("max_slots", inst.max_slots, f"the priorities chain {depth} tasks: at least {depth} slots")
    columns = model_variables(inst)
    if columns > MAX_VARIABLES:
        raise InstanceError("tasks", len(inst.tasks),
                            f"the model would have {columns:,} variables ({len(inst.tasks)} tasks x {inst.slots} "
                            f"slots), more than {MAX_VARIABLES:,}: give fewer tasks, a smaller solver.max_slots or "
                            "fewer distinct capability sets")


def model_variables(inst: Instance) -> int:
    """Columns of the TDSM model (TCTM has 2|S| fewer): x, w, y^X, y^Y per (task, slot); z, Θ, ḡ and K's flows."""
    classes = inst.classes()
    types = {t.capabilities for t in inst.tasks}
    arcs = sum(1 for j in types for k in classes if j <= k)
    return inst.slots * (4 * len(inst.tasks) + 5 + arcs)


class ModelTimeout(Exception):
    """The time limit ran out while the model was being built."""


def _deadline_check(deadline: float) -> None:
    if time.perf_counter() > deadline:
        raise ModelTimeout


def _priority_depth(inst: Instance) -> int | None:
    """Length of the longest priority chain, or None when the priorities have a cycle."""
    after = {t.id: t.after for t in inst.tasks}
    depth: dict[str, int] = {}
    state: dict[str, int] = {}

    def visit(u: str) -> int | None:
        if state.get(u) == 1:
            return None
        if u in depth:
            return depth[u]
        state[u] = 1
        best = 0
        for v in after[u]:
            d = visit(v)
            if d is None:
                return None
            best = max(best, d)
        state[u] = 2
        depth[u] = best + 1
        return depth[u]

    out = 0
    for t in inst.tasks:
        d = visit(t.id)
        if d is None:
            return None
        out = max(out, d)
    return out


def _priority_cycle(inst: Instance) -> list[str]:
    after = {t.id: t.after for t in inst.tasks}
    for start in after:
        path, seen, u = [start], {start}, start
        stack = [(start, iter(after[start]))]
        while stack:
            u, it = stack[-1]
            v = next(it, None)
            if v is None:
                stack.pop()
                path.pop()
                continue
            if v == start:
                return path[:]
            if v not in seen:
                seen.add(v)
                path.append(v)
                stack.append((v, iter(after[v])))
    return []


def arm_reach(inst: Instance, w: float) -> float:
    """R = Γ(w + Ω)/Ω (Eqs. 8-9, scaled by ARMS): the axis reach of an arm of w robots in Ω disjoint paths."""
    return ARMS[inst.arms] * inst.gamma * (w + inst.omega) / inst.omega


def min_arms(inst: Instance, point: Sequence[float], task: Task) -> int:
    """Fewest arm robots w with (y^X, y^Y) = |σ_t − Θ| inside the three pieces of Eqs. 7-9."""
    dx, dy = abs(task.position[0] - point[0]), abs(task.position[1] - point[1])
    need = max(dx, dy, (dx + dy) / math.sqrt(2))  # the octagon's gauge: the R the point needs
    unit = ARMS[inst.arms] * inst.gamma / inst.omega
    return max(0, math.ceil(need / unit - inst.omega - 1e-6))  # HiGHS keeps constraints to ~1e-6


@dataclass
class Schedule:
    """One model's answer: solver outcome, the variables of Eqs. 4-14, and the robots given each role.

    ``x[t][s]``, ``w[t][s]``, ``y[t][s] = [y^X, y^Y]`` per task t and slot s (0-based: slot 1 of the paper is
    index 0), ``z[s]``, ``theta[s] = [Θ^X, Θ^Y]``, ``gbar[s] = [ḡ^X, ḡ^Y]`` (TDSM; None for TCTM).
    ``assignment[s]`` for each used slot: master robot, and per task its robots and its arm's robots.
    """

    model: str
    status: str  # optimal | time_limit (incumbent, see gap) | no_solution (limit hit, none found) | infeasible
    message: str
    seconds: float
    objective: float | None = None
    dual_bound: float | None = None
    gap: float | None = None
    nodes: int | None = None
    bound: float | None = None  # Λ used by TDSM
    x: list[list[int]] = field(default_factory=list)
    z: list[float] = field(default_factory=list)
    w: list[list[int]] = field(default_factory=list)
    y: list[list[list[float]]] = field(default_factory=list)
    theta: list[list[float]] = field(default_factory=list)
    gbar: list[list[float]] | None = None
    assignment: list[dict] = field(default_factory=list)

    @property
    def solved(self) -> bool:
        return self.status in ("optimal", "time_limit")

    def slot_of(self) -> list[int]:
        """The slot index of every task."""
        return [row.index(1) for row in self.x]

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def used_slots(sched: Schedule) -> list[int]:
    """Indices of the slots holding at least one task (a prefix, by Eq. 12)."""
    return [s for s in range(len(sched.z)) if any(row[s] for row in sched.x)]


def dislocation(inst: Instance, sched: Schedule) -> float:
    """Σ over used slots of |Θ^s − Θ^{s−1}|_1 from the start Θ_0 (Fig. 7's measure, Eq. 14's first sum / |N|)."""
    prev, total = inst.start, 0.0
    for s in used_slots(sched):
        total += abs(sched.theta[s][0] - prev[0]) + abs(sched.theta[s][1] - prev[1])
        prev = sched.theta[s]
    return total


def arm_cost(inst: Instance, sched: Schedule, tight: bool = False) -> float:
    """Σ_{s,t} (Γ/Ω) w_t^s (Fig. 8's measure); ``tight`` uses the fewest robots reaching from the same Θ."""
    total = 0
    for t, task in enumerate(inst.tasks):
        for s in range(len(sched.z)):
            if sched.x[t][s]:
                total += min_arms(inst, sched.theta[s], task) if tight else sched.w[t][s]
    return inst.gamma / inst.omega * total


class _Builder:
    """Columns (bounds, integrality, cost) and sparse rows lo ≤ a·x ≤ hi for scipy.optimize.milp."""

    def __init__(self):
        self.lb: list[float] = []
        self.ub: list[float] = []
        self.integ: list[int] = []
        self.cost: list[float] = []
        self.r_idx: list[int] = []
        self.c_idx: list[int] = []
        self.vals: list[float] = []
        self.lo: list[float] = []
        self.hi: list[float] = []

    def var(self, shape: tuple[int, ...], lb, ub, integer: bool) -> np.ndarray:
        n = int(np.prod(shape)) if shape else 1
        idx = np.arange(len(self.lb), len(self.lb) + n).reshape(shape)
        self.lb += list(np.broadcast_to(lb, shape).ravel()) if shape else [lb]
        self.ub += list(np.broadcast_to(ub, shape).ravel()) if shape else [ub]
        self.integ += [int(integer)] * n
        self.cost += [0.0] * n
        return idx

    def row(self, terms: Sequence[tuple[int, float]], lo: float = -np.inf, hi: float = np.inf) -> None:
        r = len(self.lo)
        for c, v in terms:
            self.r_idx.append(r)
            self.c_idx.append(int(c))
            self.vals.append(float(v))
        self.lo.append(lo)
        self.hi.append(hi)

    def solve(self, time_limit: float, mip_rel_gap: float | None):
        """``milp`` with HiGHS's ``time_limit``; None if HiGHS overran it (see ``_within``)."""

        def run():
            a = csr_array((self.vals, (self.r_idx, self.c_idx)), shape=(len(self.lo), len(self.lb)))
            options = {"time_limit": float(time_limit), "presolve": True}
            if mip_rel_gap is not None:
                options["mip_rel_gap"] = mip_rel_gap
            return milp(np.array(self.cost), integrality=np.array(self.integ), bounds=Bounds(self.lb, self.ub),
                        constraints=LinearConstraint(a, self.lo, self.hi), options=options)

        return _within(run, time_limit + OVERRUN_S + OVERRUN_SHARE * time_limit)


def _within(fn: Callable[[], Any], seconds: float):
    """``fn()`` run in a forked child process, killed if it has not answered within ``seconds`` (then None).

    An exception in the child is raised again here as a RuntimeError. Without ``fork`` (Windows), ``fn()`` runs
    here, unbounded.
    """
    if "fork" not in multiprocessing.get_all_start_methods():
        return fn()
    ctx = multiprocessing.get_context("fork")
    receive, send = ctx.Pipe(duplex=False)
    child = ctx.Process(target=_answer, args=(fn, send), daemon=True)
    child.start()
    send.close()
    try:
        if not receive.poll(seconds):
            return None
        try:
            ok, value = receive.recv()
        except EOFError:
            child.join(1.0)
            raise RuntimeError(f"the solver process ended without an answer (exit code {child.exitcode})") from None
        if not ok:
            raise RuntimeError(f"the solver failed: {value}")
        return value
    finally:
        receive.close()
        child.kill()
        child.join()


def _answer(fn: Callable[[], Any], send) -> None:
    try:
        out = (True, fn())
    except BaseException as exc:  # noqa: BLE001 — reported to the parent, which raises it
        out = (False, f"{exc.__class__.__name__}: {exc}")
    send.send(out)
    send.close()


def _model(inst: Instance, tdsm: bool, bound: float | None, deadline: float = math.inf):
    """Variables and constraints shared by TCTM and TDSM (Eqs. 5-13 and Y, R, K), plus G and B for TDSM.

    ModelTimeout once ``time.perf_counter()`` passes ``deadline`` (checked once per task and per slot).
    """
    b = _Builder()
    tasks, n, m, nt = inst.tasks, len(inst.robots), inst.slots, len(inst.tasks)
    (x0, x1), (y0, y1) = inst.arena
    sx = np.array([t.position[0] for t in tasks])
    sy = np.array([t.position[1] for t in tasks])
    beta = np.array([t.robots for t in tasks])
    delta = np.array([t.duration for t in tasks], dtype=float)
    ux, uy = np.maximum(sx - x0, x1 - sx), np.maximum(sy - y0, y1 - sy)  # largest |σ_t − Θ| per axis
    reach0 = arm_reach(inst, 0)  # Γ' (reach with w = 0)
    slope = ARMS[inst.arms] * inst.gamma / inst.omega  # Γ'/Ω
    r2 = math.sqrt(2)

    x = b.var((nt, m), 0, 1, True)
    w = b.var((nt, m), 0, (n - 1 - beta)[:, None] * np.ones((1, m)), True)
    yx = b.var((nt, m), 0, ux[:, None] * np.ones((1, m)), False)
    yy = b.var((nt, m), 0, uy[:, None] * np.ones((1, m)), False)
    z = b.var((m,), 0, float(delta.max()), False)
    thx = b.var((m,), x0, x1, False)
    thy = b.var((m,), y0, y1, False)  # R: Θ^s inside the region
    for t in range(nt):
        _deadline_check(deadline)
        b.row([(x[t, s], 1) for s in range(m)], 1, 1)  # (6) each task in exactly one slot
        m7 = max(ux[t] + uy[t] - r2 * reach0, 0.0)
        m8, m9 = max(ux[t] - reach0, 0.0), max(uy[t] - reach0, 0.0)
        for s in range(m):
            b.row([(z[s], 1), (x[t, s], -delta[t])], lo=0)  # (5) z^s ≥ δ_t x_t^s
            b.row([(yx[t, s], 1), (thx[s], 1)], lo=sx[t])  # Y: y^X ≥ σ^X − Θ^X
            b.row([(yx[t, s], 1), (thx[s], -1)], lo=-sx[t])  # Y: y^X ≥ Θ^X − σ^X
            b.row([(yy[t, s], 1), (thy[s], 1)], lo=sy[t])
            b.row([(yy[t, s], 1), (thy[s], -1)], lo=-sy[t])
            # (7) y^X + y^Y ≤ √2 Γ/Ω (w + Ω) + M(1 − x)
            b.row([(yx[t, s], 1), (yy[t, s], 1), (w[t, s], -r2 * slope), (x[t, s], m7)], hi=r2 * reach0 + m7)
            b.row([(yx[t, s], 1), (w[t, s], -slope), (x[t, s], m8)], hi=reach0 + m8)  # (8)
            b.row([(yy[t, s], 1), (w[t, s], -slope), (x[t, s], m9)], hi=reach0 + m9)  # (9)
            b.row([(w[t, s], 1), (x[t, s], -(n - 1 - beta[t]))], hi=0)  # (11), tightened
    for s in range(m):
        _deadline_check(deadline)
        b.row([(w[t, s], 1) for t in range(nt)] + [(x[t, s], beta[t]) for t in range(nt)], hi=n - 1)  # (10)
        if s > 0:  # (12) slot s used only if slot s-1 is
            b.row([(x[t, s], 1) for t in range(nt)] + [(x[t, s - 1], -nt) for t in range(nt)], hi=0)
    pos = {t.id: i for i, t in enumerate(tasks)}
    for t2, task in enumerate(tasks):  # (13) a^{s} positions: t1 strictly before t2
        _deadline_check(deadline)
        for a in task.after:
            t1 = pos[a]
            b.row([(x[t1, s], s + 1) for s in range(m)] + [(x[t2, s], -(s + 1)) for s in range(m)], hi=-1)
    # K: robots of class k feed the tasks of type j (demanded capability set) only if τ: j ⊆ k
    classes = inst.classes()
    types = sorted({t.capabilities for t in tasks}, key=sorted)
    arcs = [(j, k) for j, k in product(range(len(types)), classes) if types[j] <= k]
    u = b.var((len(arcs), m), 0, np.inf, False)
    for s in range(m):
        _deadline_check(deadline)
        for j, tj in enumerate(types):
            terms = [(u[a, s], 1) for a, (jj, _) in enumerate(arcs) if jj == j]
            terms += [(x[t, s], -beta[t]) for t in range(nt) if tasks[t].capabilities == tj]
            b.row(terms, 0, 0)
        for k, nk in classes.items():
            b.row([(u[a, s], 1) for a, (_, kk) in enumerate(arcs) if kk == k], hi=nk)
    cols = {"x": x, "w": w, "yx": yx, "yy": yy, "z": z, "thx": thx, "thy": thy}
    if not tdsm:
        for s in range(m):
            b.cost[z[s]] = 1.0  # (4) Λ = min Σ_s z^s
        return b, cols
    gx = b.var((m,), 0, x1 - x0, False)
    gy = b.var((m,), 0, y1 - y0, False)
    cols.update(gx=gx, gy=gy)
    for s in range(m):  # G: ḡ^s ≥ |Θ^s − Θ^{s−1}|, Θ^{-1} = Θ_0 (slot 0 of S_0)
        for g, th, start in ((gx, thx, inst.start[0]), (gy, thy, inst.start[1])):
            if s == 0:
                b.row([(g[s], 1), (th[s], -1)], lo=-start)
                b.row([(g[s], 1), (th[s], 1)], lo=start)
            else:
                b.row([(g[s], 1), (th[s], -1), (th[s - 1], 1)], lo=0)
                b.row([(g[s], 1), (th[s], 1), (th[s - 1], -1)], lo=0)
        b.cost[gx[s]] = b.cost[gy[s]] = float(n)  # (14) |N| Σ (ḡ^X + ḡ^Y)
        for t in range(nt):
            b.cost[w[t, s]] = inst.gamma / inst.omega  # (14) + Σ (Γ/Ω) w
    b.row([(z[s], 1) for s in range(m)], hi=bound + 1e-7 * max(1.0, abs(bound)))  # B: Σ z ≤ Λ
    return b, cols


def _solve(inst: Instance, model: str, time_limit: float, mip_rel_gap: float | None, bound: float | None) -> Schedule:
    check_instance(inst)
    if time_limit <= 0:
        raise ValueError(f"time_limit = {time_limit!r}: must be > 0")
    t0 = time.perf_counter()
    deadline = t0 + time_limit  # one limit for building the model and solving it
    try:
        b, cols = _model(inst, model == "tdsm", bound, deadline)
        _deadline_check(deadline - 0.01)  # leave HiGHS at least 10 ms
    except ModelTimeout:
        seconds = time.perf_counter() - t0
        return Schedule(model=model, status="no_solution", seconds=round(seconds, 4), bound=bound,
                        message=f"the time limit ({time_limit:g} s) ran out while the model was being built "
                                f"(after {seconds:.2f} s)")
    res = b.solve(deadline - time.perf_counter(), mip_rel_gap)
    seconds = time.perf_counter() - t0
    if res is None:
        return Schedule(model=model, status="no_solution", seconds=round(seconds, 4), bound=bound,
                        message=f"HiGHS did not stop at the time limit ({time_limit:g} s): stopped after "
                                f"{seconds:.2f} s")
    status = {0: "optimal", 1: "time_limit", 2: "infeasible", 3: "unbounded"}.get(res.status, "error")
    out = Schedule(model=model, status=status, message=str(res.message), seconds=round(seconds, 4), bound=bound,
                   nodes=getattr(res, "mip_node_count", None))
    if res.x is None:
        if status == "time_limit":
            out.status = "no_solution"
            out.dual_bound = _finite(getattr(res, "mip_dual_bound", None))
        return out
    v = res.x
    out.objective = float(res.fun)
    out.dual_bound = _finite(getattr(res, "mip_dual_bound", None))
    out.gap = _finite(getattr(res, "mip_gap", None)) if status == "time_limit" else 0.0
    nt, m = cols["x"].shape
    out.x = [[int(round(v[cols["x"][t, s]])) for s in range(m)] for t in range(nt)]
    out.w = [[int(round(v[cols["w"][t, s]])) * out.x[t][s] for s in range(m)] for t in range(nt)]
    out.y = [[[float(v[cols["yx"][t, s]]), float(v[cols["yy"][t, s]])] for s in range(m)] for t in range(nt)]
    out.z = [float(v[cols["z"][s]]) for s in range(m)]
    out.theta = [[float(v[cols["thx"][s]]), float(v[cols["thy"][s]])] for s in range(m)]
    if "gx" in cols:
        out.gbar = [[float(v[cols["gx"][s]]), float(v[cols["gy"][s]])] for s in range(m)]
    master = None
    for s in used_slots(out):
        here = [t for t in range(nt) if out.x[t][s]]
        a = assign_robots(inst, here, {t: out.w[t][s] for t in here}, master)
        if a is None:  # cannot happen when constraint K holds; the checker reports it
            out.assignment.append({"slot": s, "master": None, "tasks": {}})
            continue
        out.assignment.append(a | {"slot": s})
        master = a["master"]
    return out


def _finite(v) -> float | None:
    return float(v) if v is not None and math.isfinite(v) else None


def assign_robots(inst: Instance, tasks: Sequence[int], arms: dict[int, int], master: int | None = None) -> dict | None:
    """Give robot ids the roles of one slot: β_t capable robots per task, a master, w_t arm robots per task.

    The task robots come from a bipartite assignment (seats x robots, a robot may take a seat only if its class
    can do the task, τ_tk = 1), preferring robots with fewer capabilities. The master stays the previous slot's
    when it is free; the arms take the remaining robots in id order; the rest are spares. None if no assignment.
    """
    seats = [t for t in tasks for _ in range(inst.tasks[t].robots)]
    n = len(inst.robots)
    big = 10.0 * (n + 1) * (max((len(c) for c in inst.robots), default=0) + 1)
    cost = np.array([[len(inst.robots[r]) + 1e-3 * (r == master) if inst.tasks[t].capabilities <= inst.robots[r]
                      else big for r in range(n)] for t in seats]).reshape(len(seats), n)
    if len(seats) > n:
        return None
    rows, cols = linear_sum_assignment(cost)
    if len(seats) and cost[rows, cols].max() >= big:
        return None
    robots = {inst.tasks[t].id: [] for t in tasks}
    for r, c in zip(rows, cols, strict=True):
        robots[inst.tasks[seats[r]].id].append(int(c))
    free = sorted(set(range(n)) - {int(c) for c in cols})
    if not free:
        return None
    master = master if master in free else free[0]
    free.remove(master)
    out = {"master": master, "tasks": {}, "spare": []}
    for t in tasks:
        k = arms.get(t, 0)
        if k > len(free):
            return None
        out["tasks"][inst.tasks[t].id] = {"robots": sorted(robots[inst.tasks[t].id]), "arm": free[:k]}
        free = free[k:]
    out["spare"] = free
    return out


def solve_tctm(inst: Instance, time_limit: float = 60.0, mip_rel_gap: float | None = None) -> Schedule:
    """TCTM: min Λ = Σ_s z^s (Eq. 4) s.t. Eqs. 5-13 and Y, R, K; returns the schedule (see Schedule)."""
    return _solve(inst, "tctm", time_limit, mip_rel_gap, None)


def solve_tdsm(inst: Instance, bound: float, time_limit: float = 60.0, mip_rel_gap: float | None = None) -> Schedule:
    """TDSM: min |N| Σ_{s∈S̄} (ḡ^X + ḡ^Y) + Σ (Γ/Ω) w (Eq. 14) s.t. the TCTM constraints, G and Σ z ≤ Λ."""
    return _solve(inst, "tdsm", time_limit, mip_rel_gap, bound)


def solve(inst: Instance, time_limit: float = 60.0,
          mip_rel_gap: float | None = None) -> tuple[Schedule, Schedule | None]:
    """TCTM then TDSM with Λ = TCTM's objective (§IV-B: the incumbent if the limit was hit); each gets the limit."""
    tctm = solve_tctm(inst, time_limit, mip_rel_gap)
    if not tctm.solved:
        return tctm, None
    return tctm, solve_tdsm(inst, completion_time(inst, tctm), time_limit, mip_rel_gap)


def completion_time(inst: Instance, sched: Schedule) -> float:
    """Σ over used slots of the longest task's δ (Eq. 5 tight): Λ of a schedule, free of solver tolerance."""
    return float(sum(max(t.duration for t, row in zip(inst.tasks, sched.x, strict=True) if row[s])
                     for s in used_slots(sched)))


def random_instance(n_robots: int, n_tasks: int, density: float, *, p_rob: float, p_tsk: float, beta_max: int,
                    delta_max: int, seed: Sequence[int] | int, n_caps: int = 2, gamma: float = 1.0,
                    omega: int = 1) -> Instance:
    """An instance drawn as in §IV-B: square arena of side L = sqrt(|N| π Γ² / D) (Eq. 15), |C| = n_caps.

    Robot n has capability c with probability p_rob, task t demands c with probability p_tsk; β_t and δ_t are
    uniform in {1..β_max} and {1..δ_max}; σ_t and Θ_0 uniform in the arena; μ = 0. A task demanding more
    capable robots than exist (the paper does not say what it did) has its capability set drawn again, up to 100
    times, then demands none; β_max is capped at |N| - 1.
    """
    rng = np.random.default_rng(seed)
    side = math.sqrt(n_robots * math.pi * gamma**2 / density)
    caps = [f"c{i + 1}" for i in range(n_caps)]
    robots = tuple(frozenset(c for c in caps if rng.random() < p_rob) for _ in range(n_robots))
    tasks = []
    for i in range(n_tasks):
        pos = (float(rng.uniform(0, side)), float(rng.uniform(0, side)))
        beta = int(rng.integers(1, min(beta_max, n_robots - 1) + 1))
        duration = int(rng.integers(1, delta_max + 1))
        for _ in range(100):
            need = frozenset(c for c in caps if rng.random() < p_tsk)
            if sum(1 for r in robots if need <= r) >= beta:
                break
        else:
            need = frozenset()
        tasks.append(Task(f"t{i}", pos, beta, float(duration), need))
    start = (float(rng.uniform(0, side)), float(rng.uniform(0, side)))
    return Instance(((0.0, side), (0.0, side)), start, robots, tuple(tasks), gamma=gamma, omega=omega)
