"""A deliberately buggy flooding implementation, to show what `swarmactors check` reports.

The bug: a robot forwards the flood with one hop too many in its budget - it
forwards while ``now <= deadline + 1`` instead of ``now <= deadline`` - so
robots one hop beyond the expiry also receive it. Run from this directory:

    swarmactors check flooding --behavior buggy_flooding:LateFlood --clock lockstep

and see docs/conformance.md for the report.
"""

from protocols.flooding.behavior import Flooding
from swarmactors import Frame


class LateFlood(Flooding):
    """Accepts copies that arrive one tick after their deadline."""

    def on_frame(self, ctx, frame: Frame) -> None:
        body = frame.body
        if isinstance(body, dict) and body.get("dl") is not None:
            body = {**body, "dl": body["dl"] + 1}  # the bug: an off-by-one on the deadline
        super().on_frame(ctx, Frame(frame.src, frame.kind, body, frame.seq, frame.sent))
