"""The lockstep barrier: a tick ends when every registered live host has sent its step for it.

A host registers once (tick -1: held until its first inputs go out); then it may send only the awaited tick's
step, once, or, after the last tick, its final report. A stale, future or repeated step is refused (the session
counts it as malformed) and never stands in for the awaited one. Only hosts that registered are waited for: a
join alone never stalls a tick.
"""

from __future__ import annotations

import asyncio

from transport.messages import Uplink


class Barrier:
    """Each host's pending step (or registration), and the tick awaited from every host of the barrier."""

    def __init__(self):
        self.held: dict[str, tuple[int, Uplink | None]] = {}
        self.awaited = -1
        self.all_in = asyncio.Event()

    def open(self, tick: int) -> None:
        """Await ``tick``'s steps."""
        self.awaited = tick
        self.all_in.clear()

    def release(self, host: str) -> bool:
        """Forget ``host``'s pending step or registration; whether it had one (then its next inputs go out)."""
        return self.held.pop(host, None) is not None

    def step(self, host: str) -> Uplink | None:
        """``host``'s step of the awaited tick, if it is held."""
        t, msg = self.held.get(host, (None, None))
        return msg if t == self.awaited else None

    def stepped(self, host: str) -> bool:
        """The host has the awaited step (or its registration) pending."""
        held = self.held.get(host)
        return held is not None and (held[0] >= self.awaited or held[0] == -1)

    def problem(self, host: str, msg: Uplink, registered: bool, reported: bool, started: bool,
                collecting: bool) -> str | None:
        """Why ``msg`` is not a step (or final report) the barrier takes from ``host`` now (None if it is)."""
        if host in self.held:  # one step per host per tick: a second one is a replay or a forgery
            return f"a second step while one is pending (tick {msg.tick})"
        if msg.reports is not None and reported:
            return "a second report"
        if msg.tick == -1:
            return "registered already" if registered else None
        if msg.reports is not None:
            if msg.tick > self.awaited or collecting:
                return None
            return f"report for tick {msg.tick} before the end"
        if not started or msg.tick != self.awaited:
            what = "stale" if msg.tick < self.awaited else "future"
            return f"{what} step for tick {msg.tick} (awaited: {self.awaited if started else -1})"
        return None

    def hold(self, host: str, msg: Uplink, hosts: list[str]) -> None:
        """Hold ``msg`` (checked by ``problem``); ``hosts``: those of the barrier, all in opens it."""
        self.held[host] = (msg.tick, msg)
        self.check(hosts)

    def check(self, hosts: list[str]) -> None:
        """Open the barrier if every one of ``hosts`` has stepped."""
        if all(self.stepped(h) for h in hosts):
            self.all_in.set()

    async def wait(self, hosts: list[str], limit: float) -> bool:
        """Wait until every one of ``hosts`` stepped (``check`` opens it), ``limit`` s at most; whether they did."""
        if all(self.stepped(h) for h in hosts):
            return True
        try:
            async with asyncio.timeout(limit):  # no task per wait, as asyncio.wait_for makes one on Python 3.11
                await self.all_in.wait()
        except TimeoutError:
            return False
        return True
