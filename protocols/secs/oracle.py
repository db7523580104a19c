"""Oracle checks of the SECS navigation controller (seed 003 §III-B), from the trace's true positions.

- ``secs.connected``: the swarm's radio graph is connected at every tick (design table: "the swarm stays
  connected at every tick while prominences reach the tasks").
- ``secs.reach``: every task (world object ``task*``) has a backbone robot within ``tol`` m by the end;
  value: the latency in seconds of the last task reached.
- ``secs.angle``: ∠T of each aligned robot, turned into the world frame, against the true direction from
  the master to its arm's task; value: the largest error (rad).
- ``secs.slots``: in a run driven by the master's schedule (§III-C), every task of every slot is reached
  during its own slot's eruption; ``slot_times`` gives per slot when each task was reached and how regrouped
  the swarm was.

Collisions are ``world.no_collisions`` (10 cm bodies).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse.csgraph import connected_components
from scipy.spatial.distance import cdist

from swarmactors.oracle.checks import Outcome
from swarmactors.oracle.result import Result


def _tasks(result: Result, prefix: str = "task") -> list[tuple[str, np.ndarray]]:
    objs = result["scenario"]["world"].get("objects", [])
    return sorted((o["name"], np.array(o["pos"], dtype=float)) for o in objs if o["name"].startswith(prefix))


def _master(result: Result) -> int:
    return int(result.behavior_params("secs").get("master", 0))


def _pos(rec: dict) -> tuple[list[int], np.ndarray]:
    rows = rec.get("pos", [])
    return [int(r[0]) for r in rows], np.array([r[1:3] for r in rows], dtype=float).reshape(-1, 2)


def connected_ticks(result: Result) -> tuple[int, int | None, int]:
    """(ticks checked, first disconnected tick or None, disconnected ticks)."""
    ranges = result.ranges()
    first, bad, n = None, 0, 0
    for rec in result.records():
        ids, pos = _pos(rec)
        n += 1
        if len(ids) < 2:
            continue
        r = np.array([ranges[i] for i in ids])
        d = cdist(pos, pos)
        adj = (d <= r[:, None]) & (d <= r[None, :])
        k, _ = connected_components(adj, directed=False)
        if k > 1:
            bad += 1
            first = rec["t"] if first is None else first
    return n, first, bad


def connected(result: Result) -> Outcome:
    """The whole swarm is one component of the true radio graph at every tick of the trace."""
    n, first, bad = connected_ticks(result)
    return Outcome("secs.connected", bad == 0, bad, 0, f"{bad} of {n} ticks disconnected", first, op="<=")


def reach_times(result: Result, tol: float = 0.5) -> dict[str, float | None]:
    """For each task: the first time (s) a backbone robot is within ``tol`` m of it, or None."""
    master, dt = _master(result), float(result["scenario"]["run"]["dt"])
    tasks = _tasks(result)
    out: dict[str, float | None] = {name: None for name, _ in tasks}
    for rec in result.records():
        ids, pos = _pos(rec)
        keep = [k for k, i in enumerate(ids) if i != master]
        if not keep:
            continue
        for name, p in tasks:
            if out[name] is None and np.min(np.linalg.norm(pos[keep] - p, axis=1)) <= tol:
                out[name] = round(rec["t"] * dt, 6)
    return out


def max_reach(result: Result) -> dict[str, float]:
    """For each task: the farthest a backbone robot got along the master → task direction (m)."""
    master = _master(result)
    ids0, pos0 = _pos(result.first_record())
    origin = pos0[ids0.index(master)]
    tasks = _tasks(result)
    best = {name: 0.0 for name, _ in tasks}
    towards = {name: (p - origin) / np.linalg.norm(p - origin) for name, p in tasks}
    for rec in result.records():
        ids, pos = _pos(rec)
        for name, u in towards.items():
            proj = (pos - origin) @ u
            proj[[k for k, i in enumerate(ids) if i == master]] = 0.0
            best[name] = max(best[name], float(proj.max()))
    return best


def reach(result: Result, tol: float = 0.5) -> Outcome:
    """Every task has a backbone robot within ``tol`` m of it at some tick."""
    times = reach_times(result, tol)
    missed = sorted(k for k, v in times.items() if v is None)
    latest = max((v for v in times.values() if v is not None), default=None)
    detail = f"missed: {missed}" if missed else f"reached at {times} s"
    return Outcome("secs.reach", not missed and bool(times), latest, None, detail)


def heading_offset(odo: list, start: np.ndarray, now: np.ndarray) -> float | None:
    """The robot's frame offset from its odometry and its true displacement (None if it barely moved)."""
    true = now - start
    if np.linalg.norm(true) < 0.05 or math.hypot(*odo) < 0.05:
        return None
    return math.atan2(true[1], true[0]) - math.atan2(odo[1], odo[0])


