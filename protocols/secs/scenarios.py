"""Scenarios of the ARGoS set-up of §IV-A: 30 m × 30 m arena, 10 cm robots at 0.15 m/s, 3 m radio range.

Robot 0 is the master at the origin, with global sensing (it alone knows the tasks: world objects ``task*``
known by it only; the core hands ``ctx.objects`` in world coordinates, so a robot in its own frame could not
use them). The N backbone robots sense in their own frame (``sensing_frame = "local"``) and start in a
compact hexagonal cluster round the master, 0.4 m apart (the swarm after a rendez-vous).
"""

from __future__ import annotations

import math


def cluster(n: int, spacing: float = 0.4) -> list[list[float]]:
    """The n hexagonal-lattice points nearest the origin, the origin itself excluded, sorted by distance."""
    pts = []
    k = int(math.ceil(math.sqrt(n))) + 2
    for a in range(-k, k + 1):
        for b in range(-k, k + 1):
            x, y = spacing * (a + b / 2), spacing * b * math.sqrt(3) / 2
            if (a, b) != (0, 0):
                pts.append((round(math.hypot(x, y), 9), round(math.atan2(y, x), 9), round(x, 6), round(y, 6)))
    pts.sort()
    return [[x, y] for _, _, x, y in pts[:n]]


def tasks_at(distance: float, count: int = 1, first: float = math.pi / 4) -> list[dict]:
    """``count`` tasks at ``distance`` from the master, evenly spread in angle from ``first``."""
    out = []
    for k in range(count):
        a = first + 2 * math.pi * k / count
        out.append({"name": f"task{k}", "pos": [round(distance * math.cos(a), 6), round(distance * math.sin(a), 6)],
                    "known_by": [0]})
    return out


def secs_scenario(n: int, distance: float, *, tasks: int = 1, delta: float = 240.0, seconds: float = 200.0,
                  seed: int = 1, name: str = "secs", loss: float = 0.0, bearing_noise: float = 0.0,
                  range_noise: float = 0.0, checks: list | None = None, clock: str = "lockstep",
                  **params) -> dict:
    """N backbone robots plus the master, ``tasks`` tasks at ``distance`` m, run for ``seconds``.

    dt = 0.1 s, ARGoS's 10 ticks per second.
    """
    beh = {"use": "secs", "delta": delta, **params}
    common = {"range": 3.0, "speed": 0.15, "body_radius": 0.05, "behaviors": [beh]}
    backbone = {"positions": cluster(n), "sensing_frame": "local", **common}
    if bearing_noise or range_noise:
        backbone.update(bearing_noise=bearing_noise, range_noise=range_noise)
    radio = {"range": 3.0, "latency": 1, "loss": loss}
    if clock == "realtime":  # frames arrive within half a tick, after at least a fifth
        radio.update(latency_s=0.05, latency_min_s=0.02)
    return {
        "run": {"name": name, "seed": seed, "clock": clock, "dt": 0.1, "ticks": int(round(seconds / 0.1))},
        "radio": radio,
        "world": {"bounds": [[-15.0, -15.0], [15.0, 15.0]], "objects": tasks_at(distance, tasks)},
        "robots": [{"positions": [[0.0, 0.0]], **common}, backbone],
        "checks": checks if checks is not None else [
            {"use": "secs.connected"}, {"use": "secs.reach"}, {"use": "world.no_collisions"}],
    }


class SequenceError(ValueError):
    """A SECS sequence file (``swarmactors schedule --secs``) that cannot drive a scenario."""


