"""Deliberately broken implementations: the conformance suites must catch each of them.

Each mutant changes one rule of a built-in behaviour; tests/test_conformance.py
runs the family's quick suite against it and expects the named case and check
to fail.
"""

from __future__ import annotations

import types

from protocols.biconnectivity import behavior as biconnectivity
from protocols.biconnectivity.behavior import Biconnectivity
from protocols.cbaa import behavior as cbaa
from protocols.cbaa.behavior import CBAA
from protocols.flooding.behavior import Flooding
from protocols.stigmergy.behavior import StigmergyScript
from protocols.stigmergy.table import Entry
from swarmactors import Frame


# -- flooding -----------------------------------------------------------------------------------
class FloodBackToSender(Flooding):
    """Forwards to every neighbour, the sender included (breaks 'all neighbours but the sender')."""

    def _send(self, ctx, msg, deadline, hop, exclude, payload=None):
        super()._send(ctx, msg, deadline, hop, (), payload)


class FloodIgnoresExpiry(Flooding):
    """Treats every copy as unexpired (breaks the deadline: robots beyond the expiry receive)."""

    def on_frame(self, ctx, frame):
        body = dict(frame.body) if isinstance(frame.body, dict) else frame.body
        if isinstance(body, dict):
            body["dl"] = None
        super().on_frame(ctx, Frame(frame.src, frame.kind, body, frame.seq, frame.sent))


_started_here: list[int] = []  # robots started in this process, ever


class FloodWithHiddenState(Flooding):
    """Delays its forward once this process has started more than four robots.

    Hidden global state, so the run depends on how the robots are spread over host processes.
    """

    def on_start(self, ctx):
        _started_here.append(ctx.id)
        self.lag = len(_started_here) > 4

    def _send(self, ctx, msg, deadline, hop, exclude, payload=None):
        if self.lag and hop > 1:
            ctx.after(1, lambda: Flooding._send(self, ctx, msg, deadline, hop, exclude, payload))
        else:
            super()._send(ctx, msg, deadline, hop, exclude, payload)


# -- cbaa -----------------------------------------------------------------------------------------
def _higher_id_pair(bid, winner):
    return (bid, float("-inf") if winner is None else winner)


class CBAAHigherIdWins(CBAA):
    """Breaks ties by the higher robot id (the rule says the lower)."""


for _name in ("_auction", "on_frame"):
    _f = getattr(CBAA, _name)
    setattr(CBAAHigherIdWins, _name, types.FunctionType(
        _f.__code__, {**vars(cbaa), "pair": _higher_id_pair}, _f.__name__, _f.__defaults__, _f.__closure__))


class CBAAKeepsOutbidTask(CBAA):
    """Keeps its task after being outbid (drops rule X1: two robots end up holding one task)."""

    def on_frame(self, ctx, frame):
        held = self.x
        super().on_frame(ctx, frame)
        if held is not None and self.x is None:
            self.x = held


# -- stigmergy -------------------------------------------------------------------------------------
class StigmergyNoRelay(StigmergyScript):
    """Stores a newer PUT but does not relay it (breaks P1: the write never spreads past one hop)."""

    def on_start(self, ctx):
        super().on_start(ctx)
        node = self.node

        def on_put(table, key, local, remote):
            if local is None or remote.ts > local.ts:
                table._store(key, remote)
            elif remote.ts == local.ts and remote.writer != local.writer:
                node._conflict(table, key, local, remote)

        node._on_put = on_put


class StigmergyLowerWriterWins(StigmergyScript):
    """Resolves equal-timestamp conflicts for the lower writer id (the default rule says the higher)."""

    def on_start(self, ctx):
        super().on_start(ctx)
        self.table.on_conflict = lambda key, local, remote: local if local.writer < remote.writer else remote


# -- biconnectivity ----------------------------------------------------------------------------
class _NoRelay:
    """A context that drops relayed stamped messages (stamp lists longer than one)."""

    def __init__(self, ctx):
        self._ctx = ctx

    def __getattr__(self, name):
        return getattr(self._ctx, name)

    def broadcast(self, kind, body=None, exclude=()):
        if kind in (biconnectivity.CR, biconnectivity.DCR) and isinstance(body, list) and len(body[1]) > 1:
            return
        self._ctx.broadcast(kind, body, exclude)


class BiconNoRelay(Biconnectivity):
    """Never relays stamped messages (breaks Algorithm 1: lists stay at the neighbours)."""

    def _on_stamped(self, ctx, frame, body):
        super()._on_stamped(_NoRelay(ctx), frame, body)


class BiconShortDCR(Biconnectivity):
    """Adds S2 to DCR when |S2| >= 1 (Algorithm 2 says > 1): tree neighbours look doubly connected."""

    def _on_stamped(self, ctx, frame, body):
        malformed = sum(self.malformed.values())
        super()._on_stamped(ctx, frame, body)
        if frame.kind == biconnectivity.DCR and sum(self.malformed.values()) == malformed:
            s = body.stamps
            if ctx.id in s and len(s[s.index(ctx.id) + 1:]) == 1:
                self.dcr.update(s[s.index(ctx.id) + 1:])


_ = Entry  # re-exported for mutants that build entries
