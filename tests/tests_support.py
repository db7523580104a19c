"""Test-only behaviours (importable by spawned host processes: tests/ is put on their sys.path) and fakes."""

from __future__ import annotations

from swarmactors import Behavior


class RandomWalk(Behavior):
    """Move in a direction drawn from the robot's own seeded generator, changed every few ticks."""

    name = "random_walk"

    def on_tick(self, ctx, sensed) -> None:
        if ctx.tick % 3 == 0:
            ctx.move(ctx.rng.normal(size=2))
        ctx.set_status(moved=ctx.tick)


class Clock(Behavior):
    """Record ctx.now and the error of sensed positions against the true ones (from the tick's record)."""

    name = "clock"

    def __init__(self):
        self.last_now = None
        self.sense_error = None
        self.first = None

    def on_tick(self, ctx, sensed) -> None:
        self.last_now = ctx.now
        if ctx.tick == 0 and len(sensed):
            # relative sensed position of the first neighbour; compared after the run via the report
            self.first = [sensed[0].id, *sensed[0].pos.tolist()]

    def report(self) -> dict:
        return {"last_now": self.last_now, "sense_error": self.sense_error, "first": self.first}


class FakeLink:
    """Enough of transport.Link for a world session or a host driven by hand, below Zenoh.

    Puts are recorded in ``published``; ``query`` and ``put`` reach the handlers the session declared with
    ``serve`` and ``subscribe`` (key expressions with ``*`` match one chunk), as Zenoh would deliver them.
    """

    def __init__(self):
        self.published: list[tuple[str, bytes]] = []
        self._served: list[tuple[str, object]] = []
        self._subscribed: list[tuple[str, object]] = []

    def publish(self, key, data, *, reliable=True):
        self.published.append((key, data))

    def serve(self, key, handler):
        self._served.append((key, handler))

    def subscribe(self, key, handler):
        self._subscribed.append((key, handler))

    def watch_liveliness(self, *a, **k):
        pass

    def subscribed(self, key: str) -> bool:
        return True

    def declare_token(self, *a, **k):
        pass

    def query(self, key: str, payload: bytes) -> FakeQuery:
        """A query on ``key``, answered by the handler serving it; returns it with its replies."""
        q = FakeQuery(key, payload)
        for pattern, handler in self._served:
            if _matches(pattern, key):
                handler(q)
        return q

    def put(self, key: str, payload: bytes) -> None:
        """A put on ``key``, handed to every subscriber of it."""
        for pattern, handler in self._subscribed:
            if _matches(pattern, key):
                handler(key, payload)


def _matches(pattern: str, key: str) -> bool:
    a, b = pattern.split("/"), key.split("/")
    return len(a) == len(b) and all(x == "*" or x == y for x, y in zip(a, b, strict=True))


class FakeQuery:
    """A query handed to a World by hand: its replies are recorded as ("ok", bytes) or ("err", message)."""

    def __init__(self, key: str, payload: bytes):
        self.key, self.payload = key, payload
        self.replies: list[tuple[str, object]] = []

    def reply(self, data: bytes) -> None:
        self.replies.append(("ok", data))

    def reply_error(self, message: str) -> None:
        self.replies.append(("err", message))
