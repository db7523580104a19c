"""Key-expression layout of a run (DESIGN.md, "Key expressions").

Everything of one run lives under ``swarmactors/{run_id}``, so runs in parallel
on one Zenoh network never see each other's traffic.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

_RUN_ID = re.compile(r"^[A-Za-z0-9_.-]{1,64}$")
CONTROL_ANY = "swarmactors/*/control"  # every run's control queryable (to find the runs on a network)


@dataclass(frozen=True)
class Keys:
    """The keys of run ``run_id``."""

    run_id: str

    def __post_init__(self) -> None:
        if not _RUN_ID.match(self.run_id):
            raise ValueError(
                f"run id {self.run_id!r} must be 1-64 characters of letters, digits, '_', '.' or '-'"
            )

    @property
    def prefix(self) -> str:
        return f"swarmactors/{self.run_id}"

    @property
    def join(self) -> str:
        """Queryable: a host registers and receives its robots."""
        return f"{self.prefix}/world/join"

    def up(self, host: str) -> str:
        """Host to world: outgoing frames, velocity commands, step-done markers."""
        return f"{self.prefix}/up/{host}"

    @property
    def up_all(self) -> str:
        return f"{self.prefix}/up/*"

    def down(self, host: str) -> str:
        """World to host: poses, sensing, delivered frames, the tick."""
        return f"{self.prefix}/down/{host}"

    @property
    def state(self) -> str:
        """World to observers: per-tick snapshot."""
        return f"{self.prefix}/state"

    @property
    def events(self) -> str:
        """World to observers: faults, joins, failures, verdicts."""
        return f"{self.prefix}/events"

    @property
    def control(self) -> str:
        """Queryable: status, pause, step, faults, stop."""
        return f"{self.prefix}/control"

    def alive(self, host: str) -> str:
        """Liveliness token of a host; its disappearance means the host crashed."""
        return f"@swarmactors/{self.run_id}/alive/{host}"

    @property
    def world_alive(self) -> str:
        """Liveliness token of the world; its disappearance tells the hosts that the run is over."""
        return f"@swarmactors/{self.run_id}/world"

    @property
    def alive_all(self) -> str:
        return f"@swarmactors/{self.run_id}/alive/*"

    def host_of(self, key: str) -> str:
        """The host name at the end of an ``up/{host}`` or liveliness key."""
        return key.rsplit("/", 1)[-1]
