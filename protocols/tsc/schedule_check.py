"""Independent check of a TCTM/TDSM schedule: every constraint recomputed from the variables.

Reads the plain JSON forms (``Instance.to_dict()``, ``Schedule.to_dict()``) and imports nothing from the
solver module, so a bug in the model builder cannot hide here. Where the solver encodes a rule one way, this
checks it another: capability coverage by Hall's condition over the task types instead of a flow, the arm
length from Θ directly (not only from y), the slots' order from the slot indices instead of Eq. 12's
aggregate form, and the objective recomputed from the variables.
"""

from __future__ import annotations

import math
from itertools import combinations

__all__ = ["check_schedule", "euclidean_excess"]

SCALE = {"paper": 1.0, "inscribed": math.cos(math.pi / 8)}


def check_schedule(instance: dict, schedule: dict, tol: float = 1e-6) -> list[str]:
    """Return every violated constraint of ``schedule`` on ``instance`` as a sentence (empty: feasible).

    Args:
        instance: ``Instance.to_dict()``.
        schedule: ``Schedule.to_dict()`` of a solved model (``tctm`` or ``tdsm``).
        tol: absolute tolerance; for lengths it is scaled by the arena's |·|₁ diameter (twice its larger side),
            the largest big-M of Eqs. 7-9: a solver accepts a binary x within its integrality tolerance (HiGHS:
            1e-6) of 1, which leaves a big-M row up to M·1e-6 of slack (seen: 3.4e-5 on a 25 m arena).
    """
    bad: list[str] = []
    tasks, robots = instance["tasks"], [set(r) for r in instance["robots"]]
    n, nt = len(robots), len(tasks)
    (x0, x1), (y0, y1) = instance["arena"]["x"], instance["arena"]["y"]
    gamma, omega = instance["gamma"], instance["omega"]
    g = SCALE[instance.get("arms", "paper")] * gamma
    ltol = tol * max(1.0, 2 * (x1 - x0), 2 * (y1 - y0))
    x, w, y, z, th = schedule["x"], schedule["w"], schedule["y"], schedule["z"], schedule["theta"]
    m = len(z)
    if len(x) != nt or any(len(r) != m for r in x) or len(w) != nt or len(th) != m:
        return [f"variables have the wrong shape for {nt} tasks and {m} slots"]
    if m > nt or (instance.get("max_slots") and m > instance["max_slots"]):
        bad.append(f"{m} slots, more than |S| allows")
    for t in range(nt):
        for s in range(m):
            if x[t][s] not in (0, 1):
                bad.append(f"x[{t}][{s}] = {x[t][s]} is not binary")
            if not (isinstance(w[t][s], int) and w[t][s] >= 0):
                bad.append(f"w[{t}][{s}] = {w[t][s]} is not a non-negative integer")
            if min(y[t][s]) < -ltol:
                bad.append(f"y[{t}][{s}] = {y[t][s]} is negative")
    if bad:
        return bad
    slot = {}
    for t, task in enumerate(tasks):
        if sum(x[t]) != 1:  # (6)
            bad.append(f"(6) task {task['id']} is in {sum(x[t])} slots")
        else:
            slot[t] = x[t].index(1)
    for s in range(m):
        if z[s] < -tol:
            bad.append(f"z[{s}] = {z[s]} < 0")
        if not (x0 - ltol <= th[s][0] <= x1 + ltol and y0 - ltol <= th[s][1] <= y1 + ltol):
            bad.append(f"(R) deployment point of slot {s} {th[s]} is outside the arena")
    for t, s in slot.items():
        task = tasks[t]
        if z[s] < task["duration"] - tol:  # (5)
            bad.append(f"(5) slot {s} lasts {z[s]} < δ = {task['duration']} of task {task['id']}")
    for t, task in enumerate(tasks):
        for s in range(m):
            dx, dy = abs(task["position"][0] - th[s][0]), abs(task["position"][1] - th[s][1])
            if y[t][s][0] < dx - ltol or y[t][s][1] < dy - ltol:  # (Y)
                bad.append(f"(Y) y[{task['id']}][{s}] = {y[t][s]} below |σ - Θ| = {[dx, dy]}")
            if x[t][s]:
                reach = g * (w[t][s] + omega) / omega
                if y[t][s][0] + y[t][s][1] > math.sqrt(2) * reach + ltol:
                    bad.append(f"(7) task {task['id']} slot {s}: y^X + y^Y = {sum(y[t][s]):.6g} > √2·{reach:.6g}")
                if max(y[t][s]) > reach + ltol:
                    bad.append(f"(8-9) task {task['id']} slot {s}: y = {y[t][s]} beyond {reach:.6g}")
                if max(dx, dy, (dx + dy) / math.sqrt(2)) > reach + ltol:
                    bad.append(f"arm of task {task['id']} in slot {s}: {w[t][s]} robots do not reach from Θ")
            if w[t][s] > (n - 1) * x[t][s]:  # (11)
                bad.append(f"(11) w[{task['id']}][{s}] = {w[t][s]} on an inactive task")
    for s in range(m):
        here = [t for t in slot if slot[t] == s]
        used = sum(w[t][s] for t in range(nt)) + sum(tasks[t]["robots"] for t in here)
        if used > n - 1:  # (10)
            bad.append(f"(10) slot {s} needs {used} robots + the master > |N| = {n}")
        bad += [f"(K) slot {s}: {msg}" for msg in _hall(tasks, robots, here)]
    used_slots = sorted(set(slot.values()))
    if used_slots != list(range(len(used_slots))):  # (12)
        bad.append(f"(12) used slots {used_slots} are not the first ones")
    ids = {task["id"]: t for t, task in enumerate(tasks)}
    for t2, task in enumerate(tasks):  # (13)
        for a in task.get("after", []):
            t1 = ids[a]
            if t1 in slot and t2 in slot and not slot[t1] < slot[t2]:
                bad.append(f"(13) task {a} (slot {slot[t1]}) must come before {task['id']} (slot {slot[t2]})")
    bad += _objective(instance, schedule, slot, used_slots, tol, ltol)
    bad += _assignment(tasks, robots, schedule, slot)
    return bad


