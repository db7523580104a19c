"""``swarmactors schedule TASKS.toml``: Panerati et al. (2018)'s Task Scheduling Controller (TCTM, TDSM) on HiGHS.

Reads robots and tasks (format: docs/protocols/tsc.md), solves TCTM (Eq. 4) then TDSM (Eq. 14) with a time
limit each, checks every returned schedule with ``protocols.tsc.schedule_check``, and writes
``OUT/schedule.json``, ``OUT/schedule.png`` (like the paper's Fig. 6) and, with ``--secs``, the task subsets as
a sequence for a SECS scenario.

Exit codes, as the rest of the command line: 0 a schedule was found and passed the check (also when the time
limit was hit: the MIP gap is printed); 1 a schedule failed the independent check; 2 bad input (the message
names the file, the key and the value; nothing is solved); 3 no schedule found within the time limit.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import stat
import sys
import tomllib
from pathlib import Path

from swarmactors.exitcodes import EXIT_CHECK, EXIT_INPUT, EXIT_OK, EXIT_RUNTIME

__all__ = ["InputError", "add_parser", "command", "load_instance"]

DEFAULT_TIME_LIMIT = 60.0
MAX_FILE_BYTES = 1 << 20  # a TASKS.toml at the task bound (protocols.tsc.schedule.MAX_TASKS) is ~20 kB


class InputError(ValueError):
    """Bad schedule input; the message names the file, the key and the value."""

    def __init__(self, source: str, key: str, value, message: str):
        shown = "" if value is _MISSING else f" = {value!r}"
        super().__init__(f"{source}: {key}{shown}: {message}")


_MISSING = object()


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Register ``schedule`` on the command line's subparsers; the handler is ``command``."""
    sp = subparsers.add_parser("schedule", help="task scheduling (Panerati et al., ICRA 2018: the TCTM/TDSM MILPs): "
                                                "slots, arms, deployment points as JSON and a plot")
    sp.add_argument("tasks", type=Path, help="robots and tasks TOML file (see docs/protocols/tsc.md)")
    sp.add_argument("--time-limit", type=float, metavar="S",
                    help=f"seconds per model (default: solver.time_limit, else {DEFAULT_TIME_LIMIT:g})")
    sp.add_argument("--model", choices=["tctm", "tdsm"],
                    help="tctm: only the completion time; tdsm: TCTM then TDSM (default: solver.model, else tdsm)")
    sp.add_argument("--arms", choices=["paper", "inscribed"],
                    help="arm-length pieces of Eqs. 7-9: the paper's (corners 8%% beyond the range) or inscribed")
    sp.add_argument("--out", type=Path, help="output directory (default out/schedule-<file stem>)")
    sp.add_argument("--secs", type=Path, metavar="OUT.toml",
                    help="also write the task subsets as a sequence for a SECS scenario")
    sp.add_argument("--no-plot", action="store_true", help="do not write schedule.png")
    sp.add_argument("--json", action="store_true", help="print the summary as JSON on stdout")
    sp.set_defaults(handler=command)
    return sp


