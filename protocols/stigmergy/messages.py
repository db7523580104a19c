"""Virtual stigmergy's frame bodies (``VS_PUT``, ``VS_QUERY``, ``VS_DIGEST``), typed: the lists they always were.

A key or a table id is an integer or a string; a timestamp and a writer are integers. What depends on the kind
(a PUT's timestamp is at least 1, a timestamp-0 query carries nil) is checked here and counted as ``timestamp``.
"""

from __future__ import annotations

from typing import Annotated, Any, Union

from msgspec import Meta

from swarmactors.robot.bodies import Bodies, Body, Index

PUT = "VS_PUT"
QUERY = "VS_QUERY"
DIGEST = "VS_DIGEST"

Key = Union[int, str]  # noqa: UP007 - read by msgspec at runtime


class Put(Body, array_like=True):
    """W1/P1-P3: an entry of table ``sid``: ``[sid, key, value, ts, writer]``."""

    KIND = PUT
    sid: Key
    key: Key
    value: Any
    ts: int
    writer: Index

    def __post_init__(self):
        if self.ts < 1:
            raise ValueError("timestamp")


class Query(Body, array_like=True):
    """W3/Q1-Q6: the querier's entry (timestamp 0 and nil: it has none) and its query id: ``[..., qid]``."""

    KIND = QUERY
    sid: Key
    key: Key
    value: Any
    ts: int
    writer: Index
    qid: Index

    def __post_init__(self):
        if self.ts < 0 or (self.ts == 0 and self.value is not None):
            raise ValueError("timestamp")


class Digest(Body, array_like=True):
    """A1/A2: table ``sid``'s keys with their timestamps and writers: ``[sid, [[key, ts, writer], ...]]``."""

    KIND = DIGEST
    sid: Key
    items: list[tuple[Key, Annotated[int, Meta(ge=1)], Index]]


BODIES = Bodies(Put, Query, Digest)
KINDS = BODIES.kinds
