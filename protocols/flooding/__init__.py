"""Message-expiration flooding (Kobayashi et al. 2022, Sec. III-C).

The originator broadcasts (origin, msg_id, deadline, payload), the deadline
being the send time plus the expiration period. Rules, per robot:

* F1 - a copy that arrives after its deadline is ignored (counted ``expired``);
* F2 - the first copy of (origin, msg_id) is delivered once (``received``
  records its hop count, arrival time and sender);
* F3 - on that first copy, while the deadline has not passed (arrival <=
  deadline), the robot forwards it to all its neighbours except the sender
  (a broadcast excluding the sender);
* F4 - with a hop limit H (option ``hops``), a copy travels at most H hops, and
  a robot forwards again when a copy arrives with strictly more hops left
  than any before, so that asynchrony cannot hide a robot behind a long path.

* F1r - with ``lifetime = "remaining"`` a copy carries the lifetime
  it has left instead of the deadline; each hop consumes ``hop_cost`` (the
  paper's "single timestep per hop", default one tick) and a copy with a
  negative remainder has expired. No clock is compared across robots.

With a time deadline alone, forwarding on first arrival reaches exactly the
robots whose earliest possible arrival is not after the deadline: in lockstep
with per-hop latency c, the robots within floor(expiry / c) hops.

Parameters: ``origin`` (robot id), ``at`` (tick of origination), ``expiry``
(ticks in lockstep, seconds in realtime; none = no deadline), ``hops``
(optional limit), ``payload``, ``lifetime`` ("deadline" or "remaining"),
``hop_cost``. One flood per run.
"""
