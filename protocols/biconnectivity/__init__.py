"""Biconnectivity by stamped messages (Ahmadi & Stone, "Keeping in Touch", AAAI 2006).

The paper's rules are the specification; what it defers to its companion paper
(Ahmadi & Stone 2006a: when the initiating messages are sent, when the lists are
reset) is chosen here so that its stated bounds hold, and marked *(choice)*.

Messages and lists
==================

A message is ``(T, S)``: a type T and the ordered list S of robot stamps; a robot
stamps by appending its id. Every CR/DCR frame also carries a *period* number p
(a documented extension): body ``[p, S]``.

* **R1 - relay (Algorithm 1).** On ``("CR", S)`` with own id not in S, a robot
  broadcasts ``("CR", S + [id])``; a message that already carries its id is
  received but never relayed. ``DCR`` frames are relayed the same way. There is
  no other suppression: a robot relays every copy, so the relay enumerates the
  simple paths of the graph. Per period, robot R *sends* one frame per simple
  path ending at R, and *receives* one per simple path ending at a neighbour of
  R (the ``biconnectivity.paths`` check counts them against the oracle).
* **R2 - CR-FILL.** Each robot starts a period by broadcasting ``("CR", [id])``.
  CR_R collects every id seen in the stamps R receives in the period (own id
  excluded). Complete within 3Nc.
* **R3 - DCR-FILL (Algorithm 2).** Each robot broadcasts ``("DCR", [id])``; on
  ``("DCR", S)`` containing its own id, it splits S = (S1, id, S2) and, if
  |S2| > 1, adds S2's ids to DCR_R (R, S2 and the sender, a neighbour, close a
  cycle). DCR_R is the set of robots sharing a cycle with R, i.e. a biconnected
  block of at least three robots. Complete within nc.
* **R4 - periods** *(choice)*. A period is numbered by the tick at which it was
  started. A robot *joins* period p on the first frame of p it hears (CR, DCR,
  CHECK-REQUEST, BUDGET) or when it starts p itself: it resets CR and DCR (the
  "first DCR message" reset of Algorithm 2) and broadcasts its two initiating
  messages, once per period. Frames of an older period are counted ``stale`` and
  neither relayed nor used; a newer period supersedes the current one. The join
  wave spreads at most c per hop, and every initiating message travels at most
  n-1 hops, so every CR/DCR frame of a period arrives within 2(n-1)c of the
  period's start, inside the paper's 3Nc.

The check (Algorithm 3)
=======================

* **R5.** An initiator (parameters ``initiator``, ``at``, optionally ``every``)
  starts a new period - or reuses its current one while that is younger than
  3Nc *(choice: concurrent initiators share a fill)* - and at once broadcasts
  ``("CHECK-REQUEST", [p, t_request, initiator])`` *(choice: the request goes out
  when the fills start, not after line 1's wait; the neighbours' fills are the
  same period's wave, so every decision still lands within 6Nc + 2c - within
  3Nc + 2c for a lone initiator)*. The initiator and every robot that hears a
  request run the check; one already running it ignores the request, one that
  already evaluated the period repeats its DC answer.
* **R6.** A check-running robot evaluates 3Nc after it joined the period: it
  broadcasts ``("DC-TRUE", [p])`` if |DCR| = |CR|, else ``("DC-FALSE", [p])`` and
  concludes false (line 7). Then, with DC answers of the period heard from
  neighbours (before or after its own evaluation): DC-FALSE -> false (line 9);
  DC-TRUE and |DCR| = |CR| -> true (lines 10-11; Theorem 1: two distinct robots
  doubly connected to all). *(choices)* A robot with an empty CR list concludes
  false at once (``reason = "alone"``; Theorem 1 needs two robots); an evaluated
  robot still undecided 6Nc + 2c after the request concludes ``null`` with
  ``reason = "timeout"`` (only possible with loss or failures).
* The verdict is the paper's biconnectivity of the robot's component as its CR
  list knows it: every pair doubly connected (Lemma 1), so a component of one
  or two robots is *not* biconnected (networkx says a single edge is).
* **R7 - budget** *(choice)*. A robot relays at most ``budget`` CR+DCR frames
  per period. The one that would exceed it stops relaying the period and floods
  ``("BUDGET", [p])`` (forward once); every robot that learns it stops relaying
  the period too, and a check-running robot concludes ``null`` with
  ``reason = "budget"`` at its evaluation time, so the run never hangs on the
  (n-1)! worst case.
* **R8 - verdict flood** (``flood_verdict``, beyond the paper). The initiator
  floods ``("VERDICT", [p, initiator, value, reason])`` once decided; robots
  without a verdict for the period adopt it (``reason = "flooded"``).
* **R9 - bad input.** A CR/DCR body that is not ``[p, S]`` with p a
  non-negative integer and S a non-empty list of at most N distinct integers
  whose last stamp is the sender is dropped, counted in ``malformed`` (by
  reason), and never relayed or joined.
* **R13 - repeated fills** (``repeat``, beyond the paper; default 1 = the
  paper). A robot sends each initiating message ``repeat`` times when it joins
  a period; every copy is relayed like any frame, so each simple path is tried
  ``repeat`` times with independent losses and a lost copy no longer removes
  an id from DCR as easily. Traffic grows ``repeat``-fold; the timing (3Nc,
  6Nc + 2c) is unchanged. A robustness layer for lossy links, which the paper
  does not have (Assumption 4: reliable links).
* **R14 - the graph the fills run on** (``graph``; default ``"radio"``). The
  paper calls two robots neighbours when they can talk from anywhere in their
  regions. With ``region = 0`` that is the radio graph. With regions, the
  radio reaches further than that, and ``graph = "structure"`` makes a robot
  ignore (count, not relay) CR/DCR frames from a sender whose region centre,
  as its table knows it (R10), is beyond the structure-neighbour distance: the
  check then judges the structure graph, the one Theorems 3 and 4 speak of.
* **R15 - agreeing periods** (``agree``, beyond the paper; default 1 = the
  paper). With ``agree = k > 1`` a check-running robot's conclusion of a period
  is not yet its verdict: the verdict is given once its last k periods
  concluded alike (true or false), or is null (``"no agreement"``) after
  ``max_periods``. Otherwise it runs the check's next period (the newer one a
  neighbour started, else one it starts) and broadcasts ``("CHECK-REQUEST",
  [p, t_request, initiator, k])``; robots running that check follow (a decided
  one only answers DC in p, keeping its verdict), others just join p (R4).
  Each period has the paper's timeout; the check's bound is
  ``max_periods`` x (6Nc + 2c).

Maintaining the structure (add and remove)
==========================================

Robots sit at the centres of their circular regions (radius ``region``). Two
robots are *structure neighbours* when they can talk from anywhere in their
regions: distance between centres + 2·region <= range (the robot's radio range,
``ctx.range``, from its robot group), and a safety ``margin`` (fraction of that
distance) is kept so that rounding never breaks a link.

* **R10 - positions** *(choice)*. Every ``hello`` ticks each robot broadcasts
  ``("HELLO", table)``: its table of (id, centre, stamp tick, neighbour ids) for
  every robot it knows, merged by newest stamp. Robots thus learn neighbours,
  neighbours of neighbours and (approximate, delayed) centres of everybody,
  the knowledge the paper assumes.
* **R11 - add (Theorem 3).** A ``joiner`` broadcasts ``("POS-REQUEST")``; robots
  answer ``("POS-REPLY", table)``. It picks the candidate position within the
  neighbour distance of at least two robots that maximises the sum of the
  distances to its two closest region centres (``placement = "heuristic"``; or
  the minimum total intersection with the other regions,
  ``"min_intersection"``), goes towards the first of these two robots, asks
  again from there, re-optimises under the constraint of being a neighbour of
  both, goes there and settles (starts its HELLOs).
* **R12 - remove (Theorem 4).** A robot whose neighbour r has not been heard
  for ``silence`` ticks, or which hears ``("LEAVE")`` from it, takes r as
  removed. The lowest-id neighbour of r (from r's last advertised neighbour
  list) leads: it steps d = 0, d_step, 2·d_step, ... until its model of r's
  ex-neighbours, each moved d towards r's ex-position (clamped at it), is
  biconnected (two robots: adjacent, which the proof of Theorem 4 needs;
  *choice*); it floods ``("MOVE", [leader, round, r, pos, d, start, speed])``
  (forward once) with start = now + N·c + 1 tick, the flood's worst delivery
  time, so that every robot starts moving at the same tick, at the common
  ``speed``, d towards pos (clamped at pos). The positions at every instant are
  the proximal map x -> pos + (x-pos)·max(0, 1 - s/|x-pos|), which is
  1-Lipschitz: no link is ever lengthened. After the move the leader runs the
  check; while it says false it floods further moves of ``d_more``, at most
  ``max_rounds`` rounds.

Units: ``at``, ``every``, ``hello``, ``silence`` are ticks; ``c`` is the per-hop
bound in the clock's unit (ticks in lockstep, seconds in realtime); lengths in
world units; ``speed`` in units per second. The radio range and the seconds per
tick are the scenario's, read from the context (``ctx.range``, ``ctx.dt``), never
parameters: the structure-neighbour distance and the default ``d_step`` and
``d_more`` are derived from them in ``on_start``.
"""

