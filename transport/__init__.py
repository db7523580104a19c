"""Zenoh transport: the only package that imports zenoh.

It holds the session configuration, the key-expression layout, the msgpack
wire codec and the bridge from Zenoh's callback threads into asyncio.
"""

from transport.auth import new_key, seal, unseal
from transport.codec import MalformedMessage, pack, unpack
from transport.config import Endpoints, host_loss_s, lease_settings, make_config
from transport.keys import Keys
from transport.link import Link, PendingQuery, QueryError
from transport.security import Security, ensure_files

__all__ = [
    "Endpoints",
    "Keys",
    "Link",
    "MalformedMessage",
    "PendingQuery",
    "QueryError",
    "Security",
    "ensure_files",
    "host_loss_s",
    "lease_settings",
    "make_config",
    "new_key",
    "seal",
    "unseal",
    "pack",
    "unpack",
]
