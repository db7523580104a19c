"""What the world takes from a host's uplink: the rules a decoded ``Uplink`` must still pass.

``transport.messages`` checks types and ranges. What needs the world's state is checked here, robot by
robot: a host speaks only for the robots it runs; a dead robot's outputs are ignored; a velocity has 1 to
``dims`` finite components and is within ``MAX_SPEED`` (world.kinematics), else its robot crashes; a robot's
frame sequence numbers increase. What fails is reported as a reason (counted as ``malformed`` by the world);
the rest of the uplink is still used.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from transport.messages import RobotOut
from world.kinematics import velocity_problem
from world.radio import Outgoing

REFUSED_BEHAVIOR = "refused_behavior"  # a host refused to build a behaviour outside its allowlist (plugins)
INVALID_VELOCITY = "invalid_velocity"  # a velocity command the world cannot integrate (world.kinematics)
INVALID_POSITION = "invalid_position"  # a position that left the finite world (world.kinematics)
COUNTED_CRASHES = (REFUSED_BEHAVIOR, INVALID_VELOCITY, INVALID_POSITION)


@dataclass
class Accepted:
    """An uplink's usable content, and the reasons for what was refused (robot id or None, reason)."""

    velocities: list[tuple[int, np.ndarray]] = field(default_factory=list)
    statuses: list[tuple[int, dict]] = field(default_factory=list)
    frames: list[Outgoing] = field(default_factory=list)
    crashes: list[tuple[int, str, str]] = field(default_factory=list)  # (robot, cause, error)
    refused: list[tuple[int | None, str]] = field(default_factory=list)


def accept(host: str, rows: list[RobotOut], owned: set[int], alive: np.ndarray, dims: int,
           last_seq: dict[int, int]) -> Accepted:
    """Check a host's robot rows against the world's state; ``last_seq`` is updated for accepted frames."""
    out = Accepted()
    n = len(alive)
    gone: set[int] = set()
    is_alive = alive.tolist()
    take = out.frames.append
    for row in rows:
        rid = row.id
        if rid not in owned:
            out.refused.append((rid if rid < n else None, f"host {host} sent for robot {rid}, which it does not run"))
            continue
        if not is_alive[rid] or rid in gone:
            continue
        if row.error is not None:
            cause = ("watchdog" if row.error.startswith("watchdog")
                     else REFUSED_BEHAVIOR if row.error.startswith("refused behaviour") else "crashed")
            out.crashes.append((rid, cause, row.error))
            gone.add(rid)
            continue
        vel = row.velocity
        if vel is not None:
            problem = velocity_problem(vel, dims)
            if problem is None:
                v = np.zeros(dims)
                v[: len(vel)] = vel
                out.velocities.append((rid, v))
            else:  # the robot's own command: it crashes, the run goes on
                out.crashes.append((rid, INVALID_VELOCITY, f"velocity {vel!r} {problem}"))
                gone.add(rid)
                continue
        if row.status:
            out.statuses.append((rid, row.status))
        if row.frames:
            last = last_seq.get(rid, -1)
            for f in row.frames:
                if f.seq <= last:
                    out.refused.append((rid, f"bad frame header from robot {rid}: dst={f.dst!r} kind={f.kind!r} "
                                             f"seq={f.seq!r} (not after {last})"))
                    continue
                last = f.seq
                take(Outgoing(rid, f.dst, f.kind, f.seq, f.body, tuple(f.exclude) if f.exclude else (), f.at))
            last_seq[rid] = last
    return out
