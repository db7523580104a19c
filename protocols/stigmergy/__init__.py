"""Virtual stigmergy: a replicated key -> value table shared through neighbour messages.

The semantics are those of the Buzz language's virtual stigmergy (Pinciroli &
Beltrame, reference [28] of Swarm Relays, 002 Sec. III-D), which Swarm Relays
uses to share task assignments, paths and election results. A robot may hold
several tables, one per stigmergy id (``sid``). An entry is ``(value,
timestamp, writer)``: the timestamp is a Lamport clock per key, the writer the
id of the robot that wrote that version. ``None`` is Buzz's nil.

Local operations
  W1 ``put(k, v)`` on a key with a local entry: timestamp = local + 1, writer =
     self; on an unknown key: timestamp 1. It queues a VS_PUT.
  W2 ``put(k, None)`` deletes: it stores a *tombstone* (nil value with the new
     timestamp and writer) and queues a VS_PUT carrying the nil. Buzz drops the
     entry instead, so that an older PUT still in flight brings the key back at
     the deleting robot (its neighbours keep the nil and diverge from it for
     ever); ``tombstones = False`` restores Buzz's behaviour. ``put(k, None)``
     on an unknown key does nothing (as in Buzz).
  W3 ``get(k)`` returns the local value at once (nil when missing or deleted)
     and queues a VS_QUERY carrying the local entry (timestamp 0 when there is
     none). ``peek(k)`` is the same read without the query (not in Buzz).

Receiving a VS_PUT (remote entry r, local entry l)
  P1 no local entry, or r newer (r.ts > l.ts): store r and relay it;
  P2 same timestamp, different writer: a conflict, resolved by the table's
     ``on_conflict(key, l, r)`` which returns the winning entry; the winner is
     stored and relayed; when the local entry was this robot's own write and
     it lost, ``on_conflict_lost(key, l)`` is called;
  P3 older, or the identical (timestamp, writer): ignore, do not relay - this
     is what stops the flood.

Receiving a VS_QUERY (r: the querier's entry, timestamp 0 when it has none)
  Q1 r.ts = 0 and no local entry: relay the query once per (sid, key,
     querier, query number) - Buzz relays it on every receipt, which keeps a
     query for a key that nobody holds bouncing for ever;
  Q2 r.ts = 0 and a local entry: answer with a VS_PUT of the local entry;
  Q3 r newer than the local entry (or no local entry): store r, relay a VS_PUT;
  Q4 local entry newer: answer with a VS_PUT of the local entry;
  Q5 same timestamp, different writer: conflict, as P2;
  Q6 identical: ignore.

Conflict rule (``conflict`` parameter, or any ``on_conflict`` callable)
  C1 default (Buzz): a non-nil value beats a nil one; otherwise the higher
     writer id wins. ``lower_value`` (elections) and ``higher_value`` compare
     the values (lists lexicographically), then the higher writer id. Every
     built-in rule picks the larger of the two entries under a total order,
     so all robots resolve the same set of concurrent writes to the same
     winner in any order of arrival. A custom handler must do the same;
     if it returns an entry that is neither argument, its value and writer
     are kept with the local timestamp (Buzz's rule).

Outgoing queue
  O1 at most one message per (sid, key) is queued per tick: a newer entry
     (higher timestamp) replaces the queued one; at equal timestamps a PUT
     outranks a QUERY and otherwise the later one (which reflects the local
     table after conflict resolution) replaces the earlier. The queue is sent
     in ``flush``, once per tick, in the order keys were first queued.

Anti-entropy (optional, not in Buzz)
  A1 every ``anti_entropy`` ticks a robot with a non-empty table broadcasts a
     VS_DIGEST (sid, [(key, ts, writer), ...]) of that table;
  A2 on a digest: for a key where the sender is newer (or that is unknown
     locally), send the sender an addressed VS_QUERY with the local entry (it
     answers by Q2/Q4); where the local entry is newer, or has the same
     timestamp and another writer, or the digest lacks the key, broadcast a
     VS_PUT of the local entry (a conflict is then resolved by P2 on the other
     side); identical entries: nothing.

Bad input: a body that is not the expected list, a sid or key that is not an
int or str, a timestamp that is not an integer (or < 1 in a PUT, < 0 in a
QUERY), a writer that is not a non-negative integer, or a malformed digest is
dropped and counted in ``malformed`` by reason. Timestamps are unbounded
Python integers (Buzz's wrap at 2^16).

Elections (Swarm Relays' "gradient" elections of the root and of one worker
per target): ``Election`` runs a lowest-bid-wins election over a table whose
conflict rule is ``lower_value``. While the election is open (``start`` to
``start + duration``) every robot whose bid ``[bid, id]`` beats the table's
current value puts it (E1); the conflict rule keeps the lowest ``[bid, id]``
(E2); at the close every robot reads the winner with ``get`` (E3). With
``exclusive`` elections run one after the other and a robot that won one does
not bid in the later ones (E4).

Keys appear in reports and result.json as strings: the keys 1 and "1" would
collide there (they are distinct in the table).
"""

