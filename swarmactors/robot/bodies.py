"""Typed frame bodies: a family's frame kinds as msgspec Structs, decoded and encoded in one place.

A family declares one Struct per frame kind (subclassing ``Body`` and naming its kind in ``KIND``) in its
``messages.py`` and groups them in a ``Bodies`` (the tagged union: the tag is the frame's kind, carried in the
frame's header, so a body holds no tag of its own). A behaviour then

* decodes a received frame with ``BODIES.decode(frame, counts)``: the Struct of the frame's kind, or None for
  a body that does not fit, counted in ``counts`` (a ``collections.Counter`` the behaviour reports) under its
  cause: ``unknown_kind`` (no Struct for the kind), ``not_a_map`` / ``not_an_array`` (the wrong container),
  ``bad_length`` (an array too short), ``missing_field``, ``bad_field`` (a field of the wrong type or out of
  its bounds), or the cause a Struct's ``__post_init__`` names (``raise ValueError("angle")``: a lower-case
  identifier is taken as the cause);
* dispatches on the type (``match body: case Flood(): ...`` or ``isinstance``);
* sends a Struct with ``BODIES.broadcast(ctx, body)`` / ``BODIES.send(ctx, dst, body)``, which encode it to
  the plain value (``encode``: maps in field order, arrays for ``array_like`` Structs, ``UNSET`` fields
  left out) that the context packs as msgpack, as it packs any body.

A Struct declared with today's keys in today's order (``msgspec.field(name=...)`` for a short key,
``array_like=True`` for a list body, ``UNSET`` defaults for keys sent only sometimes) encodes exactly the
bytes a hand-written dict or list gave. Numbers that may be integers or floats are ``Num`` (``int | float``):
a ``float`` field would turn an integer into a float and change the bytes a robot forwards.

A robot host loads this module: msgspec only.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Iterable, MutableMapping
from typing import Annotated, Any, ClassVar, Union

import msgspec

Num = Union[int, float]  # noqa: UP007 - a runtime alias msgspec reads in annotations
_BIG = sys.float_info.max
Finite = Union[int, Annotated[float, msgspec.Meta(ge=-_BIG, le=_BIG)]]  # noqa: UP007 - no inf, no nan
NonNeg = Union[Annotated[int, msgspec.Meta(ge=0)], Annotated[float, msgspec.Meta(ge=0, le=_BIG)]]  # noqa: UP007
Index = Annotated[int, msgspec.Meta(ge=0)]  # a robot id, a task index, a period
UNSET = msgspec.UNSET
UnsetType = msgspec.UnsetType

_CAUSE = re.compile(r"[a-z][a-z0-9_]*")
_AS_IS = (bytes, bytearray, memoryview)  # msgpack's own bin type: not base64 text
_convert = msgspec.convert


class Body(msgspec.Struct, kw_only=True):
    """Base of a typed frame body; a subclass names its frame kind in ``KIND``.

    Give a subclass ``kw_only=True`` when a required field follows one with a default (the wire's key order).
    """

    KIND: ClassVar[str] = ""


def cause_of(error: msgspec.ValidationError) -> str:
    """The cause under which a body that failed validation is counted (see the module's docstring)."""
    text = str(error)
    if _CAUSE.fullmatch(text):
        return text
    if " - at `$" not in text:  # the body itself, not one of its fields
        if text.startswith("Expected `object`"):
            return "not_a_map"
        if text.startswith("Expected `array` of"):
            return "bad_length"
        if text.startswith("Expected `array`"):
            return "not_an_array"
        if text.startswith("Object missing required field"):
            return "missing_field"
    return "bad_field"


class Bodies:
    """A family's frame bodies: the tagged union of its Structs, keyed by frame kind."""

    def __init__(self, *types: type[Body]):
        self.types: dict[str, type[Body]] = {}
        for t in types:
            if not t.KIND or t.KIND in self.types:
                raise ValueError(f"{t.__name__}: KIND {t.KIND!r} is empty or given twice")
            self.types[t.KIND] = t

    @property
    def kinds(self) -> tuple[str, ...]:
        """The frame kinds, in declaration order (a behaviour's ``kinds``)."""
        return tuple(self.types)

    def decode_body(self, kind: str, body: Any, counts: MutableMapping[str, int] | None = None) -> Body | None:
        """``body`` (a decoded msgpack value) as the Struct of ``kind``; None (counted by cause) if it does not fit."""
        t = self.types.get(kind)
        if t is None:
            return _count(counts, "unknown_kind")
        try:
            return msgspec.convert(body, t)
        except msgspec.ValidationError as exc:
            return _count(counts, cause_of(exc))

    def decode(self, frame: Any, counts: MutableMapping[str, int] | None = None) -> Body | None:
        """A received ``Frame``'s body as the Struct of its kind; None (counted by cause) if it does not fit.

        The same as ``decode_body(frame.kind, frame.body, counts)``, one call fewer per frame when it fits.
        """
        t = self.types.get(frame.kind)
        if t is not None:
            try:
                return _convert(frame.body, t)
            except msgspec.ValidationError:
                pass
        return self.decode_body(frame.kind, frame.body, counts)

    def _decode_via_body(self, frame: Any, counts: MutableMapping[str, int] | None = None) -> Body | None:
        return self.decode_body(frame.kind, frame.body, counts)

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """A subclass with its own ``decode_body`` (its own shapes) decodes every frame through it."""
        super().__init_subclass__(**kwargs)
        if cls.decode_body is not Bodies.decode_body and cls.decode is Bodies.decode:
            cls.decode = Bodies._decode_via_body

    @staticmethod
    def encode(body: Body) -> Any:
        """The plain value (map, list, numbers, strings) that the context packs for ``body``."""
        return msgspec.to_builtins(body, builtin_types=_AS_IS, enc_hook=_plain)

    def broadcast(self, ctx: Any, body: Body, exclude: Iterable[int] = ()) -> None:
        """``ctx.broadcast`` of a typed body under its kind."""
        ctx.broadcast(self._kind(body), self.encode(body), exclude=tuple(exclude))

    def send(self, ctx: Any, dst: int, body: Body) -> None:
        """``ctx.send`` of a typed body under its kind."""
        ctx.send(dst, self._kind(body), self.encode(body))

    def _kind(self, body: Body) -> str:
        kind = type(body).KIND
        if self.types.get(kind) is not type(body):
            raise TypeError(f"{type(body).__name__} is not one of this family's bodies")
        return kind


def _plain(obj: Any) -> Any:
    """What msgpack packs a subclass of float or int as (numpy's float64 is one): the plain number."""
    if isinstance(obj, float):
        return float(obj)
    if isinstance(obj, int):
        return int(obj)
    raise TypeError(f"a frame body cannot hold a {type(obj).__name__}")


def _count(counts: MutableMapping[str, int] | None, cause: str) -> None:
    if counts is not None:
        counts[cause] = counts.get(cause, 0) + 1
    return None