def angle_errors(result: Result) -> dict[int, float]:
    """{robot: |∠T error|} of the robots aligned at the end, against master → task in the world frame."""
    reports = result.reports("secs")
    master = _master(result)
    tasks = _tasks(result)
    ids0, pos0 = _pos(result.first_record())
    start = dict(zip(ids0, pos0, strict=True))
    out = {}
    recs = {}
    for rid, rep in reports.items():
        if rid == master or not rep.get("aligned") or rep.get("target") is None or rep.get("arm") is None:
            continue
        if rep["at"] not in recs:
            recs[rep["at"]] = dict(zip(*_pos(result.record(rep["at"])), strict=True))
        now = recs[rep["at"]]
        off = heading_offset(rep["odo"], start[rid], now[rid])
        if off is None or master not in now:
            continue
        task = tasks[rep["arm"]][1]
        truth = math.atan2(task[1] - now[master][1], task[0] - now[master][0])
        err = (rep["target"] + off - truth + math.pi) % (2 * math.pi) - math.pi
        out[rid] = abs(err)
    return out


def angle(result: Result, bound: float = 0.05) -> Outcome:
    """Every aligned robot's ∠T, in the world frame, is within ``bound`` rad of master → its task."""
    errs = angle_errors(result)
    worst = max(errs.values(), default=0.0)
    return Outcome("secs.angle", bool(errs) and worst <= bound, round(worst, 6), bound,
                   f"{len(errs)} aligned robots judged", op="<=")


def schedule_of(result: Result) -> dict | None:
    """The ``schedule`` parameter of the master's ``secs`` behaviour (the TSC's task subsets), or None."""
    for g in result["scenario"]["robots"]:
        for spec in g["behaviors"]:
            if spec.get("as") == "secs" and spec.get("schedule"):
                return spec["schedule"]
    return None


def slot_times(result: Result, tol: float = 0.5) -> list[dict]:
    """Per slot of a scheduled run (§III-C), from the master's stage log and the true positions.

    Each slot: ``start``/``end`` (s) of its eruption (from the master's switch to "secs" to its rendez-vous,
    or the end of the run), ``reached`` {task id: seconds after ``start`` when a backbone robot first came
    within ``tol`` m of it in that window, or None}, and ``spread``: the largest distance of a robot from the
    master when the eruption began (the swarm regrouped: at most the master's range).
    """
    sch, master = schedule_of(result), _master(result)
    dt = float(result["scenario"]["run"]["dt"])
    stages = result.reports("secs").get(master, {}).get("stages") or []
    starts = {slot: tick for tick, slot, stage in stages if stage == "secs"}
    ends = {slot: tick for tick, slot, stage in stages if stage == "rendezvous"}
    out, wins = [], []
    for k, slot in enumerate((sch or {}).get("slots", []), start=1):
        row = {"slot": k, "start": None, "end": None, "spread": None,
               "reached": {str(t.get("id", i)): None for i, t in enumerate(slot["tasks"])}}
        if k in starts:
            row["start"] = round(starts[k] * dt, 6)
            row["end"] = round(ends[k] * dt, 6) if k in ends else None
            wins.append((starts[k], ends.get(k, math.inf), row, [np.array(t["position"], dtype=float)
                                                                 for t in slot["tasks"]]))
        out.append(row)
    for rec in result.records():
        ids, pos = _pos(rec)
        if master not in ids:
            continue
        at_master = pos[ids.index(master)]
        back = pos[[k for k, i in enumerate(ids) if i != master]]
        for a, b, row, tasks in wins:
            if rec["t"] == a:
                row["spread"] = round(float(np.max(np.linalg.norm(pos - at_master, axis=1))), 3)
            if not a <= rec["t"] < b or not len(back):
                continue
            for name, p in zip(row["reached"], tasks, strict=True):
                if row["reached"][name] is None and np.min(np.linalg.norm(back - p, axis=1)) <= tol:
                    row["reached"][name] = round((rec["t"] - a) * dt, 6)
    return out


def slots(result: Result, tol: float = 0.5) -> Outcome:
    """Every task of every slot of the master's schedule is reached during its own slot's eruption."""
    rows = slot_times(result, tol)
    missed = [f"{r['slot']}:{t}" for r in rows for t, v in r["reached"].items() if v is None]
    detail = "; ".join(f"slot {r['slot']} from {r['start']} s (spread {r['spread']} m): "
                       + ", ".join(f"{t} {v} s" for t, v in r["reached"].items()) for r in rows)
    return Outcome("secs.slots", bool(rows) and not missed, len(missed), 0,
                   (f"missed {missed}; " if missed else "") + (detail or "no schedule"), op="<=")
