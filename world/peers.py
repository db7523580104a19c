"""The world session's hosts as peers on the wire: their keys, where each is in the protocol, and the rules on it.

Each host that joins gets a key (transport/auth.py): its uplinks must be sealed with it, and the session seals its
downlinks with it. A host must register within ``register_within_s`` of its join (``late``); the session acks a
registered host that heard nothing for ``watchdog_s`` (``quiet``), so that a paused world is not taken for a dead
one (swarmactors/robot/session.py stops after 2·watchdog_s + 5 s of silence).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from transport import MalformedMessage, new_key, seal, unseal
from transport.messages import Uplink, decode, encode


@dataclass
class Peer:
    """A host as the session knows it: its key and where it is in the protocol."""

    key: bytes
    joined_at: float  # time.monotonic() of its join
    registered: bool = False  # its registration (tick -1) arrived (lockstep: once only)
    reported: bool = False  # its final reports arrived
    last_down: float = 0.0  # time.monotonic() of its last downlink


class Peers(dict[str, Peer]):
    """Every host that joined, by name (``h0``, ``h1``, ...)."""

    def join(self) -> tuple[str, Peer]:
        """A new host: its name and its peer entry, with a fresh key."""
        name = f"h{len(self)}"
        self[name] = Peer(new_key(), joined_at=time.monotonic())
        return name, self[name]

    def seal(self, host: str, msg) -> bytes:
        """A downlink message for ``host``, sealed with its key."""
        peer = self[host]
        peer.last_down = time.monotonic()
        return seal(peer.key, encode(msg))

    def open(self, host: str, payload: bytes) -> Uplink:
        """An uplink on ``up/{host}``: verified with the host's key and decoded; ``MalformedMessage`` if not."""
        peer = self.get(host)
        if peer is None:
            raise MalformedMessage(f"uplink on up/{host}: no such host joined")
        msg = decode(unseal(peer.key, payload, what=f"uplink on up/{host}"), Uplink, what=f"uplink from {host}")
        if msg.host != host:
            raise MalformedMessage(f"uplink on up/{host} claims host {msg.host!r}")
        return msg

    def late(self, hosts: list[str], held: dict, within_s: float, every: bool = False) -> list[tuple[str, float]]:
        """Hosts among ``hosts`` that have not registered ``within_s`` after their join; the seconds since it.

        ``every``: whenever they joined; a registration still ``held`` counts as registered.
        """
        now = time.monotonic()
        out = []
        for host in hosts:
            peer = self[host]
            if not (peer.registered or host in held) and (every or now - peer.joined_at > within_s):
                out.append((host, now - peer.joined_at))
        return out

    def quiet(self, hosts: list[str], held: dict, watchdog_s: float) -> list[str]:
        """Registered hosts among ``hosts`` that were sent nothing for ``watchdog_s``."""
        since = time.monotonic() - watchdog_s
        return [h for h in hosts if (self[h].registered or h in held) and self[h].last_down < since]
