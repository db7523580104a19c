"""The one Zenoh configuration builder used by every entry point.

Inside one machine every process is a Zenoh peer with multicast scouting off;
the world listens on an ephemeral loopback port (``tcp/127.0.0.1:0``) unless
told otherwise, so runs in parallel never collide, and hosts connect to the
locator the world reports. Across machines the world runs as a router and the
hosts as clients.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field

import zenoh

_ENDPOINT = re.compile(r"^(tcp|udp|tls|quic|ws|unixsock-stream)/\S+$")
_MODES = ("peer", "router", "client")


def check_endpoint(endpoint: str) -> str:
    """Return ``endpoint`` if it looks like a Zenoh locator, else raise ``ValueError``."""
    if not _ENDPOINT.match(endpoint):
        raise ValueError(
            f"endpoint {endpoint!r} is not a Zenoh locator such as tcp/127.0.0.1:7447"
        )
    return endpoint


@dataclass
class Endpoints:
    """Where a process listens and what it connects to."""

    mode: str = "peer"
    listen: list[str] = field(default_factory=list)
    connect: list[str] = field(default_factory=list)
    extra: dict[str, object] = field(default_factory=dict)  # slash-separated Zenoh config keys

    def __post_init__(self) -> None:
        if self.mode not in _MODES:
            raise ValueError(f"zenoh mode {self.mode!r} is not one of {', '.join(_MODES)}")
        for ep in [*self.listen, *self.connect]:
            check_endpoint(ep)


DEFAULT_WATCHDOG_S = 10.0  # run.watchdog_s when a scenario does not set it


def host_loss_s(watchdog_s: float = DEFAULT_WATCHDOG_S) -> float:
    """How long a silent host may take before the world loses it: 2·watchdog_s + 5 (docs/writing-behaviors.md)."""
    return 2.0 * watchdog_s + 5.0


def lease_settings(watchdog_s: float = DEFAULT_WATCHDOG_S) -> dict[str, object]:
    """Zenoh config keys giving a session the lease of the documented rule (``host_loss_s``).

    Zenoh's own default lease (10 s) would drop a host stalled for 10 s before the world's watchdog can act;
    both ends of a run announce this lease instead, so the rule decides.
    """
    return {"transport/link/tx/lease": int(host_loss_s(watchdog_s) * 1000)}


def make_config(endpoints: Endpoints) -> zenoh.Config:
    """Build the Zenoh config for ``endpoints`` (multicast scouting always off)."""
    cfg = zenoh.Config()
    cfg.insert_json5("mode", json.dumps(endpoints.mode))
    cfg.insert_json5("scouting/multicast/enabled", "false")
    cfg.insert_json5("adminspace/enabled", "true")
    cfg.insert_json5("listen/endpoints", json.dumps(endpoints.listen))
    cfg.insert_json5("connect/endpoints", json.dumps(endpoints.connect))
    if endpoints.connect:
        # Keep retrying while the world starts up, rather than failing at once.
        cfg.insert_json5("connect/timeout_ms", "30000")
    for key, value in endpoints.extra.items():
        cfg.insert_json5(key, json.dumps(value))
    return cfg