def read_sequence(path) -> dict:
    """The TOML sequence written by ``swarmactors schedule --secs``; SequenceError names the file and key."""
    import tomllib
    from pathlib import Path

    try:
        seq = tomllib.loads(Path(path).read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise SequenceError(f"{path}: {exc}") from None
    _check_sequence(seq, str(path))
    return seq


def _check_sequence(seq: dict, source: str) -> None:
    def point(v) -> bool:
        return isinstance(v, list) and len(v) == 2 and all(isinstance(x, (int, float)) and math.isfinite(x)
                                                           for x in v)

    if not point(seq.get("start")):
        raise SequenceError(f"{source}: start = {seq.get('start')!r}: must be [x, y]")
    if not (isinstance(seq.get("robots"), int) and seq["robots"] >= 2):
        raise SequenceError(f"{source}: robots = {seq.get('robots')!r}: must be an integer >= 2")
    gamma = seq.get("gamma", 1.0)
    if not (isinstance(gamma, (int, float)) and gamma > 0):
        raise SequenceError(f"{source}: gamma = {gamma!r}: must be a positive number")
    if not isinstance(seq.get("slots"), list) or not seq["slots"]:
        raise SequenceError(f"{source}: slots: no [[slots]] table")
    for k, slot in enumerate(seq["slots"]):
        if not point(slot.get("deployment")):
            raise SequenceError(f"{source}: slots[{k}].deployment = {slot.get('deployment')!r}: must be [x, y]")
        dur = slot.get("duration")
        if not (isinstance(dur, (int, float)) and dur > 0):
            raise SequenceError(f"{source}: slots[{k}].duration = {dur!r}: must be a positive number")
        if not isinstance(slot.get("tasks"), list) or not slot["tasks"]:
            raise SequenceError(f"{source}: slots[{k}].tasks: no [[slots.tasks]] table")
        for i, t in enumerate(slot["tasks"]):
            if not point(t.get("position")):
                raise SequenceError(f"{source}: slots[{k}].tasks[{i}].position = {t.get('position')!r}: "
                                    "must be [x, y]")


def sequence_scenario(sequence, *, scale: float | None = None, time_unit: float = 60.0, delta: float = 240.0,
                      seconds: float | None = None, seed: int = 1, name: str = "secs-schedule",
                      checks: list | None = None, **params) -> dict:
    """A §IV-A scenario whose master runs the TSC's sequence (``swarmactors schedule --secs``; §III-C).

    ``sequence`` is that file's path or its content. Lengths become metres by ``scale`` (default the radio
    range over Γ: one Γ is one 3 m hop), measured from the sequence's ``start``, where the swarm starts
    (the origin); durations become seconds by ``time_unit`` (s per duration unit). The swarm is the
    sequence's ``robots``: robot 0 is the master, the only one given the schedule (a behaviour parameter),
    the others backbone robots. The tasks are world objects ``task_<id>`` known by no robot (for the
    oracle and the plots). ``seconds`` defaults to the flights at ``flock_speed`` plus each slot's
    duration plus 60 s per slot.
    """
    source = "<sequence>"
    if not isinstance(sequence, dict):
        source, sequence = str(sequence), read_sequence(sequence)
    else:
        _check_sequence(sequence, source)
    scale = 3.0 / float(sequence.get("gamma", 1.0)) if scale is None else float(scale)
    sx, sy = sequence["start"]

    def world(p, key: str) -> list[float]:
        q = [round((p[0] - sx) * scale, 6), round((p[1] - sy) * scale, 6)]
        if max(abs(q[0]), abs(q[1])) > 15.0:
            raise SequenceError(f"{source}: {key} = {p!r} lies at {q} m from the start, outside the 30 m arena "
                                f"(scale = {scale} m per unit)")
        return q

    slots, objects = [], []
    for k, slot in enumerate(sequence["slots"]):
        tasks = [{"id": str(t.get("id", f"t{i}")),
                  "position": world(t["position"], f"slots[{k}].tasks[{i}].position")}
                 for i, t in enumerate(slot["tasks"])]
        slots.append({"deployment": world(slot["deployment"], f"slots[{k}].deployment"),
                      "duration": float(slot["duration"]) * time_unit, "tasks": tasks})
        objects += [{"name": f"task_{t['id']}", "pos": t["position"], "known_by": []} for t in tasks]
    if seconds is None:
        speed, here, seconds = float(params.get("flock_speed", 0.05)), [0.0, 0.0], 0.0
        for slot in slots:
            seconds += math.dist(here, slot["deployment"]) / speed + slot["duration"] + 60.0
            here = slot["deployment"]
    common = {"range": 3.0, "speed": 0.15, "body_radius": 0.05}
    master = {"use": "secs", "delta": delta, "schedule": {"robots": sequence["robots"], "slots": slots}, **params}
    return {
        "run": {"name": name, "seed": seed, "clock": "lockstep", "dt": 0.1, "ticks": int(round(seconds / 0.1))},
        "radio": {"range": 3.0, "latency": 1, "loss": 0.0},
        "world": {"bounds": [[-15.0, -15.0], [15.0, 15.0]], "objects": objects},
        "robots": [{"positions": [[0.0, 0.0]], **common, "behaviors": [master]},
                   {"positions": cluster(sequence["robots"] - 1), "sensing_frame": "local", **common,
                    "behaviors": [{"use": "secs", "delta": delta, **params}]}],
        "checks": checks if checks is not None else [
            {"use": "secs.connected"}, {"use": "world.no_collisions"}, {"use": "secs.slots"}],
    }


def main(argv: list[str] | None = None) -> int:
    """Write a runnable scenario from the sequence of ``swarmactors schedule --secs``.

    ``python -m protocols.secs.scenarios SEQUENCE.toml --out SCENARIO.toml``; bad input: the file, the key and
    the value, exit 2.
    """
    import argparse
    import sys
    from pathlib import Path

    import tomli_w

    ap = argparse.ArgumentParser(prog="python -m protocols.secs.scenarios", description=main.__doc__.split("\n")[0])
    ap.add_argument("sequence", type=Path)
    ap.add_argument("--out", type=Path, required=True, help="the scenario TOML to write")
    ap.add_argument("--scale", type=float, default=None, help="metres per length unit (default 3 m / gamma)")
    ap.add_argument("--time-unit", type=float, default=60.0, help="seconds per duration unit (default 60)")
    ap.add_argument("--delta", type=float, default=240.0, help="Lennard-Jones δ in cm (default 240)")
    ap.add_argument("--flock-speed", type=float, default=0.05, help="the master's speed leading the flock (m/s)")
    ap.add_argument("--seconds", type=float, default=None, help="run length (default: flights + durations + 60 s "
                                                                 "a slot)")
    args = ap.parse_args(argv)
    for key in ("scale", "time_unit", "delta", "flock_speed", "seconds"):
        v = getattr(args, key)
        if v is not None and not (math.isfinite(v) and v > 0):
            print(f"--{key.replace('_', '-')} = {v!r}: must be a positive number", file=sys.stderr)
            return 2
    try:
        sc = sequence_scenario(args.sequence, scale=args.scale, time_unit=args.time_unit, delta=args.delta,
                               seconds=args.seconds, flock_speed=args.flock_speed,
                               name=f"secs-{args.sequence.stem}")
    except SequenceError as exc:
        print(exc, file=sys.stderr)
        return 2
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(f"# The SECS navigation controller driven by {args.sequence} (seed 003 §III-C), written by\n"
                        f"# python -m protocols.secs.scenarios. Robot 0, the master, alone holds the schedule.\n"
                        + tomli_w.dumps(sc))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
