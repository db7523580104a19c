"""CBAA: the consensus-based auction algorithm (Choi, Brunet & How 2009), as neighbour messages.

Swarm Relays (002 Sec. III-D, its reference [26]) allocates free robots to
tasks with CBAA, the single-assignment case of CBBA. Robot i keeps

* c_ij, its score for task j (fixed at the start from its position: a
  positive, decreasing function of the distance, or a scenario matrix);
* x_i, the task it holds (or none);
* y_ij and z_ij, the winning bid and the winner it believes for each task;
* (table consensus only) s_ik, the time of the freshest information it has
  from robot k.

Bids are compared as pairs (bid, -id): the higher bid wins and equal bids go
to the lower robot id. Every tick from ``at`` on, a robot

  A1 (auction, only while it holds no task) takes, among the tasks whose
     (c_ij, -i) beats (y_ij, -z_ij) and whose score is positive, the one with
     the largest c_ij (ties: the lowest task index) and bids on it:
     x_i = J, y_iJ = c_iJ, z_iJ = i;
  A2 broadcasts a BID frame {t: x_i, y: y_i, z: z_i, s: s_i} when its state
     changed since its last frame, and otherwise every ``every`` ticks.

On a BID frame from k (consensus):

  M1 ``max`` rule (the paper's synchronous CBAA): for every task, (y_ij, z_ij)
     becomes the larger pair of its own and the sender's;
  T1 ``table`` rule (asynchronous CBBA, Choi et al. 2009, Table 1): for every
     task, update (copy the sender's y_kj, z_kj), reset (y_ij = 0, z_ij =
     none) or leave, by the receiver's and the sender's beliefs of the winner
     and the freshness of their information on it (table below); then
     s_ik = now and s_im = max(s_im, s_km) for every other m;
  X1 with either rule, if z_iJ is no longer i for the task J it holds, it
     drops J (x_i = none) and bids again in its next auction.

``consensus = "auto"`` (the default) uses M1 in lockstep, where ticks are the
paper's synchronous rounds, and T1 under the realtime clock, where frames
arrive late and out of order. With static scores the pairs of CBAA only grow
(a bid is only ever replaced by a larger one), so M1 is already immune to
stale frames; T1 matters once bids may fall (a task released, scores that
change). Both converge to the sequential greedy assignment on a static
connected network (repeatedly give the largest remaining (c_ij, -i, -j)
pair's task to its robot), and M1 within N_min * D rounds (D the diameter).

Table T1: i the receiver, k the sender, m and n other robots; "k newer on m"
means s_km > s_im; "higher" means (y_kj, -z_kj) > (y_ij, -z_ij).

| sender z_kj | receiver z_ij | action                                               |
|-------------|---------------|------------------------------------------------------|
| k           | i             | update if higher, else leave                         |
| k           | k             | update                                               |
| k           | m             | update if k newer on m or higher, else leave         |
| k           | none          | update                                               |
| i           | i             | leave                                                |
| i           | k             | reset                                                |
| i           | m             | reset if k newer on m, else leave                    |
| i           | none          | leave                                                |
| m           | i             | update if k newer on m and higher, else leave        |
| m           | k             | update if k newer on m, else reset                   |
| m           | m             | update if k newer on m, else leave                   |
| m           | n             | update if k newer on m and on n; update if k newer   |
|             |               | on m and higher; reset if k newer on n and i newer   |
|             |               | on m; else leave                                     |
| m           | none          | update if k newer on m, else leave                   |
| none        | i             | leave                                                |
| none        | k             | update                                               |
| none        | m             | update if k newer on m, else leave                   |
| none        | none          | leave                                                |

Timestamps are ``ctx.now`` (ticks in lockstep, seconds since the run started
in realtime); a robot never heard of has time -inf.

Bad input: a BID body that does not decode as the typed ``Bid`` (messages.py)
is dropped under the decoder's cause (``not_a_map``, ``missing_field``,
``bad_field``: non-numeric or negative bids, winners that are not robot ids);
one whose y or z table does not have one entry per task (``wrong_length``),
whose own task t is past the last task (``unknown_task``), or with a bid
without a winner or t not matching z (``inconsistent``) is dropped too. All
are counted in ``dropped`` by reason.

Parameters: ``tasks`` = [[x, y], ...] (a task's id is its index), ``at``
(first tick), ``score`` (``inverse`` 1/(1 + d/scale), ``exp`` exp(-d/scale),
``linear`` max(0, scale - d), or a score registered under the entry-point group
``swarmactors.cbaa.scores`` as f(robot_pos, task_pos, scale)),
``scale``, ``scores`` (an explicit matrix, one row per robot id, overriding
``score``), ``consensus`` (``auto`` | ``max`` | ``table``), ``every``
(rebroadcast period in ticks while nothing changes), ``quiet_after`` (stop
rebroadcasting after that many unchanged ticks; none = never).
"""

