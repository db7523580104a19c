"""Authenticated uplinks and downlinks.

Every robot host receives its own random key in the ``world/join`` reply and
seals each uplink message with HMAC-SHA256 under it. Replicas that share one
Zenoh credential therefore still cannot speak for one another: a message on
``up/{host}`` that does not verify under ``{host}``'s key is dropped and
counted as malformed by the world.

Sealed form: msgpack ``[tag, body]`` where ``body`` is the packed message and
``tag = HMAC-SHA256(key, body)``.

Downlinks (``down/{host}`` and the replies to a host's steps) are sealed by the world with the same per-host
key, and the ``world/join`` reply with the run's secret when there is one: ``swarmactors run`` makes a random
secret per run and gives it to the hosts it starts through the environment (``SWARMACTORS_RUN_SECRET``, hex);
an operator may set the same variable for ``swarmactors world`` and its ``robots``. A host drops (and counts)
a downlink or join reply that does not verify.
"""

from __future__ import annotations

import hashlib
import hmac
import os
import secrets

from transport.codec import MalformedMessage, pack, unpack

KEY_BYTES = 32
RUN_SECRET_ENV = "SWARMACTORS_RUN_SECRET"


def run_secret_from_env() -> bytes | None:
    """The run secret shared through the environment (hex), or None."""
    value = os.environ.get(RUN_SECRET_ENV)
    if not value:
        return None
    try:
        return bytes.fromhex(value)
    except ValueError:
        raise ValueError(f"{RUN_SECRET_ENV} is not a hex string") from None


def verifies(key: bytes, data: bytes) -> bool:
    """True if ``data`` is a message sealed under ``key``."""
    try:
        unseal(key, data, what="message")
    except MalformedMessage:
        return False
    return True


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