def _hall(tasks: list[dict], robots: list[set], here: list[int]) -> list[str]:
    """Hall's condition: for every set J of demand types, the demand of J ≤ the robots able to serve some type in J."""
    demand: dict[frozenset, int] = {}
    for t in here:
        key = frozenset(tasks[t]["capabilities"])
        demand[key] = demand.get(key, 0) + tasks[t]["robots"]
    types, out = list(demand), []
    for size in range(1, len(types) + 1):
        for group in combinations(types, size):
            need = sum(demand[j] for j in group)
            able = sum(1 for r in robots if any(j <= r for j in group))
            if need > able:
                out.append(f"tasks demanding {[sorted(j) for j in group]} need {need} robots, {able} can")
    return out


def _objective(instance: dict, schedule: dict, slot: dict, used: list[int], tol: float, ltol: float) -> list[str]:
    bad, z, w = [], schedule["z"], schedule["w"]
    obj = schedule.get("objective")
    if schedule["model"] == "tctm":
        value = sum(z)
    else:
        gbar, th, start = schedule.get("gbar"), schedule["theta"], instance["start"]
        if gbar is None or len(gbar) != len(z):
            return ["TDSM schedule without ḡ"]
        prev = start
        for s in range(len(z)):  # (G) ḡ^s ≥ |Θ^s − Θ^{s−1}|, slot -1 being the start Θ_0
            if gbar[s][0] < abs(th[s][0] - prev[0]) - ltol or gbar[s][1] < abs(th[s][1] - prev[1]) - ltol:
                bad.append(f"(G) ḡ of slot {s} = {gbar[s]} below the move {th[s]} - {prev}")
            prev = th[s]
        bound = schedule.get("bound")
        total = sum(max(instance["tasks"][t]["duration"] for t in slot if slot[t] == s) for s in used)
        if bound is not None and total > bound + tol * max(1.0, bound):  # (B)
            bad.append(f"(B) completion time {total} exceeds Λ = {bound}")
        if bound is not None and sum(z) > bound + tol * max(1.0, bound):
            bad.append(f"(B) Σ z = {sum(z)} exceeds Λ = {bound}")
        value = len(instance["robots"]) * sum(a + b for a, b in gbar)
        value += instance["gamma"] / instance["omega"] * sum(map(sum, w))
    if obj is not None and abs(obj - value) > 1e-5 * max(1.0, abs(value)):
        bad.append(f"objective {obj} differs from the recomputed {value}")
    return bad


def _assignment(tasks: list[dict], robots: list[set], schedule: dict, slot: dict) -> list[str]:
    bad = []
    by_slot = {a["slot"]: a for a in schedule.get("assignment", [])}
    for s in sorted(set(slot.values())):
        a = by_slot.get(s)
        if a is None or a.get("master") is None:
            bad.append(f"slot {s} has no robot assignment")
            continue
        seen = [a["master"]]
        for t in (t for t in slot if slot[t] == s):
            got = a["tasks"].get(tasks[t]["id"])
            if got is None:
                bad.append(f"slot {s}: task {tasks[t]['id']} has no robots")
                continue
            if len(got["robots"]) != tasks[t]["robots"]:
                bad.append(f"slot {s}: task {tasks[t]['id']} got {len(got['robots'])} robots, β = {tasks[t]['robots']}")
            if len(got["arm"]) != schedule["w"][t][s]:
                bad.append(f"slot {s}: arm of {tasks[t]['id']} has {len(got['arm'])} robots, w = {schedule['w'][t][s]}")
            for r in got["robots"]:
                if not set(tasks[t]["capabilities"]) <= robots[r]:
                    bad.append(f"slot {s}: robot {r} lacks a capability task {tasks[t]['id']} demands")
            seen += got["robots"] + got["arm"]
        if len(seen) != len(set(seen)) or not all(0 <= r < len(robots) for r in seen):
            bad.append(f"slot {s}: a robot has two roles, or an id does not exist")
    return bad


def euclidean_excess(instance: dict, schedule: dict) -> float:
    """Largest ratio of the true (Euclidean) distance Θ-σ to the reach Γ(w + Ω)/Ω of the arm, over active arms.

    Above 1 means an arm longer than its robots can span at range Γ: the paper's octagon (Eqs. 7-9) admits up
    to 1/cos(π/8) = 1.082; ``arms = "inscribed"`` keeps it ≤ 1.
    """
    worst = 0.0
    for t, task in enumerate(instance["tasks"]):
        for s, on in enumerate(schedule["x"][t]):
            if on:
                d = math.dist(task["position"], schedule["theta"][s])
                reach = instance["gamma"] * (schedule["w"][t][s] + instance["omega"]) / instance["omega"]
                worst = max(worst, d / reach)
    return worst
