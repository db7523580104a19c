"""Leader-follower navigation: the paper's guarantees as oracle checks, from the trace (tests and suites only).

Truth comes from the trace's true positions and the resolved scenario (each robot's sensing range ρ_i, body
radius and behaviour parameters); what the followers claim comes from their status fields (``target``,
``mode``, ``sigma``) and the commanded velocities the world records with ``run.trace_commands = true``.
The theorem holds only while Assumptions 1–3 do: the guarantee checks are asserted up to the first tick at
which ``assumptions`` finds one broken (``where_assumed = true``, the default), and say so in their detail.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field

from swarmactors import Outcome, Result

NAME = "leader_follower"
EPS = 2e-6  # positions and commands are rounded to 6 decimals in the trace


@dataclass
class Agent:
    rid: int
    role: str  # "leader" or "follower"
    size: float
    rho: float = 0.0
    rho1: float = 0.0
    rho2: float = 0.0
    rho3: float = 0.0
    U: float = 0.0


@dataclass
class Step:
    """One tick as the checks read it: positions, targets and modes (status carried forward), claims made then."""

    t: int
    pos: dict[int, tuple[float, float]]
    target: dict[int, int]
    mode: dict[int, str]
    sigma: list[tuple[int, float]]  # (robot, σ) reported at this tick
    cmd: list[tuple[int, float]]  # (robot, ‖u‖) commanded at this tick


def gap(agents: dict[int, Agent], pos: dict[int, tuple[float, float]], i: int, j: int) -> float:
    """Distance from i's centre to the closest point of j's body (Eqs. 4–5)."""
    a, b = pos[i], pos[j]
    return math.hypot(a[0] - b[0], a[1] - b[1]) - agents[j].size


class Stream:
    """A run's ticks, streamed from its trace one at a time (what the checks read: memory O(N), not O(ticks))."""

    def __init__(self, result: Result):
        self.result = result
        self.agents = agents_of(result["scenario"])
        self.traced_commands = bool(result["scenario"]["run"].get("trace_commands"))
        self._violations: list[tuple[int, str]] | None = None

    @property
    def leader(self) -> int | None:
        return next((a.rid for a in self.agents.values() if a.role == "leader"), None)

    @property
    def followers(self) -> list[int]:
        return sorted(a.rid for a in self.agents.values() if a.role == "follower")

    def steps(self) -> Iterator[Step]:
        target: dict[int, int] = {}
        mode: dict[int, str] = {}
        for rec in self.result.records():
            t = rec["t"]
            sig = []
            for rid, fields in rec.get("status", {}).items():
                rid = int(rid)
                if "target" in fields:
                    target[rid] = int(fields["target"])
                if "mode" in fields:
                    mode[rid] = fields["mode"]
                if "sigma" in fields:
                    sig.append((rid, float(fields["sigma"])))
            yield Step(t, {row[0]: (row[1], row[2]) for row in rec.get("pos", [])},
                       {r: j for r, j in target.items() if j >= 0}, dict(mode), sig,
                       [(rid, math.hypot(*v)) for rid, *v in rec.get("cmd", [])])


@dataclass
class Run:
    """Per-tick truth and claims held in memory (for plots of small runs; the checks stream with ``Stream``)."""

    agents: dict[int, Agent]
    ticks: list[int] = field(default_factory=list)
    pos: list[dict[int, tuple[float, float]]] = field(default_factory=list)
    target: list[dict[int, int]] = field(default_factory=list)
    mode: list[dict[int, str]] = field(default_factory=list)
    sigma: list[tuple[int, int, float]] = field(default_factory=list)  # (tick, robot, σ) as reported
    cmd: list[tuple[int, int, float]] = field(default_factory=list)  # (tick, robot, ‖u‖) as commanded
    traced_commands: bool = False

    leader = Stream.leader
    followers = Stream.followers

    def gap(self, k: int, i: int, j: int) -> float:
        """Distance from i's centre to the closest point of j's body at tick index k (Eqs. 4–5)."""
        return gap(self.agents, self.pos[k], i, j)

    def steps(self) -> Iterator[Step]:
        sig: dict[int, list] = {}
        cmd: dict[int, list] = {}
        for t, rid, v in self.sigma:
            sig.setdefault(t, []).append((rid, v))
        for t, rid, u in self.cmd:
            cmd.setdefault(t, []).append((rid, u))
        for k, t in enumerate(self.ticks):
            yield Step(t, self.pos[k], self.target[k], self.mode[k], sig.get(t, []), cmd.get(t, []))


