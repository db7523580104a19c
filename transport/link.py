"""A Zenoh session bridged into one asyncio loop.

Zenoh has no asyncio API: its callbacks run on Zenoh's own threads. Every
callback here does nothing but hand the payload to the loop with
``loop.call_soon_threadsafe``; all handling then happens on the loop's thread.
Callbacks are registered with ``indirect=False`` so that no Python thread is
spawned per subscriber or per query.

Traffic classes:

* ``reliable=True`` (world <-> host): ``CongestionControl.BLOCK`` - never
  silently dropped; a slow receiver slows the sender.
* ``reliable=False`` (observer streams ``state``/``events``):
  ``CongestionControl.DROP`` with express delivery - a slow or vanished viewer
  loses snapshots, never ticks.
"""

from __future__ import annotations

import asyncio
import json
import logging
from collections.abc import Callable
from typing import Any

import zenoh

from transport.config import Endpoints, make_config

log = logging.getLogger(__name__)


class PendingQuery:
    """A query received by a queryable, answerable later from the loop thread."""

    __slots__ = ("key", "payload", "_query")

    def __init__(self, query: zenoh.Query):
        self._query = query
        self.key = str(query.key_expr)
        payload = query.payload
        self.payload = payload.to_bytes() if payload is not None else b""

    def reply(self, data: bytes) -> None:
        """Send one reply and close the query (a query gets exactly one answer here)."""
        try:
            self._query.reply(self.key, data)
        finally:
            self._query.drop()

    def reply_error(self, message: str) -> None:
        try:
            self._query.reply_err(message.encode())
        finally:
            self._query.drop()


class QueryError(RuntimeError):
    """A query was answered with an error, or by nobody."""


