"""The msgpack wire codec.

Every message between world, hosts and observers is one msgpack map. Frame
bodies travel as opaque ``bytes`` (packed by the sending robot's host), so the
world routes frames from their header alone and never decodes a body.
"""

from __future__ import annotations

from typing import Any

import msgpack


class MalformedMessage(ValueError):
    """Raised for bytes that are not a well-formed message of the expected shape."""


def pack(obj: Any) -> bytes:
    """Encode ``obj`` as msgpack (bytes stay bytes, strings stay strings)."""
    return msgpack.packb(obj, use_bin_type=True)


def unpack(data: bytes, *, what: str = "message") -> Any:
    """Decode msgpack ``data``; any decoding failure becomes ``MalformedMessage``."""
    try:
        return msgpack.unpackb(data, raw=False, strict_map_key=False, use_list=True)
    except Exception as exc:  # msgpack raises several unrelated types
        raise MalformedMessage(f"undecodable {what}: {exc.__class__.__name__}: {exc}") from None


def unpack_map(data: bytes, *, what: str, required: dict[str, type | tuple[type, ...]]) -> dict:
    """Decode a msgpack map and check that ``required`` keys have the given types."""
    obj = unpack(data, what=what)
    if not isinstance(obj, dict):
        raise MalformedMessage(f"{what} is a {type(obj).__name__}, expected a map")
    for key, typ in required.items():
        if key not in obj:
            raise MalformedMessage(f"{what} lacks key {key!r}")
        if not isinstance(obj[key], typ) or isinstance(obj[key], bool) and bool not in _as_tuple(typ):
            raise MalformedMessage(
                f"{what} key {key!r} is {type(obj[key]).__name__}, expected {_names(typ)}"
            )
    return obj


def _as_tuple(typ: type | tuple[type, ...]) -> tuple[type, ...]:
    return typ if isinstance(typ, tuple) else (typ,)


def _names(typ: type | tuple[type, ...]) -> str:
    return " or ".join(t.__name__ for t in _as_tuple(typ))
