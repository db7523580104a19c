"""The ``control`` commands a world session answers: clock commands, status, stop, and world actions.

Clock commands (pause, resume, step, run_to) need the lockstep clock; ``status`` tells the run; ``stop`` ends it
after the current tick; every other command is a world action (transport/scenario.py ``ACTIONS``), queued for the
next tick by the simulation (world/sim.py ``Simulation.queue``), which refuses what it cannot apply.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from transport import MalformedMessage, PendingQuery, pack
from transport.messages import CLOCK_COMMANDS, ControlCommand, decode
from world.clock import LockstepClock
from world.sim import Refused

if TYPE_CHECKING:
    from world.session import WorldSession


def answer_control(session: WorldSession, q: PendingQuery) -> None:
    """Answer one query on ``control``; a bad command is refused, counted as malformed, and changes nothing."""
    try:
        answer = control_answer(session, decode(q.payload, ControlCommand, what="control command"))
    except Refused as exc:  # counted under its own cause already
        answer = {"ok": False, "error": str(exc)}
    except (MalformedMessage, ValueError, TypeError) as exc:
        session.sim.record.malformed(None, f"control: {exc}")
        answer = {"ok": False, "error": str(exc)}
    q.reply(pack(answer))


def control_answer(session: WorldSession, cmd: ControlCommand) -> dict:
    """The answer to ``cmd``; ``ValueError`` (or ``Refused``) for a command this run cannot take."""
    name = cmd.cmd
    if name == "status":
        return {"ok": True, **session.status()}
    if name == "stop":
        session.request_stop("stopped by control")
        return {"ok": True}
    if name in CLOCK_COMMANDS:
        clock = session.clock
        if not isinstance(clock, LockstepClock):
            raise ValueError(f"{name} needs the lockstep clock (this run is {clock.name})")
        if name == "pause":
            clock.pause()
            return {"ok": True, "tick": session.tick}
        if name == "resume":
            clock.resume()
            return {"ok": True, "tick": session.tick}
        target = session.tick + 1 if name == "step" else cmd.tick
        if type(target) is not int or target < 0:
            raise ValueError(f"run_to: tick {target!r} is not a non-negative integer")
        clock.run_to(target)
        return {"ok": True, "until": target}
    at = session.sim.queue({name: cmd.args})
    return {"ok": True, "at": at if session.started else 0}
