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
    """Enough of transport.Link for a World or a host driven by hand, below Zenoh: puts are recorded."""

    def __init__(self):
        self.published: list[tuple[str, bytes]] = []

    def publish(self, key, data, *, reliable=True):
        self.published.append((key, data))

    def serve(self, *a, **k):
        pass

    def subscribe(self, *a, **k):
        pass

    def watch_liveliness(self, *a, **k):
        pass


class FakeQuery:
    """A query handed to a World by hand: its replies are recorded as ("ok", bytes) or ("err", message)."""

    def __init__(self, key: str, payload: bytes):
        self.key, self.payload = key, payload
        self.replies: list[tuple[str, object]] = []

    def reply(self, data: bytes) -> None:
        self.replies.append(("ok", data))

    def reply_error(self, message: str) -> None:
        self.replies.append(("err", message))