def command(args) -> int:
    """Run ``swarmactors schedule``; returns the exit code."""
    from protocols.tsc import schedule as tsc

    try:
        inst, opts = load_instance(args.tasks)
        if args.arms:
            inst = _replace(inst, arms=args.arms)
        limit = args.time_limit if args.time_limit is not None else opts.get("time_limit", DEFAULT_TIME_LIMIT)
        if not (isinstance(limit, (int, float)) and math.isfinite(limit) and limit > 0):
            raise InputError(str(args.tasks), "--time-limit" if args.time_limit is not None else "solver.time_limit",
                             limit, "must be a number of seconds > 0")
        model = args.model or opts.get("model", "tdsm")
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    src = str(args.tasks)
    with _stdout_to_stderr():  # HiGHS prints stray lines on fd 1; keep stdout for --json
        tctm = tsc.solve_tctm(inst, limit)
        tdsm = None
        if tctm.solved and model == "tdsm":
            tdsm = tsc.solve_tdsm(inst, tsc.completion_time(inst, tctm), limit)
    if tctm.status == "infeasible":
        key = "solver.max_slots" if inst.max_slots else "tasks"
        print(f"error: {src}: {key} = {inst.max_slots if inst.max_slots else len(inst.tasks)!r}: "
              f"no schedule exists (HiGHS: {tctm.message})", file=sys.stderr)
        return EXIT_INPUT
    if not tctm.solved:
        print(f"error: {src}: TCTM found no schedule within {limit:g} s ({tctm.status}: {tctm.message}); "
              f"raise --time-limit", file=sys.stderr)
        return EXIT_RUNTIME
    out = args.out or Path("out") / f"schedule-{args.tasks.stem}"
    report = _report(inst, src, tctm, tdsm, limit)
    best = tdsm if tdsm is not None and tdsm.solved else tctm
    try:
        out.mkdir(parents=True, exist_ok=True)
        (out / "schedule.json").write_text(json.dumps(report, indent=1))
        files = [out / "schedule.json"]
        if not args.no_plot:
            from protocols.tsc.schedule_plot import save_schedule_figure

            files.append(save_schedule_figure(inst, tctm, tdsm if tdsm and tdsm.solved else None,
                                              out / "schedule.png"))
        if args.secs:
            args.secs.parent.mkdir(parents=True, exist_ok=True)
            args.secs.write_text(secs_sequence(inst, best, src))
            files.append(args.secs)
    except OSError as exc:
        print(f"error: cannot write the schedule: {exc}", file=sys.stderr)
        return EXIT_RUNTIME
    if args.json:
        print(json.dumps({k: v for k, v in report.items() if k != "input"} | {"files": [str(f) for f in files]}))
    else:
        _print_summary(report, files)
    if tdsm is not None and not tdsm.solved:
        print(f"warning: TDSM found no schedule within {limit:g} s; the TCTM schedule is the one written",
              file=sys.stderr)
    failed = [f"{m}: {v}" for m in ("tctm", "tdsm") if report.get(m) for v in report[m]["violations"]]
    if failed:
        print("error: a schedule failed the independent check:\n  " + "\n  ".join(failed), file=sys.stderr)
        return EXIT_CHECK
    return EXIT_OK


def _report(inst, src: str, tctm, tdsm, limit: float) -> dict:
    from protocols.tsc.schedule import arm_cost, completion_time, dislocation, used_slots
    from protocols.tsc.schedule_check import check_schedule, euclidean_excess

    rep = {"source": src, "time_limit": limit, "input": inst.to_dict()}
    for sched in (tctm, tdsm):
        if sched is None:
            continue
        d = sched.to_dict()
        if sched.solved:
            d["violations"] = check_schedule(rep["input"], d)
            d["metrics"] = {
                "completion_time": completion_time(inst, sched),
                "slots_used": len(used_slots(sched)),
                "dislocation": dislocation(inst, sched),
                "arm_cost": arm_cost(inst, sched),
                "arm_cost_tight": arm_cost(inst, sched, tight=True),
                "arm_excess": euclidean_excess(rep["input"], d),
            }
        else:
            d["violations"] = []
        rep[sched.model] = d
    return rep


def _print_summary(rep: dict, files: list[Path]) -> None:
    for m in ("tctm", "tdsm"):
        d = rep.get(m)
        if d is None:
            continue
        line = f"{m.upper()}  {d['status']:<11} {d['seconds']:8.2f} s"
        if d["status"] in ("optimal", "time_limit"):
            mt = d["metrics"]
            line += (f"  objective {d['objective']:.6g}  Λ = {mt['completion_time']:g} in {mt['slots_used']} slots"
                     f"  dislocation {mt['dislocation']:.4g}  arm cost {mt['arm_cost']:.4g}")
            if d["status"] == "time_limit":
                gap = d["gap"]
                line += f"  (time limit: MIP gap {gap:.1%}, bound {d['dual_bound']})" if gap is not None else ""
        print(line)
    print("wrote " + ", ".join(str(f) for f in files))