def agents_of(scenario: dict) -> dict[int, Agent]:
    """Robot id -> its role and constants, from the resolved scenario (ids in group order)."""
    out: dict[int, Agent] = {}
    rid = 0
    for g in scenario["robots"]:
        specs = [b for b in g["behaviors"] if b.get("as") == NAME]
        for _ in g["positions"]:
            size = float(g.get("body_radius") or 0.0)
            if specs and specs[0]["use"].endswith(("Leader", "lf_leader")):
                out[rid] = Agent(rid, "leader", size, U=float(specs[0].get("U", 0.2)))
            elif specs:
                b = specs[0]
                out[rid] = Agent(rid, "follower", size, float(g["sensing"]), float(b["rho1"]), float(b["rho2"]),
                                 float(b["rho3"]), float(b["U"]))
            rid += 1
    return out


def load(result: Result) -> Run:
    """Every tick in memory (status fields carried forward from their last change); cached. For plots of small runs."""
    cached = getattr(result, "_leader_follower_run", None)
    if cached is not None:
        return cached
    run = Run(agents_of(result["scenario"]), traced_commands=bool(result["scenario"]["run"].get("trace_commands")))
    for st in Stream(result).steps():
        run.ticks.append(st.t)
        run.pos.append(st.pos)
        run.target.append(st.target)
        run.mode.append(st.mode)
        run.sigma += [(st.t, rid, v) for rid, v in st.sigma]
        run.cmd += [(st.t, rid, u) for rid, u in st.cmd]
    result._leader_follower_run = run
    return run


def stream(result: Result) -> Stream:
    """The run as the checks read it, one tick at a time; cached (with its violations) on the result."""
    cached = getattr(result, "_leader_follower_stream", None)
    if cached is None:
        cached = Stream(result)
        result._leader_follower_stream = cached
    return cached


def _descendants(targets: dict[int, int], i: int) -> set[int]:
    children: dict[int, list[int]] = {}
    for a, b in targets.items():
        children.setdefault(b, []).append(a)
    out, stack = set(), [i]
    while stack:
        for c in children.get(stack.pop(), []):
            if c not in out:
                out.add(c)
                stack.append(c)
    return out


def violations(run: Run | Stream) -> list[tuple[int, str]]:
    """(tick, what) for every tick at which Assumption 1, 2 or 3 fails, in tick order (one pass over the ticks)."""
    if isinstance(run, Stream) and run._violations is not None:
        return run._violations
    out: list[tuple[int, str]] = []
    lead = run.leader
    fol = run.followers
    agents = run.agents
    prev: Step | None = None
    for st in run.steps():
        if prev is None:
            if lead is not None and fol and agents[lead].U > min(agents[f].U for f in fol) + 1e-12:
                out.append((st.t, f"Assumption 2: leader U {agents[lead].U} > min U_i "
                                  f"{min(agents[f].U for f in fol)}"))
            for i in fol:
                a = agents[i]
                gaps = [gap(agents, st.pos, i, j) for j in st.pos if j != i]
                if any(g <= a.rho2 for g in gaps) or not any(a.rho2 < g < a.rho1 for g in gaps):
                    out.append((st.t, f"Assumption 1: follower {i} at t = 0 has no agent in S' \\ S'' "
                                      f"or one in S''"))
            prev = st
            continue
        t = st.t
        started = [i for i in fol if st.mode.get(i) == "switch" and prev.mode.get(i) != "switch"]
        if len(started) > 1:
            out.append((t, f"Assumption 3: followers {started} start switching at once"))
        for i in started:
            new = st.target.get(i)
            if new is not None and new in _descendants(prev.target, i):
                out.append((t, f"Assumption 3: follower {i}'s new target {new} is its descendant"))
            elif new is not None and new != lead and new not in prev.target:
                out.append((t, f"Assumption 3: follower {i}'s new target {new} has no target yet (not LSC)"))
        for i in fol:
            if st.mode.get(i) != "switch" or i in started:
                continue
            tgt = st.target.get(i)
            inside = [j for j in st.pos if j not in (i, tgt) and i in st.pos
                      and gap(agents, st.pos, i, j) < agents[i].rho2 - EPS]
            if inside:
                out.append((t, f"Assumption 3: agent(s) {inside} inside S''_{i} during its switch"))
        prev = st
    out.sort(key=lambda x: x[0])
    if isinstance(run, Stream):
        run._violations = out
    return out


