"""Faults and world actions: scenario ``[[events]]`` and ``control`` commands, and robot crashes.

Every action (kill, kill a fraction, add robots, cut or restore links, partition and heal, change the loss,
move an object, stop) is one of ``transport.scenario.ACTIONS``, validated there before it is queued or
applied; scenario events come typed (``transport.scenario.Event``), control commands are typed when queued
(an ``add``'s robots are robot specs, checked as a scenario's). Actions apply at the start of a tick, scenario
events first (in ``at`` order), then the control commands that arrived since the last tick, so a run with the
same events is the same run.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import msgspec
import numpy as np

from transport.scenario import ACTIONS, MAX_ROBOTS, Event, action_problem, robot_spec
from world import rng
from world.counters import TickRecord
from world.radio import Medium
from world.registry import HostEntry, Robots

log = logging.getLogger("world")

ROBOT_CAP = "robot_cap"  # an add or join that would exceed world.max_robots
REQUEST_CAP = "request_cap"  # one add or mid-run join asking for more than MAX_PER_REQUEST robots


@dataclass
class Applied:
    """What an action asks of the world beyond what ``Faults`` did itself."""

    added: list[int] = field(default_factory=list)  # new robots, to be given to hosts
    stop: str | None = None  # the run should stop, for this reason


class Faults:
    """Applies actions and crashes robots; tells each host which of its robots died."""

    def __init__(self, events: list[Event], seed: int, robots: Robots, hosts: dict[str, HostEntry],
                 medium: Medium, objects: dict[str, list[float]], record: TickRecord,
                 max_robots: int = MAX_ROBOTS):
        self.events = sorted(events, key=lambda e: e.at)
        self._next_event = 0
        self.queued: list[dict] = []  # control actions, applied at the next tick
        self.seed = seed
        self.robots = robots
        self.hosts = hosts
        self.medium = medium
        self.objects = objects
        self.record = record
        self.max_robots = max_robots

    def refuse(self, tick: int, cause: str, reason: str) -> None:
        """A request refused under a named cause: counted (result.json ``world.refused``), logged, recorded."""
        self.record.refused(tick, cause, reason)

    def problem(self, action: dict) -> str | None:
        """Why ``action`` cannot be applied to this world now, or None."""
        return action_problem(action, robots=len(self.robots), dims=self.robots.dims, objects=set(self.objects),
                              radio=self.medium.config)

    def queue(self, action: dict) -> None:
        """Queue a control command for the next tick (ValueError naming the problem), typed as an event's action.

        An ``add``'s robots get the scenario's defaults (the radio's range) as a group's would.
        """
        problem = self.problem(action)
        if problem:
            raise ValueError(problem)
        ((name, value),) = action.items()
        value = msgspec.convert(value, ACTIONS[name], strict=True)  # typed as a scenario event's argument
        if name == "add":
            value = [robot_spec(s, self.robots.dims, self.medium.config.range) for s in value]
        self.queued.append({name: value})

    def due(self, tick: int) -> list[tuple[dict, str]]:
        """The actions to apply at ``tick``: due scenario events, then queued control commands."""
        out = []
        while self._next_event < len(self.events) and self.events[self._next_event].at <= tick:
            out.append((self.events[self._next_event].action(), "scenario"))
            self._next_event += 1
        queued, self.queued = self.queued, []
        return out + [(a, "control") for a in queued]

    def crash(self, rid: int, tick: int, cause: str, error: str | None = None) -> None:
        """Robot ``rid`` fails now (killed, crashed, watchdog, host-lost); its host is told."""
        if self.robots.kill(rid, tick, cause, error):
            ev = {"robot": rid, "failed": cause}
            if error:
                ev["error"] = error
            self.record.event(tick, ev)
            host = self.robots.host[rid]
            if host:
                self.hosts[host].pending_dead.append(rid)

    def apply(self, action: dict, source: str, tick: int) -> Applied:
        """Apply one validated action now (an invalid one is logged and changes nothing)."""
        problem = self.problem(action)
        if problem:
            log.error("%s action at tick %d: %s", source, tick, problem)
            return Applied()
        ((name, value),) = action.items()
        if name == "kill":
            ids = [value] if type(value) is int else value
            self._kill(ids, source, tick)
        elif name == "kill_fraction":
            alive = self.robots.alive_ids()
            k = int(round(float(value) * len(alive)))
            order = np.argsort(rng.uniform(self.seed, rng.PLACEMENT, tick, -1, alive), kind="stable")
            self._kill(sorted(alive[order[:k]].tolist()), source, tick)
        elif name == "add":
            if len(self.robots) + len(value) > self.max_robots:
                self.refuse(tick, ROBOT_CAP, f"{source} add of {len(value)} robot(s) at tick {tick}: the run "
                                             f"would hold more than world.max_robots = {self.max_robots}")
                return Applied()
            ids = self.robots.add(value, tick=tick)
            self.record.event(tick, {"added": ids, "source": source})
            return Applied(added=ids)
        elif name in ("cut", "restore"):
            for a, b in value:
                (self.medium.cut if name == "cut" else self.medium.restore)(a, b)
            self.record.event(tick, {name: value, "source": source})
        elif name == "partition":
            self.medium.partition(value)
            self.record.event(tick, {"partition": value, "source": source})
        elif name == "heal":
            self.medium.heal()
            self.record.event(tick, {"heal": True, "source": source})
        elif name == "loss":
            self.medium.set_loss(float(value))
            self.record.event(tick, {"loss": float(value), "source": source})
        elif name == "move":
            self.objects[value.object] = list(map(float, value.pos))
            self.record.event(tick, {"move": {"object": value.object, "pos": self.objects[value.object]},
                                     "source": source})
        elif name == "stop":
            return Applied(stop=f"stopped by {source}")
        return Applied()

    def _kill(self, ids: list[int], source: str, tick: int) -> None:
        self.record.event(tick, {"kill": ids, "source": source})
        for rid in ids:
            self.crash(rid, tick, "killed")
