"""Connectivity maintenance by distributed role switching (Kobayashi, Higuchi & Ueno, 2022).

Roles: the base station (fixed at the origin), repeaters (a chain base station -> ... -> local leader; each
links one parent and one child), one local leader (links its parent and its explorers) and explorers (link
each other and the local leader by the acute angle test). Every robot sends its state (role, position,
velocity, control input, |A_i|, epoch) to the robots in A_i every tick. Full rules and the values chosen
where the paper gives none: docs/protocols/roles.md. In short:

Algorithm 1 (local leader i, parent p, d = |x_i - x_p|), made safe under loss
  H1 d > eta_a d_c: request the linked explorer c with the largest |A_c| to become local leader (EXTEND);
     d < eta_b d_c and p is not the base station: request p (RETRACT). The ROLE_REQUEST carries the
     leadership epoch e + 1, the switch tick T = now + switch_delay, the goal and its index.
  H2 the requester re-sends the request every tick until it is answered; the candidate answers every copy
     with ROLE_ACK (or ROLE_NACK with a reason, counted in ``refused``: unknown_role, not_requestable,
     not_neighbour, base_station, role_conflict, stale; a request that does not decode is refused unanswered,
     under the decoder's cause).
  H3 the candidate switches at tick max(T, arrival of the first request): explorer -> local leader (its
     parent: the requester) or repeater -> local leader (the requester becomes one of its explorers).
  H4 the requester switches at max(T, first evidence), evidence being the ACK or a STATE / flood from the
     candidate claiming epoch e + 1: local leader -> repeater (child c; it drops its explorer links with
     DISCONNECT) or -> explorer. With no answer by T + lease it keeps the lead and raises its epoch to e + 2
     (lease expired: the request is taken as lost).
  H5 a local leader that hears (STATE or flood) of a local leader with a larger (epoch, id) steps down: it
     completes its own hand-over if that robot is its candidate, reverts to its previous role if it took the
     lead from that robot, and becomes an explorer otherwise.
  H6 (ours) a local leader or repeater beyond hold x d_c from its parent heads back to it; a repeater beyond
     hold x d_c from its child does not move away from it (it stands still if both pulls conflict).
  Without loss the two switch on the same tick T: exactly one local leader at every tick. With loss the gap
  without exactly one leader is 0 unless every answer by T was lost; it then lasts until the first answer
  arrives (two chances per tick), or until the lease ends (H4/H5).

Algorithm 2 (``aat.py``): the acute angle test on all sensed robots when the role changed, when
|A_i| < eta_c or when the robot is disconnected; otherwise only on the links whose circle C_ij now holds a
robot, and on those robots. New links are requested with CONNECT, dropped links announced with DISCONNECT;
a robot that receives a STATE from a robot it does not link tests that robot at its next tick (repair under
loss). Repeaters and the base station refuse explorer links (DISCONNECT with their role). The baseline runs
the test on every detectable robot every tick.

Motion: Eqs. 1-3 (repeaters, local leader) and 4-7 (explorers), u capped at vmax = 0.03 per timestep; the
unicycle turn rate (0.15 rad per timestep) is the world's. u_LL and x_LL reach the explorers by the
message-expiration flooding of Sec. III-C (rules F1-F3 of ``protocols.flooding``: expired copies ignored,
the first copy delivered once, forwarded to every link but the sender).

Recovery (Sec. III-D): an explorer that has heard no fresh u_LL for ``lost_after`` ticks is disconnected:
it heads to the origin, runs the acute angle test on everything it senses, asks (RS_HELP) any repeater or
the base station in range for the position of its child (RS_WHERE), heads there, asks the next repeater,
and is back when a fresh u_LL reaches it through a link.

Files: ``behavior.py`` (the robot side: RoleSwitching, AATWalk), ``params.py`` (RoleSwitching's parameters,
validated in one place), ``rules.py`` (the motion laws, Algorithm 1's request and its answer as pure
functions), ``aat.py`` (the acute angle test), ``oracle.py`` (checks), ``scenarios.py`` (placements and
scenarios) and ``suite.py`` (the conformance family).
Nothing is imported here, so loading the behaviour loads no oracle.
"""