def _ends(run: Run | Stream) -> tuple[int | None, int | None]:
    """The first and last ticks of the run."""
    if isinstance(run, Run):
        return (run.ticks[0], run.ticks[-1]) if run.ticks else (None, None)
    ticks = run.result.ticks()
    return (int(ticks[0]), int(ticks[-1])) if len(ticks) else (None, None)


def _limit(run: Run | Stream, where_assumed: bool) -> tuple[int, str]:
    """The last tick the guarantees are asserted at, and the words saying why."""
    first, last = _ends(run)
    if not where_assumed:
        return last if last is not None else 0, ""
    found = violations(run) if first is not None else []
    v = [x for x in found if x[0] > first]
    pre = [x for x in found if x[0] == first]
    if pre:
        return -1, f"; not asserted: {pre[0][1]}"
    if v:
        return v[0][0] - 1, f"; asserted up to tick {v[0][0] - 1} (then {v[0][1]})"
    return last if last is not None else 0, ""


def assumptions(result: Result) -> Outcome:
    """Assumptions 1–3 held at every tick (Assumption 1 at t = 0, 2 from the parameters, 3 at every switch)."""
    v = violations(stream(result))
    detail = f"{len(v)} violation(s); first: tick {v[0][0]}: {v[0][1]}" if v else "held"
    return Outcome("leader_follower.assumptions", not v, len(v), 0, detail, v[0][0] if v else None, op="<=")


def spanning_tree(result: Result, where_assumed: bool = True, require_all: bool = True) -> Outcome:
    """Theorem 4.5: the reported targets form a tree rooted at the leader, each edge true (closest point ≤ ρ_i).

    With ``require_all``, every follower has a target by the last tick.
    """
    run = stream(result)
    last, why = _limit(run, where_assumed)
    lead, bad, first = run.leader, 0, None
    final: dict[int, int] | None = None
    for st in run.steps():
        final = st.target
        if st.t > last:
            continue  # read on: the last tick's targets are judged below
        tg = st.target
        wrong = ""
        for i, j in tg.items():
            if j not in st.pos or i not in st.pos:
                wrong = f"follower {i}'s target {j} is not alive"
            elif gap(run.agents, st.pos, i, j) > run.agents[i].rho + EPS:
                wrong = (f"follower {i}'s target {j} is {gap(run.agents, st.pos, i, j):.4f} away, "
                         f"beyond rho {run.agents[i].rho}")
            else:
                seen, x = {i}, j
                while x != lead and x in tg and x not in seen:
                    seen.add(x)
                    x = tg[x]
                if x != lead:
                    wrong = f"follower {i}'s target chain {sorted(seen)} does not reach the leader {lead}"
            if wrong:
                break
        if wrong:
            bad += 1
            first = first if first is not None else (st.t, wrong)
    missing = [i for i in run.followers if final is not None and i not in final] if require_all else []
    ok = bad == 0 and not missing
    detail = (f"{bad} tick(s) without a tree" + (f"; first at tick {first[0]}: {first[1]}" if first else "")
              + (f"; followers without a target at the end: {missing}" if missing else "") + why)
    return Outcome("leader_follower.spanning_tree", ok, bad, 0, detail, first[0] if first else None, op="<=")


