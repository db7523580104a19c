"""Authenticated uplinks.

Every robot host receives its own random key in the ``world/join`` reply and
seals each uplink message with HMAC-SHA256 under it. Replicas that share one
Zenoh credential therefore still cannot speak for one another: a message on
``up/{host}`` that does not verify under ``{host}``'s key is dropped and
counted as malformed by the world.

Sealed form: msgpack ``[tag, body]`` where ``body`` is the packed message and
``tag = HMAC-SHA256(key, body)``.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets

from transport.codec import MalformedMessage, pack, unpack

KEY_BYTES = 32


def new_key() -> bytes:
    """A fresh random per-host key."""
    return secrets.token_bytes(KEY_BYTES)


def seal(key: bytes, body: bytes) -> bytes:
    """``body`` with its authentication tag."""
    return pack([hmac.new(key, body, hashlib.sha256).digest(), body])


def unseal(key: bytes, data: bytes, *, what: str) -> bytes:
    """The body of a sealed message, or ``MalformedMessage`` if it does not verify under ``key``."""
    env = unpack(data, what=what)
    if not (isinstance(env, list) and len(env) == 2 and isinstance(env[0], bytes) and isinstance(env[1], bytes)):
        raise MalformedMessage(f"{what} is not a sealed [tag, body] pair")
    tag, body = env
    if not hmac.compare_digest(tag, hmac.new(key, body, hashlib.sha256).digest()):
        raise MalformedMessage(f"{what} fails authentication")
    return body