class Link:
    """One Zenoh session per process, used from one asyncio loop."""

    def __init__(self, endpoints: Endpoints, loop: asyncio.AbstractEventLoop | None = None):
        self.loop = loop or asyncio.get_running_loop()
        self.endpoints = endpoints
        self.session = zenoh.open(make_config(endpoints))
        self._entities: list[Any] = []
        self._publishers: dict[tuple[str, bool], zenoh.Publisher] = {}
        self._closed = False

    # -- introspection -------------------------------------------------
    def locators(self) -> list[str]:
        """The endpoints this session actually listens on (ports resolved)."""
        zid = str(self.session.zid())
        for reply in self.session.get(f"@/{zid}/{self.endpoints.mode}", timeout=5.0):
            if reply.ok is not None:
                return list(json.loads(reply.ok.payload.to_bytes()).get("locators", []))
        return []

    # -- publish / subscribe --------------------------------------------
    def publish(self, key: str, data: bytes, *, reliable: bool = True) -> None:
        """Put ``data`` on ``key`` through a cached publisher of the right class (no-op once closed)."""
        if self._closed:
            return
        pub = self._publishers.get((key, reliable))
        if pub is None:
            if reliable:
                pub = self.session.declare_publisher(
                    key,
                    congestion_control=zenoh.CongestionControl.BLOCK,
                    reliability=zenoh.Reliability.RELIABLE,
                )
            else:
                pub = self.session.declare_publisher(
                    key,
                    congestion_control=zenoh.CongestionControl.DROP,
                    priority=zenoh.Priority.DATA_LOW,
                    express=True,
                )
            self._publishers[(key, reliable)] = pub
        pub.put(data)

    def subscribed(self, key: str, *, reliable: bool = False) -> bool:
        """Whether a put on ``key`` would reach a subscriber now (True before the first put declares its publisher).

        Zenoh's matching status, kept up to date by the session: about 1 µs to read.
        """
        pub = self._publishers.get((key, reliable))
        return pub is None or pub.matching_status.matching

    def subscribe(self, key: str, handler: Callable[[str, bytes], None]) -> None:
        """Call ``handler(key, payload)`` on the loop for every sample on ``key``."""
        loop = self.loop

        def on_sample(sample: zenoh.Sample) -> None:
            loop.call_soon_threadsafe(handler, str(sample.key_expr), sample.payload.to_bytes())

        self._entities.append(
            self.session.declare_subscriber(key, zenoh.handlers.Callback(on_sample, indirect=False))
        )

    # -- queries ---------------------------------------------------------
    def serve(self, key: str, handler: Callable[[PendingQuery], None]) -> None:
        """Call ``handler(PendingQuery)`` on the loop for every query on ``key``."""
        loop = self.loop

        def on_query(query: zenoh.Query) -> None:
            loop.call_soon_threadsafe(handler, PendingQuery(query))

        self._entities.append(
            self.session.declare_queryable(key, zenoh.handlers.Callback(on_query, indirect=False))
        )

    async def query(
        self,
        key: str,
        payload: bytes = b"",
        *,
        timeout: float = 10.0,  # noqa: ASYNC109 — Zenoh's own query timeout (session.get), not a cancel scope
        accept: Callable[[bytes], bool] | None = None,
    ) -> bytes:
        """Send a query and return the first reply's payload that ``accept`` takes (``QueryError`` if none).

        With ``accept`` (e.g. "sealed under my key") a rogue queryable answering first cannot stand in for the
        world: its replies are skipped.
        """
        loop = self.loop
        future: asyncio.Future = loop.create_future()
        replies: list[bytes] = []
        errors: list[str] = []

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is not None:
                replies.append(reply.ok.payload.to_bytes())
            else:
                errors.append(reply.err.payload.to_bytes().decode(errors="replace"))

        def on_done() -> None:
            loop.call_soon_threadsafe(_settle, future, replies, errors, accept)

        self.session.get(
            key,
            zenoh.handlers.Callback(on_reply, on_done, indirect=False),
            payload=payload,
            timeout=timeout,
            target=zenoh.QueryTarget.ALL,
            consolidation=zenoh.ConsolidationMode.NONE,  # every reply reaches ``accept``, not just the latest
            congestion_control=zenoh.CongestionControl.BLOCK,
        )
        result = await future
        return result

    async def query_all(
        self,
        key: str,
        payload: bytes = b"",
        *,
        timeout: float = 3.0,  # noqa: ASYNC109 — Zenoh's own query timeout (session.get): how long replies may come
    ) -> list[bytes]:
        """Send a query (``key`` may hold wildcards) and return every successful reply's payload.

        Waits until every matching queryable answered or ``timeout`` passed; an
        empty list means nobody answered (used to find the runs on a network).
        """
        loop = self.loop
        future: asyncio.Future = loop.create_future()
        replies: list[bytes] = []

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is not None:
                replies.append(reply.ok.payload.to_bytes())

        def on_done() -> None:
            loop.call_soon_threadsafe(lambda: future.done() or future.set_result(list(replies)))

        self.session.get(
            key,
            zenoh.handlers.Callback(on_reply, on_done, indirect=False),
            payload=payload,
            timeout=timeout,
            target=zenoh.QueryTarget.ALL,
            consolidation=zenoh.ConsolidationMode.NONE,
        )
        return await future

    # -- liveliness --------------------------------------------------------
    def declare_token(self, key: str) -> None:
        """Hold a liveliness token on ``key`` until the session closes."""
        self._entities.append(self.session.liveliness().declare_token(key))

    def watch_liveliness(self, key: str, handler: Callable[[str, bool], None]) -> None:
        """Call ``handler(key, alive)`` on the loop when a token matching ``key`` appears or vanishes."""
        loop = self.loop

        def on_sample(sample: zenoh.Sample) -> None:
            loop.call_soon_threadsafe(
                handler, str(sample.key_expr), sample.kind == zenoh.SampleKind.PUT
            )

        self._entities.append(
            self.session.liveliness().declare_subscriber(
                key, zenoh.handlers.Callback(on_sample, indirect=False), history=True
            )
        )

    # -- shutdown -------------------------------------------------------------
    def close(self) -> None:
        """Undeclare everything and close the session (idempotent)."""
        if self._closed:
            return
        self._closed = True
        for entity in [*self._entities, *self._publishers.values()]:
            try:
                entity.undeclare()
            except Exception:  # already gone with a broken session
                pass
        self._entities.clear()
        self._publishers.clear()
        self.session.close()

    def __enter__(self) -> Link:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _settle(future: asyncio.Future, replies: list[bytes], errors: list[str],
            accept: Callable[[bytes], bool] | None = None) -> None:
    if future.done():
        return
    if accept is not None:
        good = [r for r in replies if accept(r)]
        if replies and not good:
            errors = [*errors, f"{len(replies)} reply(ies), none authentic"]
        replies = good
    if replies:
        future.set_result(replies[0])
    elif errors:
        future.set_exception(QueryError(errors[0]))
    else:
        future.set_exception(QueryError("no reply (nobody answered before the timeout)"))
