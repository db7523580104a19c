"""An example radio rule: long frames do not carry far.

Every (frame, receiver) pair whose frame body is longer than ``max_bytes`` and whose receiver is farther than
``beyond`` from the sender (at the send tick) is dropped under the cause ``long-frame``. A crude model of a
radio whose long packets need a better signal than short ones; the point is the shape of a rule: a name, a
cause, a typed ``Config`` and ``apply``, a mask over the pairs under decision.

Registered with one entry point (pyproject.toml of the package that ships it)::

    [project.entry-points."swarmactors.radio_rules"]
    long-frames = "long_frames:LongFrames"

and used from a scenario::

    [[radio.rules]]
    use = "long-frames"
    max_bytes = 32
    beyond = 0.6
    before = "loss"      # optional: run before the built-in loss rule (default: after every built-in rule)
"""

import msgspec

from world import LinkRule, Transmissions


class LongFrames(LinkRule):
    """Drop a frame longer than ``max_bytes`` to a receiver farther than ``beyond``."""

    name = "long-frames"
    cause = "long-frame"

    class Config(msgspec.Struct, forbid_unknown_fields=True):
        max_bytes: int  # body bytes a frame may have and still reach beyond ``beyond``
        beyond: float  # distance (length units) past which long frames are lost

    def apply(self, tx: Transmissions):
        if not len(tx):
            return None
        long = tx.sizes()[tx.frame] > self.config.max_bytes
        return long & (tx.distances() > self.config.beyond)