def secs_sequence(inst, sched, source: str) -> str:
    """The task subsets in slot order, as the BMU of §III-C hands them to the navigation controller (TOML).

    Per slot: flock to ``deployment``, erupt one prominence per task, rendez-vous after ``duration``; the
    master robot stays at the deployment point (the SC task), ``robots`` perform the task, ``arm`` are the
    backbone robots suggested for its prominence (``arm_size`` = w_t), ``spare`` robots belong to no arm.
    """
    from protocols.tsc.schedule import used_slots

    slots = []
    by_slot = {a["slot"]: a for a in sched.assignment}
    for k, s in enumerate(used_slots(sched)):
        a = by_slot[s]
        tasks = []
        for t, task in enumerate(inst.tasks):
            if sched.x[t][s]:
                got = a["tasks"][task.id]
                tasks.append({"id": task.id, "position": list(task.position), "robots": got["robots"],
                              "arm": got["arm"], "arm_size": sched.w[t][s]})
        slots.append({"index": k + 1, "deployment": [round(v, 6) for v in sched.theta[s]],
                      "duration": max(inst.tasks[t].duration for t in range(len(inst.tasks)) if sched.x[t][s]),
                      "master": a["master"], "spare": a["spare"], "tasks": tasks})
    head = ("# Task subsets for the SECS navigation controller (Panerati et al. §III-C: the BMU's input), written by\n"
            "# `swarmactors schedule`. For each slot in order: flock to `deployment`, erupt one prominence per task,\n"
            "# rendez-vous around `master` after `duration`. Robot ids are 0..N-1 in the order of the [[robots]]\n"
            "# groups of the input, as a scenario's [[robots]] groups number them.\n")
    lines = [f"{k} = {_toml(v)}" for k, v in (("source", source), ("model", sched.model), ("gamma", inst.gamma),
                                              ("omega", inst.omega), ("start", list(inst.start)),
                                              ("robots", len(inst.robots)))]
    for slot in slots:
        lines += ["", "[[slots]]"] + [f"{k} = {_toml(v)}" for k, v in slot.items() if k != "tasks"]
        for task in slot["tasks"]:
            lines += ["", "[[slots.tasks]]"] + [f"{k} = {_toml(v)}" for k, v in task.items()]
    return head + "\n".join(lines) + "\n"


def _toml(v) -> str:
    """A TOML value on one line (strings, numbers, flat lists): the sequence stays readable."""
    if isinstance(v, list):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return json.dumps(v)  # a TOML basic string: JSON's escapes are TOML's
    return repr(v)