def margins(run: Run | Stream) -> dict[str, float]:
    """Worst margins over the run: r − ρ‴, ρ − r (target distance) and min distance − size (bodies)."""
    lo = hi = body = math.inf
    agents = run.agents
    for st in run.steps():
        for i, j in st.target.items():
            if i in st.pos and j in st.pos:
                g = gap(agents, st.pos, i, j)
                lo, hi = min(lo, g - agents[i].rho3), min(hi, agents[i].rho - g)
        for i in run.followers:
            if i in st.pos:
                body = min([body] + [gap(agents, st.pos, i, j) - agents[i].size for j in st.pos if j != i])
    return {"target_low": lo, "target_high": hi, "body": body}


def target_distance(result: Result, where_assumed: bool = True) -> Outcome:
    """Lemmas 4.1 and 4.3: ρ‴_i < r_i < ρ_i for every follower with a target (r to its closest point)."""
    run = stream(result)
    last, why = _limit(run, where_assumed)
    bad, first, worst = 0, None, math.inf
    for st in run.steps():
        if st.t > last:
            break
        for i, j in st.target.items():
            if i not in st.pos or j not in st.pos:
                continue
            a, g = run.agents[i], gap(run.agents, st.pos, i, j)
            worst = min(worst, g - a.rho3, a.rho - g)
            if not a.rho3 - EPS < g < a.rho + EPS:
                bad += 1
                if first is None:
                    first = (st.t, f"follower {i} is {g:.4f} from target {j}'s closest point, outside "
                                   f"({a.rho3}, {a.rho})")
    detail = (f"worst margin {worst:.4f}" if worst < math.inf else "no follower had a target") + (
        f"; first breach at tick {first[0]}: {first[1]}" if first else "") + why
    return Outcome("leader_follower.target_distance", bad == 0, bad, 0, detail,
                   first[0] if first else None, op="<=")


def speed(result: Result, where_assumed: bool = True) -> Outcome:
    """Eq. 2 and Lemmas 4.2, 4.4: ‖u_i‖ ≤ U_i as commanded (before the world's cap); the leader's ≤ its U."""
    run = stream(result)
    if not run.traced_commands:
        return Outcome("leader_follower.speed", False, None, None,
                       "the trace has no commanded velocities: set run.trace_commands = true")
    last, why = _limit(run, where_assumed)
    bad, first, top = 0, None, 0.0
    for st in run.steps():
        if st.t > last:
            break
        for rid, u in st.cmd:
            a = run.agents.get(rid)
            if a is None:
                continue
            if a.role == "follower":
                top = max(top, u / a.U)
            if u > a.U + EPS:
                bad += 1
                first = first or (st.t, f"robot {rid} commanded {u:.6f} > U {a.U}")
    detail = (f"largest follower ‖u_i‖/U_i {top:.4f}" + (f"; first at tick {first[0]}: {first[1]}" if first else "")
              + why)
    return Outcome("leader_follower.speed", bad == 0, bad, 0, detail, first[0] if first else None,
                   op="<=")


def sigma(result: Result) -> Outcome:
    """§3.4: σ_i ∈ [−1, 1] at every tick."""
    out = [(st.t, r, s) for st in stream(result).steps() for r, s in st.sigma if not -1.0 <= s <= 1.0]
    detail = f"{len(out)} value(s) outside [-1, 1]" + (f"; first: robot {out[0][1]} at tick {out[0][0]}: "
                                                        f"{out[0][2]}" if out else "")
    return Outcome("leader_follower.sigma", not out, len(out), 0, detail, out[0][0] if out else None, op="<=")
