"""λ2 estimation: the body of each frame kind as a msgspec Struct (robot side, no I/O).

One kind, ``L2``: every robot sends one per iteration. ``k`` and ``v`` are always there; the other fields
only when the method carries them (``dm`` in the warm-up, ``n`` for PI1's flooded norm, ``a`` and ``m`` for
PI2's consensus), so a PI1 or wave frame is the same dict as before the Struct existed. ``decode`` turns a
received body into an ``L2`` or a refusal cause; ``encode`` gives the dict that is sent (absent fields left
out).
"""

from __future__ import annotations

import math

import msgspec

KIND = "L2"


class L2(msgspec.Struct, omit_defaults=True, forbid_unknown_fields=True):
    """One iteration's frame: iteration ``k``, value ``v`` (x_i or s_i), and what the method piggybacks.

    ``dm``: the largest degree heard (warm-up); ``n``: PI1's flood record (epoch, norm > 0, period length);
    ``a``, ``m``: PI2's average-consensus and max-consensus values.
    """

    k: int
    v: float
    dm: int | None = None
    n: tuple[int, float, int] | None = None
    a: float | None = None
    m: float | None = None


def decode(body: object, flood: int) -> L2 | str:
    """Return the body as an ``L2``, or why it is refused.

    "malformed": not the Struct, or a flood record whose norm is not > 0 or whose length is not > ``flood``
    + 2; "nonfinite": a NaN or infinite number.
    """
    try:
        msg = msgspec.convert(body, L2, strict=True)
    except (msgspec.ValidationError, TypeError):
        return "malformed"
    values = [msg.v, msg.a, msg.m] + ([msg.n[1]] if msg.n is not None else [])
    if any(x is not None and not math.isfinite(x) for x in values):
        return "nonfinite"
    if msg.n is not None and (msg.n[1] <= 0.0 or msg.n[2] <= flood + 2):
        return "malformed"
    return msg


def encode(msg: L2) -> dict:
    """The dict that goes on the radio: the fields that are set, in the Struct's order."""
    out = msgspec.to_builtins(msg)
    if "n" in out:
        out["n"] = list(out["n"])
    return out