@contextlib.contextmanager
def _stdout_to_stderr():
    try:
        sys.stdout.flush()
        saved = os.dup(1)
    except (OSError, ValueError, AttributeError):  # no real fd 1 (e.g. captured): nothing to protect
        yield
        return
    try:
        os.dup2(2, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


def _replace(inst, **changes):
    import dataclasses

    return dataclasses.replace(inst, **changes)


# --- input -------------------------------------------------------------------------------------------------

_TOP = {"arena", "swarm", "robots", "tasks", "solver"}
_ARENA = {"x", "y"}
_SWARM = {"start", "gamma", "omega"}
_GROUP = {"count", "capabilities"}
_TASK = {"id", "position", "robots", "duration", "capabilities", "after"}
_SOLVER = {"time_limit", "max_slots", "arms", "model"}
# check_instance's keys -> the input's keys
_KEYMAP = {"start": "swarm.start", "gamma": "swarm.gamma", "omega": "swarm.omega", "arms": "solver.arms",
           "max_slots": "solver.max_slots", "arena": "arena"}


def load_instance(path: Path):
    """Read a TASKS.toml into an ``Instance`` and the ``[solver]`` options; raise InputError naming the key."""
    from protocols.tsc.schedule import MAX_ROBOTS, MAX_TASKS, Instance, InstanceError, Task, check_instance

    src = str(path)
    try:
        st = Path(path).stat()
        if not stat.S_ISREG(st.st_mode):
            raise InputError(src, "file", _MISSING, "not a regular file")
        if st.st_size > MAX_FILE_BYTES:
            raise InputError(src, "file", _MISSING, f"{st.st_size:,} bytes, more than the {MAX_FILE_BYTES >> 20} MiB "
                                                    "a tasks file may have")
        raw = tomllib.loads(Path(path).read_text())
    except OSError as exc:
        raise InputError(src, "file", _MISSING, f"cannot read: {exc.strerror or exc}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(src, "file", _MISSING, f"not valid TOML: {exc}") from None
    _keys(src, "", raw, _TOP)
    arena = _table(src, "arena", raw.get("arena"), required=True)
    _keys(src, "arena.", arena, _ARENA)
    ax = _pair(src, "arena.x", arena.get("x", _MISSING))
    ay = _pair(src, "arena.y", arena.get("y", _MISSING))
    swarm = _table(src, "swarm", raw.get("swarm"), required=True)
    _keys(src, "swarm.", swarm, _SWARM)
    start = _pair(src, "swarm.start", swarm.get("start", _MISSING))
    gamma = _number(src, "swarm.gamma", swarm.get("gamma", 1.0), positive=True)
    omega = _int(src, "swarm.omega", swarm.get("omega", 1), minimum=1)
    groups = raw.get("robots", _MISSING)
    if groups is _MISSING:
        raise InputError(src, "robots", _MISSING, "missing: give at least one [[robots]] group")
    if not isinstance(groups, list) or not groups:
        raise InputError(src, "robots", groups, "must be a non-empty array of tables [[robots]]")
    robots: list[frozenset[str]] = []
    for i, g in enumerate(groups):
        where = f"robots[{i}]"
        g = _table(src, where, g, required=True)
        _keys(src, where + ".", g, _GROUP)
        count = _int(src, where + ".count", g.get("count", _MISSING), minimum=1)
        if len(robots) + count > MAX_ROBOTS:  # before the list is built
            raise InputError(src, where + ".count", count, f"brings the swarm to {len(robots) + count:,} robots, "
                                                          f"more than the {MAX_ROBOTS} a schedule may have")
        caps = frozenset(_strings(src, where + ".capabilities", g.get("capabilities", [])))
        robots += [caps] * count
    items = raw.get("tasks", _MISSING)
    if items is _MISSING:
        raise InputError(src, "tasks", _MISSING, "missing: give at least one [[tasks]] entry")
    if not isinstance(items, list) or not items:
        raise InputError(src, "tasks", items, "must be a non-empty array of tables [[tasks]]")
    if len(items) > MAX_TASKS:
        raise InputError(src, "tasks", _MISSING, f"{len(items):,} tasks, more than the {MAX_TASKS} a schedule may have")
    tasks = []
    for i, t in enumerate(items):
        where = f"tasks[{i}]"
        t = _table(src, where, t, required=True)
        _keys(src, where + ".", t, _TASK)
        tid = t.get("id", f"t{i}")
        if not isinstance(tid, str) or not tid:
            raise InputError(src, where + ".id", tid, "must be a non-empty string")
        tasks.append(Task(tid, _pair(src, where + ".position", t.get("position", _MISSING)),
                          _int(src, where + ".robots", t.get("robots", 1), minimum=1),
                          float(_number(src, where + ".duration", t.get("duration", 1.0), positive=True)),
                          frozenset(_strings(src, where + ".capabilities", t.get("capabilities", []))),
                          tuple(_strings(src, where + ".after", t.get("after", [])))))
    solver = _table(src, "solver", raw.get("solver", {}), required=False)
    _keys(src, "solver.", solver, _SOLVER)
    opts = {}
    if "time_limit" in solver:
        opts["time_limit"] = float(_number(src, "solver.time_limit", solver["time_limit"], positive=True))
    if "model" in solver:
        opts["model"] = _choice(src, "solver.model", solver["model"], ("tctm", "tdsm"))
    arms = _choice(src, "solver.arms", solver.get("arms", "paper"), ("paper", "inscribed"))
    max_slots = _int(src, "solver.max_slots", solver["max_slots"], minimum=1) if "max_slots" in solver else None
    inst = Instance((ax, ay), start, tuple(robots), tuple(tasks), gamma=float(gamma), omega=omega,
                    max_slots=max_slots, arms=arms)
    try:
        check_instance(inst)
    except InstanceError as exc:
        raise InputError(src, _KEYMAP.get(exc.key, exc.key), exc.value, exc.reason) from None
    return inst, opts


def _keys(src: str, prefix: str, table: dict, allowed: set[str]) -> None:
    for k in table:
        if k not in allowed:
            raise InputError(src, prefix + k, table[k], f"unknown key (allowed: {', '.join(sorted(allowed))})")


def _table(src: str, key: str, value, required: bool) -> dict:
    if value is None and required:
        raise InputError(src, key, _MISSING, "missing")
    if not isinstance(value, dict):
        raise InputError(src, key, value, "must be a table")
    return value


def _number(src: str, key: str, value, positive: bool = False) -> float:
    if value is _MISSING:
        raise InputError(src, key, _MISSING, "missing")
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(src, key, value, "must be a finite number")
    if positive and value <= 0:
        raise InputError(src, key, value, "must be > 0")
    return value


def _int(src: str, key: str, value, minimum: int) -> int:
    if value is _MISSING:
        raise InputError(src, key, _MISSING, "missing")
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(src, key, value, "must be an integer")
    if value < minimum:
        raise InputError(src, key, value, f"must be >= {minimum}")
    return value


def _pair(src: str, key: str, value) -> tuple[float, float]:
    if value is _MISSING:
        raise InputError(src, key, _MISSING, "missing")
    if not isinstance(value, list) or len(value) != 2:
        raise InputError(src, key, value, "must be a list of two numbers")
    return (float(_number(src, key, value[0])), float(_number(src, key, value[1])))


def _strings(src: str, key: str, value) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
        raise InputError(src, key, value, "must be a list of non-empty strings")
    return value


def _choice(src: str, key: str, value, options: tuple[str, ...]) -> str:
    if value not in options:
        raise InputError(src, key, value, f"must be one of {', '.join(options)}")
    return value
