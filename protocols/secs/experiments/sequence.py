"""The TSC-driven SECS sequence (seed 003 §III-C) on §IV-B instances: flock → erupt → rendez-vous, per slot.

Each instance is drawn as in §IV-B (``protocols.tsc.schedule.random_instance``: square arena of side
L = √(|N| π Γ² / D), Eq. 15; tasks with a position, a team size β_t, a duration δ_t and capabilities; Γ = Ω = 1;
μ = 0) with the small classes of the TSC experiments (``QUICK``: |N| = 8, |T| = 4, classes 1 and 5, the paper
prints no class sizes) at the paper's densest D = 0.5. It is scheduled as in §IV-B: TCTM, then TDSM bounded
by TCTM's Λ (HiGHS). The TDSM's slots become the master robot's ``schedule`` (``protocols.secs.scenarios
.sequence_scenario``) and the swarm runs as emulator actors (lockstep, the world decides range): the master,
the BMU of §III-C, leads the flock to Θ^s, erupts one prominence per task of slot s, holds it, calls the
rendez-vous, and so on, by messages only; no robot reads the schedule but the master, nor the oracle.

Choices where the paper is silent (docs/protocols/secs.md, "TSC-driven sequence"):

- **Units.** One Γ is ``SCALE`` = 1.5 m (half the 3 m radio range: our SECS arms are files at δ = 2.4 m beyond a
  core of robots kept within the master's range, and reach less than the MILP's Γ(w + 1)); one duration unit
  is ``TIME_UNIT`` = 30 s. The paper gives no time windows: a task's window is its slot.
- **The eruption's margin.** The master cannot see when a prominence reaches its task (backbone robots know
  directions, not positions), so it holds each eruption for ``MARGIN`` = 60 s (our Table I latencies to 5√2 m
  are 25-50 s) plus the slot's Δ_s. A task is **covered on time** when, inside its slot's eruption, a backbone
  robot stays within ``TOL`` = 0.5 m of it for an unbroken δ_t × ``TIME_UNIT`` seconds.
- **Flocking** at 0.1 m/s (the master's ``flock_speed``); the other parameters are the controller's defaults.

The audit (``audit``, outside the robots) takes the world's true positions at every tick of the trace: the
radio graph (networkx, range 3 m both ways) must be connected and hold a path from every robot to the master
(the base, SC) at every tick; per task, when it was first reached and its longest unbroken cover. Makespan:
from the start to the end of the last slot's eruption, beside the TSC's planned Λ × ``TIME_UNIT``; the excess
is split into the flights, the rendez-vous and the margins, read from the master's stage log.

    python -m protocols.secs.experiments.sequence [--instances 1:0,1:1,1:2,5:0,5:2] [--variants base,hold]
        [--margin 60] [--out JSON] [--img PNG] [--runs DIR]

Variants: ``base`` is the controller's defaults; ``hold`` its opt-in ``hold_tasks`` (the master also floods each
task's distance and an aligned robot stops there, rules.hold_velocity). One seed per run (``--seed``).

The paper's §IV-B reports the MILP alone (Table II: solve times; Figs. 7-8: costs), not a schedule executed by
the controller, so the only §IV-B numbers to set beside ours are Table II's solve times for the same class at
D = 0.5; the execution is judged against the TSC's own plan.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import os
import tempfile
import time
import tomllib
from collections.abc import Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
DENSITY = 0.5
INSTANCES = ((1, 0), (1, 1), (1, 2), (5, 0), (5, 2))  # (class, index) of protocols.tsc's QUICK classes at D = 0.5
SCALE = 1.5  # m per Γ
TIME_UNIT = 30.0  # s per duration unit
MARGIN = 60.0  # s added to each eruption: the prominences' latency
FLOCK_SPEED = 0.1  # m/s
TOL = 0.5  # m: a task is covered while a backbone robot is this close
RANGE = 3.0  # m: the radio range of the §IV-A set-up
TOLERANCE = 0.25  # a measured value is "within" at ±25 % of the compared one
VARIANTS = {"base": {}, "hold": {"hold_tasks": True}}  # the controller's defaults; its opt-in task hold
PAPER_TABLE2_D05 = {1: (0.8, 44.3), 5: (9.0, 31.6)}  # Table II, D = 0.5: (TCTM, TDSM) seconds, CPLEX 12.7


# ------------------------------------------------------------------------------------------ pure rules
def with_margin(sequence: dict, margin_units: float) -> dict:
    """A copy of a sequence (``swarmactors schedule --secs``) whose slots last ``margin_units`` longer.

    The slot's planned duration Δ_s is kept as ``planned``; ``duration`` (what the master holds the eruption
    for) becomes Δ_s + margin. Refuses a negative or non-finite margin.
    """
    if not (isinstance(margin_units, (int, float)) and math.isfinite(margin_units) and margin_units >= 0):
        raise ValueError(f"margin must be a finite number >= 0, got {margin_units!r}")
    out = copy.deepcopy(sequence)
    for slot in out["slots"]:
        slot["planned"] = float(slot["duration"])
        slot["duration"] = float(slot["duration"]) + float(margin_units)
    return out


def longest_run(covered: Sequence[bool]) -> tuple[int, int | None]:
    """(length, start index) of the longest unbroken run of True in ``covered``; (0, None) if none."""
    best, best_at, run, at = 0, None, 0, None
    for k, c in enumerate(covered):
        if c:
            if run == 0:
                at = k
            run += 1
            if run > best:
                best, best_at = run, at
        else:
            run = 0
    return best, best_at


def phase_times(stages: Sequence[Sequence], dt: float, end_tick: int) -> list[dict]:
    """Per slot, seconds spent flocking, erupting and in the rendez-vous, from the master's stage log.

    ``stages`` is [[tick, slot (1-based), stage], ...] in order (``SECS.report()["stages"]``); a stage lasts
    until the next entry, the last one until ``end_tick``. Each row also has the eruption's start and end (s).
    """
    rows: dict[int, dict] = {}
    for k, (tick, slot, stage) in enumerate(stages):
        nxt = stages[k + 1][0] if k + 1 < len(stages) else end_tick
        row = rows.setdefault(int(slot), {"slot": int(slot), "flocking": 0.0, "secs": 0.0, "rendezvous": 0.0,
                                          "erupt_start": None, "erupt_end": None})
        if stage not in ("flocking", "secs", "rendezvous"):
            raise ValueError(f"stage log entry {k}: unknown stage {stage!r}")
        row[stage] += round((nxt - tick) * dt, 6)
        if stage == "secs":
            row["erupt_start"] = round(tick * dt, 6)
            row["erupt_end"] = round(nxt * dt, 6) if k + 1 < len(stages) else None
    return [rows[s] for s in sorted(rows)]


def makespan_split(phases: list[dict], planned: float, margin: float) -> dict:
    """The measured makespan (end of the last eruption) against the TSC's planned Λ, and what the excess is.

    Flights and rendez-vous before the last eruption are counted; ``margin`` is the time added per eruption.
    None for the makespan if the last eruption did not end within the run.
    """
    end = phases[-1]["erupt_end"] if phases else None
    flights = sum(p["flocking"] for p in phases)
    gathers = sum(p["rendezvous"] for p in phases[:-1])
    out = {"makespan": end, "planned": planned, "flights": round(flights, 3), "rendezvous": round(gathers, 3),
           "margins": round(margin * len(phases), 3)}
    out["ratio"] = None if end is None or planned <= 0 else round(end / planned, 3)
    return out


# ------------------------------------------------------------------------------------------ the TSC
def tsc_sequence(cls: int, idx: int, density: float = DENSITY, time_limit: float = 60.0):
    """Instance ``idx`` of cell (class, D) of the TSC experiments, solved TCTM then TDSM; (inst, seq, tctm, tdsm)."""
    from protocols.tsc.experiments.tsc_experiments import QUICK, instance
    from protocols.tsc.schedule import solve
    from protocols.tsc.schedule_cli import secs_sequence

    if cls not in QUICK:
        raise ValueError(f"class {cls!r}: must be one of {sorted(QUICK)}")
    inst = instance(QUICK, cls, density, idx)
    tctm, tdsm = solve(inst, time_limit)
    sched = tdsm if tdsm is not None and tdsm.solved else tctm
    if not sched.solved:
        raise RuntimeError(f"class {cls} instance {idx}: no schedule ({tctm.status})")
    seq = tomllib.loads(secs_sequence(inst, sched, f"class {cls}, D = {density}, instance {idx}"))
    return inst, seq, tctm, tdsm


# ------------------------------------------------------------------------------------------ the oracle
def audit(result, needs: dict[str, float], tol: float = TOL) -> dict:
    """Connectivity to the base at every tick and each task's cover, from the world's true positions.

    The radio graph joins two robots within ``RANGE`` m of each other (networkx); "connected" means one
    component holding the master. Per task (the master's schedule, world metres): first reach after its
    eruption began, longest unbroken cover inside the eruption (s) and when it began, total cover (s), and on
    time (longest unbroken cover ≥ ``needs[id]`` s).
    """
    import networkx as nx
    import numpy as np

    from protocols.secs import oracle

    dt = float(result["scenario"]["run"]["dt"])
    master = 0
    sch = oracle.schedule_of(result)
    stages = result.reports("secs").get(master, {}).get("stages") or []
    end_tick = int(result.last_tick())
    phases = phase_times(stages, dt, end_tick + 1)
    windows = {p["slot"]: (round(p["erupt_start"] / dt), end_tick + 1 if p["erupt_end"] is None
                           else round(p["erupt_end"] / dt)) for p in phases if p["erupt_start"] is not None}
    tasks = [(k + 1, str(t["id"]), np.array(t["position"], dtype=float), float(needs[str(t["id"])]))
             for k, slot in enumerate(sch["slots"]) for t in slot["tasks"]]
    covered: dict[str, list[bool]] = {name: [] for _, name, _, _ in tasks}
    first: dict[str, float | None] = {name: None for _, name, _, _ in tasks}
    bad, first_bad, n = 0, None, 0
    for rec in result.records():
        t = int(rec["t"])
        ids, pos = oracle._pos(rec)
        n += 1
        g = nx.Graph()
        g.add_nodes_from(ids)
        d = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=2)
        g.add_edges_from((ids[a], ids[b]) for a, b in zip(*np.nonzero(np.triu(d <= RANGE, 1)), strict=True))
        if master not in g or not nx.is_connected(g):
            bad += 1
            first_bad = t if first_bad is None else first_bad
        back = pos[[k for k, i in enumerate(ids) if i != master]]
        for slot, name, p, _ in tasks:
            a, b = windows.get(slot, (None, None))
            if a is None or not a <= t < b:
                continue
            c = bool(len(back)) and float(np.min(np.linalg.norm(back - p, axis=1))) <= tol
            covered[name].append(c)
            if c and first[name] is None:
                first[name] = round((t - a) * dt, 3)
    rows = []
    for slot, name, _, need in tasks:
        length, at = longest_run(covered[name])
        hold = round(length * dt, 3)
        a = windows.get(slot, (None,))[0]
        rows.append({"task": name, "slot": slot, "need": need, "first_reach": first[name], "hold": hold,
                     "hold_from": None if at is None else round((a + at) * dt, 3),
                     "covered": round(sum(covered[name]) * dt, 3), "on_time": hold + 1e-9 >= need})
    return {"ticks": n, "disconnected": bad, "first_disconnected": first_bad, "tasks": rows, "phases": phases}


# ------------------------------------------------------------------------------------------ one instance
def run_instance(cls: int, idx: int, *, seed: int = 1, scale: float = SCALE, time_unit: float = TIME_UNIT,
                 margin: float = MARGIN, flock_speed: float = FLOCK_SPEED, time_limit: float = 60.0,
                 seconds: float | None = None, out: Path | None = None, variant: str = "base") -> dict:
    """Schedule one §IV-B instance, run it through the emulator, audit it: the record the JSON keeps.

    ``variant`` "base" is the controller's defaults; "hold" turns on its opt-in ``hold_tasks`` (the master
    floods each task's distance, an aligned robot stops there: rules.hold_velocity).
    """
    if variant not in VARIANTS:
        raise ValueError(f"variant {variant!r}: must be one of {sorted(VARIANTS)}")
    import swarmactors
    from protocols.secs import oracle
    from protocols.secs.scenarios import sequence_scenario
    from protocols.tsc.schedule import completion_time

    inst, seq, tctm, tdsm = tsc_sequence(cls, idx, time_limit=time_limit)
    planned = completion_time(inst, tdsm if tdsm is not None and tdsm.solved else tctm) * time_unit
    needs = {t.id: t.duration * time_unit for t in inst.tasks}  # δ_t in seconds: the oracle's, not a robot's
    run_seq = with_margin(seq, margin / time_unit)
    sc = sequence_scenario(run_seq, scale=scale, time_unit=time_unit, flock_speed=flock_speed, seed=seed,
                           seconds=seconds, name=f"secs-seq-c{cls}-i{idx}", **VARIANTS[variant])
    t0 = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        result = swarmactors.run(sc, out=Path(out or tmp) / f"c{cls}-i{idx}-{variant}")
        wall = time.time() - t0
        rep = audit(result, needs)
        spread = [row["spread"] for row in oracle.slot_times(result)]
        checks = {c["name"]: {"passed": c["passed"], "value": c.get("value")} for c in result.checks}
        paths = _paths(result)
    split = makespan_split(rep["phases"], planned, margin)
    rec = {"class": cls, "index": idx, "variant": variant, "density": DENSITY, "seed": seed, "robots": len(inst.robots),
           "tasks": len(inst.tasks), "side_m": round(inst.arena[0][1] * scale, 3), "scale": scale,
           "time_unit": time_unit, "margin": margin, "flock_speed": flock_speed,
           "tctm": {"status": tctm.status, "seconds": round(tctm.seconds, 3)},
           "tdsm": None if tdsm is None else {"status": tdsm.status, "seconds": round(tdsm.seconds, 3)},
           "paper_table2": PAPER_TABLE2_D05.get(cls),
           "slots": [{"deployment": s["deployment"], "planned": s["planned"] * time_unit,
                      "tasks": [t["id"] for t in s["tasks"]]} for s in run_seq["slots"]],
           "task_distance_m": {t["id"]: round(math.dist(s["deployment"], t["position"]) * scale, 3)
                               for s in run_seq["slots"] for t in s["tasks"]},
           "wall_s": round(wall, 1), "spread_m": spread, "checks": checks, "audit": rep, "makespan": split,
           "paths": paths,
           "schedule": sc["robots"][0]["behaviors"][0]["schedule"]}
    rec["verdict"] = verdict(rec)
    return rec


def _paths(result, every: int = 20) -> dict:
    """Every ``every``-th tick's true position of each robot, for the plot: {id: [[t, x, y], ...]}."""
    from protocols.secs import oracle

    out: dict[str, list] = {}
    for rec in result.records():
        if int(rec["t"]) % every:
            continue
        ids, pos = oracle._pos(rec)
        for i, p in zip(ids, pos, strict=True):
            out.setdefault(str(i), []).append([int(rec["t"]), round(float(p[0]), 3), round(float(p[1]), 3)])
    return out


def verdict(rec: dict) -> dict:
    """Per instance: covered on time and connected (the paper's claim, §III-B), makespan against the plan."""
    rep, split = rec["audit"], rec["makespan"]
    missed = [t["task"] for t in rep["tasks"] if not t["on_time"]]
    out = {"connected": rep["disconnected"] == 0, "covered_on_time": not missed, "missed": missed}
    if split["makespan"] is None:
        out["makespan"] = "not within: the last eruption did not end within the run"
    elif split["ratio"] is not None and abs(split["ratio"] - 1) <= TOLERANCE:
        out["makespan"] = f"within ±{TOLERANCE:.0%} of the TSC's Λ"
    else:
        out["makespan"] = (f"not within: {split['ratio']}× the TSC's Λ; the MILP counts task durations only, the "
                           f"run adds flights {split['flights']} s, rendez-vous {split['rendezvous']} s, "
                           f"eruption margins {split['margins']} s")
    paper = rec.get("paper_table2")
    if paper and rec["tdsm"]:
        out["solve_vs_table2"] = (f"TCTM {rec['tctm']['seconds']} s vs {paper[0]} s, TDSM {rec['tdsm']['seconds']} s "
                                  f"vs {paper[1]} s (|N| = {rec['robots']}, |T| = {rec['tasks']} here; the paper's "
                                  "sizes are unprinted and larger; not comparable)")
    return out


# ------------------------------------------------------------------------------------------ plot
def plot(records: list[dict], path: Path) -> None:
    """Top: each instance's true paths, tasks and deployment points; bottom: its phases and each task's cover."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = list(dict.fromkeys((r["class"], r["index"]) for r in records))
    variants = list(dict.fromkeys(r["variant"] for r in records))
    by = {(r["class"], r["index"], r["variant"]): r for r in records}
    n = len(keys)
    fig, axes = plt.subplots(1 + len(variants), n, figsize=(4.2 * n, 5.2 + 2.0 * len(variants)), squeeze=False,
                             gridspec_kw={"height_ratios": [3] + [1.4] * len(variants)})
    colours = {"flocking": "#8da0cb", "secs": "#fc8d62", "rendezvous": "#66c2a5"}
    for k, key in enumerate(keys):
        rec = by.get((*key, variants[-1])) or next(r for r in records if (r["class"], r["index"]) == key)
        _paths_panel(axes[0][k], rec)
        for v, name in enumerate(variants, start=1):
            if (*key, name) in by:
                _timeline_panel(axes[v][k], by[(*key, name)], colours)
            else:
                axes[v][k].set_axis_off()
    handles = [plt.Rectangle((0, 0), 1, 1, color=c) for c in colours.values()]
    fig.legend(handles, ["flock", "erupt (Δ + margin)", "rendez-vous"], loc="lower center", ncol=3, fontsize=8)
    fig.suptitle("TSC-driven SECS sequence on §IV-B instances (D = 0.5, |N| = 8, |T| = 4). Top: true paths "
                 f"({variants[-1]}); below: phases and task cover per variant (dark: longest unbroken cover, red: "
                 "short of δ_t)", fontsize=9)
    fig.tight_layout(rect=(0, 0.03, 1, 0.97))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _paths_panel(ax, rec: dict) -> None:
    for rid, pts in rec["paths"].items():
        xs, ys = [p[1] for p in pts], [p[2] for p in pts]
        ax.plot(xs, ys, lw=1.6 if rid == "0" else 0.6, color="k" if rid == "0" else "0.6", zorder=2 if rid == "0"
                else 1)
    for s, slot in enumerate(rec["schedule"]["slots"], start=1):
        dx, dy = slot["deployment"]
        ax.plot(dx, dy, "s", color="C%d" % s, ms=8, zorder=3)
        ax.annotate(f"Θ{s}", (dx, dy), xytext=(4, 4), textcoords="offset points", fontsize=8)
        for t in slot["tasks"]:
            ok = next(r["on_time"] for r in rec["audit"]["tasks"] if r["task"] == t["id"])
            ax.plot(*t["position"], "o" if ok else "x", color="C%d" % s, ms=9, mfc="none", mew=2, zorder=3)
            ax.annotate(t["id"], t["position"], xytext=(4, -10), textcoords="offset points", fontsize=8)
    ax.set_aspect("equal")
    v = rec["verdict"]
    ax.set_title(f"class {rec['class']} #{rec['index']}: {'connected' if v['connected'] else 'DISCONNECTED'}, "
                 f"{sum(r['on_time'] for r in rec['audit']['tasks'])}/{len(rec['audit']['tasks'])} on time",
                 fontsize=9)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def _timeline_panel(tl, rec: dict, colours: dict) -> None:
    t0 = 0.0
    for p in rec["audit"]["phases"]:
        for stage in ("flocking", "secs", "rendezvous"):
            if p[stage] > 0:
                tl.barh(0, p[stage], left=t0, color=colours[stage], edgecolor="k", lw=0.3)
                t0 += p[stage]
    for j, r in enumerate(rec["audit"]["tasks"], start=1):
        p = rec["audit"]["phases"][r["slot"] - 1]
        if r["first_reach"] is not None and p["erupt_start"] is not None:
            a = p["erupt_start"] + r["first_reach"]
            b = p["erupt_end"] if p["erupt_end"] is not None else t0
            tl.barh(j, b - a, left=a, color="0.75")
            tl.barh(j, r["hold"], left=r["hold_from"], color="0.3" if r["on_time"] else "r", height=0.4)
    tl.axvline(rec["makespan"]["planned"], color="k", ls="--", lw=1)
    tl.set_yticks(range(len(rec["audit"]["tasks"]) + 1),
                  ["phase"] + [r["task"] for r in rec["audit"]["tasks"]], fontsize=8)
    tl.set_xlabel("time (s); dashed: the TSC's Λ")
    on = sum(r["on_time"] for r in rec["audit"]["tasks"])
    tl.set_title(f"{rec['variant']}: {on}/{len(rec['audit']['tasks'])} on time, makespan "
                 f"{rec['makespan']['makespan']} s", fontsize=8)


# ------------------------------------------------------------------------------------------ CLI
def _pairs(text: str) -> list[tuple[int, int]]:
    out = []
    for part in text.split(","):
        try:
            c, i = part.split(":")
            out.append((int(c), int(i)))
        except ValueError:
            raise argparse.ArgumentTypeError(f"--instances: {part!r} must be CLASS:INDEX, e.g. 1:0") from None
        if out[-1][1] < 0:
            raise argparse.ArgumentTypeError(f"--instances: index in {part!r} must be >= 0")
    return out


def main(argv: list[str] | None = None) -> int:
    """Run the instances, write the JSON after each, draw the plot; print one line per instance."""
    ap = argparse.ArgumentParser(prog="python -m protocols.secs.experiments.sequence",
                                 description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--instances", type=_pairs, default=list(INSTANCES),
                    help="CLASS:INDEX,... (default 1:0,1:1,1:2,5:0,5:2)")
    ap.add_argument("--variants", default="base,hold", help="base (defaults) and/or hold (hold_tasks), comma-separated")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--scale", type=float, default=SCALE, help="metres per Γ")
    ap.add_argument("--time-unit", type=float, default=TIME_UNIT, help="seconds per duration unit")
    ap.add_argument("--margin", type=float, default=MARGIN, help="seconds added to each eruption")
    ap.add_argument("--flock-speed", type=float, default=FLOCK_SPEED)
    ap.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "sequence.json")
    ap.add_argument("--img", type=Path, default=ROOT / "docs" / "img" / "secs_sequence.png")
    ap.add_argument("--runs", type=Path, default=None, help="keep each run's output under this directory")
    args = ap.parse_args(argv)
    for key in ("scale", "time_unit", "flock_speed"):
        v = getattr(args, key)
        if not (math.isfinite(v) and v > 0):
            ap.error(f"--{key.replace('_', '-')} = {v!r}: must be a positive number")
    if not (math.isfinite(args.margin) and args.margin >= 0):
        ap.error(f"--margin = {args.margin!r}: must be a number >= 0")
    variants = args.variants.split(",")
    bad = [v for v in variants if v not in VARIANTS]
    if bad:
        ap.error(f"--variants: {bad[0]!r} is not one of {sorted(VARIANTS)}")
    records = []
    for (cls, idx), variant in [(ci, v) for ci in args.instances for v in variants]:
        rec = run_instance(cls, idx, seed=args.seed, scale=args.scale, time_unit=args.time_unit,
                           margin=args.margin, flock_speed=args.flock_speed, variant=variant, out=args.runs)
        rec["load"] = [round(x, 2) for x in os.getloadavg()]
        records.append(rec)
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps({"records": records}) + "\n")
        m, v = rec["makespan"], rec["verdict"]
        print(f"class {cls} #{idx} {variant}: connected {v['connected']}, on time "
              f"{sum(t['on_time'] for t in rec['audit']['tasks'])}/{len(rec['audit']['tasks'])}, makespan "
              f"{m['makespan']} s vs Λ {m['planned']} s, wall {rec['wall_s']} s, load {rec['load']}", flush=True)
    plot(records, args.img)
    print(f"wrote {args.out} and {args.img}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
