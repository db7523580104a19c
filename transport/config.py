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
