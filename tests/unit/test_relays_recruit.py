"""Swarm Relays' recruiting (R5, Sec. IV and Proposition 1) on one robot at a time, below Zenoh.

The head's request travels down the chain towards the root until a robot with free neighbours; that robot opens
the CBAA slot and the recruit goes in front of it (between its parent and itself); only a base without free
neighbours asks the root.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from protocols.relays import motion
from protocols.relays.behavior import FREE, JOIN, NEED, NETWORKER, TASK, WORKER, Relays
from protocols.relays.messages import BODIES, CHAIN, Join, Need

DT = 0.2


class Ctx(SimpleNamespace):
    """The part of the robot context the recruiting rules use; it records what the robot sends."""

    def __init__(self, rid: int, tick: int = 100, position=(0.0, 0.0)):
        super().__init__(id=rid, tick=tick, dt=DT, position=list(position), sent=[], cast=[])

    def send(self, dst, kind, body):
        self.sent.append((dst, kind, body))

    def broadcast(self, kind, body, exclude=()):
        self.cast.append((kind, body))


def chain_body(said: dict):
    """A REL_CHAIN body as a robot receives it (decoded)."""
    return BODIES.decode_body(CHAIN, said)


# the chain 0 (root) - 1 (base) - 2 - 3 (head) along the x axis, 1.4 m apart (every link stretched)
X = {0: (0.0, 0.0), 1: (1.4, 0.0), 2: (2.8, 0.0), 3: (4.2, 0.0), 5: (0.2, 0.6)}
PARENT = {1: 0, 2: 1, 3: 2}
CHILD = {1: 2, 2: 3, 3: None}


def robot(rid: int, hears_free: bool, tick: int = 100, wp: bool = False) -> tuple[Relays, Ctx]:
    r = Relays([[8.0, 0.0]], root=0, wp=wp)
    r.rel = SimpleNamespace(peek=lambda key: None)  # no stigmergy: no flying slots
    r.role = WORKER if CHILD[rid] is None else NETWORKER
    r.chain, r.parent, r.child, r.depth = 0, PARENT[rid], CHILD[rid], rid
    r.plan = {"pe": True, "pi": [[0.0, 0.0], [8.0, 0.0]], "pig": [[0.0, 0.0], [8.0, 0.0]], "n": 6}
    r.root_pos = np.array(X[0])
    r.sensed = {j: np.array(p) for j, p in X.items() if j != rid}
    for j in (r.parent, r.child):
        if j is not None:
            r.heard[j] = (tick, chain_body({"r": NETWORKER, "c": 0, "p": PARENT.get(j), "ch": CHILD.get(j), "d": j}))
    if hears_free:
        r.heard[5] = (tick - 1, chain_body({"r": FREE, "c": None, "p": None, "ch": None, "d": None}))
    return r, Ctx(rid, tick, X[rid])


def test_a_head_without_free_neighbours_passes_its_request_down():
    head, ctx = robot(3, hears_free=False)
    head._recruit(ctx)
    assert ctx.sent == [(2, NEED, {"c": 0})] and not head.pending and not ctx.cast


def test_the_request_travels_down_past_robots_without_free_neighbours():
    mid, ctx = robot(2, hears_free=False)
    mid._on_need(ctx, 3, Need(0))
    assert ctx.sent == [(1, NEED, {"c": 0})]  # passed on towards the root
    mid._recruit(ctx)
    assert not mid.pending and not ctx.cast  # it does not recruit


def test_the_first_robot_with_free_neighbours_recruits_in_front_of_itself():
    mid, ctx = robot(2, hears_free=True)
    mid._on_need(ctx, 3, Need(0))
    assert ctx.sent == []  # the request stops here
    mid._recruit(ctx)
    assert mid.pending[0]["parent"] == 1 and mid.pending[0]["child"] == 2  # between its parent and itself
    ((kind, task),) = ctx.cast
    assert kind == TASK and task["c"] == 0 and task["pos"] == list(X[1])  # the recruit goes to the parent first
    # CBAA: robot 5 holds the slot at the close; the recruiter calls it to sit between 1 and 2
    mid.pending[0]["z"], mid.pending[0]["y"] = 5, 0.5
    ctx.tick = mid.pending[0]["close"]
    mid._recruit(ctx)
    assert (5, JOIN, {"c": 0, "parent": 1, "child": 2, "key": task["key"]}) in ctx.sent
    # the recruit names 1 as parent and 2 as child; within d_s, robot 2 takes it as its parent
    mid.sensed[5] = np.array([2.1, 0.1])
    mid._on_chain(ctx, 5, chain_body({"r": NETWORKER, "c": 0, "p": 1, "ch": 2, "d": 2, "up": [5, 1, 0], "dn": [5]}))
    assert mid.parent == 5 and mid.depth == 3
    ctx.tick += 1
    mid._recruit(ctx)
    assert 0 not in mid.pending and mid.joined[-1] == [ctx.tick, 5]


def test_a_head_with_free_neighbours_recruits_itself():
    head, ctx = robot(3, hears_free=True)
    head._recruit(ctx)
    assert ctx.sent == [] and head.pending[0]["parent"] == 2 and head.pending[0]["child"] == 3


def test_the_old_parent_takes_the_recruit_as_its_child():
    """Robot 1's child 2 took recruit 6 (which names 1 as parent, 2 as child): 6 is 1's child now, in either order."""
    for order in ((2, 6), (6, 2)):
        base, ctx = robot(1, hears_free=False)
        said = {2: chain_body({"r": NETWORKER, "c": 0, "p": 6, "ch": 3, "d": 3}),
                6: chain_body({"r": NETWORKER, "c": 0, "p": 1, "ch": 2, "d": 2})}
        base._on_chain(ctx, order[0], said[order[0]])
        assert base.child == 2
        base._on_chain(ctx, order[1], said[order[1]])
        assert base.child == 6
    other, ctx = robot(1, hears_free=False)  # a robot naming 1 as parent but not sitting above 2: ignored
    other._on_chain(ctx, 2, chain_body({"r": NETWORKER, "c": 0, "p": 6, "ch": 3, "d": 3}))
    other._on_chain(ctx, 6, chain_body({"r": NETWORKER, "c": 0, "p": 1, "ch": 4, "d": 2}))
    assert other.child == 2


def test_a_base_without_free_neighbours_asks_the_root_which_recruits_in_front_of_it():
    base, ctx = robot(1, hears_free=False)
    base._on_need(ctx, 2, Need(0))
    base._recruit(ctx)
    assert ctx.sent == [(0, NEED, {"c": 0})] and not base.pending
    root = Relays([[8.0, 0.0]], root=0)
    root.rel = SimpleNamespace(peek=lambda key: None)
    root.role, root.root_pos = "root", np.array(X[0])
    root.heard[1] = (100, chain_body({"r": NETWORKER, "c": 0, "p": 0, "ch": 2, "d": 1}))
    rctx = Ctx(0)
    root._on_need(rctx, 1, Need(0))
    assert root.pending[0]["parent"] == 0 and root.pending[0]["child"] == 1


def test_a_slot_that_closes_empty_sends_the_next_requests_down_for_forget_time():
    mid, ctx = robot(2, hears_free=True)
    mid._on_need(ctx, 3, Need(0))
    mid._recruit(ctx)
    ctx.tick = mid.pending[0]["close"]
    mid._recruit(ctx)  # nobody bid
    assert 0 not in mid.pending and mid.slot_empty_at == ctx.tick
    ctx.sent.clear()
    mid.heard[5] = (ctx.tick, mid.heard[5][1])
    mid._on_need(ctx, 3, Need(0))
    assert ctx.sent == [(1, NEED, {"c": 0})]
    ctx.tick += mid._ticks(ctx, "forget") + 1
    mid.heard[5] = (ctx.tick, mid.heard[5][1])
    ctx.sent.clear()
    mid._on_need(ctx, 3, Need(0))
    assert ctx.sent == []  # it recruits again


def test_with_wp_prediction_a_stretched_robot_with_free_neighbours_recruits_unasked():
    mid, ctx = robot(2, hears_free=True, wp=True)
    mid._recruit(ctx)
    assert mid.pending[0]["parent"] == 1 and ctx.sent == []
    far, ctx = robot(2, hears_free=False, wp=True)
    far._recruit(ctx)
    assert not far.pending and ctx.sent == []  # not the base: without free neighbours it waits


def test_a_recruit_beyond_d_s_of_its_parent_heads_for_it_not_back_along_pi():
    """Eq. 6 would send it back along pi (towards the root, away from a parent further out): it goes to the parent."""
    r, ctx = robot(2, hears_free=False)
    r.acked, r.child = False, 3  # a recruit its child has not taken yet
    r.joined = [[ctx.tick, 0]]
    r.path, r.s = (np.array([[0.0, 0.0], [8.0, 0.0]]), np.array([0.0, 8.0])), None
    x = np.array([0.3, -0.8])  # beside the root, 2.06 m from its parent 1 at (2.2, 0)
    r.sensed = {0: np.array(X[0]), 1: np.array([2.2, 0.0]), 3: np.array([3.6, 0.0])}
    moves = []
    ctx.position, ctx.map, ctx.rng = list(x), None, np.random.default_rng(0)
    ctx.move = moves.append
    r._move(ctx)
    ((u,),) = [moves]
    to_parent = (r.sensed[1] - x) / np.linalg.norm(r.sensed[1] - x)
    assert np.dot(u, to_parent) > 0.45  # towards the parent, nearly at v_max
    r.acked, r.child = True, None  # not a fresh recruit: Eq. 6 as written (back along pi, towards the root)
    moves.clear()
    r._move(ctx)
    assert np.dot(moves[0], to_parent) < np.dot(u, to_parent) - 0.2


def test_a_free_robot_bids_only_on_slots_within_d_s_of_the_recruits_parent():
    r = Relays([[8.0, 0.0]], root=0)
    r.role = FREE
    near = {"pos": [1.0, 0.0], "close": 110, "y": -np.inf, "z": None, "owner": 2, "chain": 0, "fly": False}
    far = {**near, "pos": [3.0, 0.0], "owner": 3}
    r.slots = {"2:1": dict(near), "3:1": dict(far)}
    ctx = Ctx(7, position=(0.2, 0.3))
    r._bid(ctx)
    assert r.choice == "2:1" and r.slots["2:1"]["z"] == 7 and r.slots["3:1"]["z"] is None
    r.slots, r.choice = {"3:1": dict(far)}, None
    r._bid(ctx)
    assert r.choice is None  # 2.8 m from the slot's parent: it would be a link beyond d_b at once


def test_a_recruit_not_yet_taken_does_not_recruit_it_passes_the_request_on():
    mid, ctx = robot(2, hears_free=True)
    mid.acked = False
    mid._on_need(ctx, 3, Need(0))
    assert ctx.sent == [(1, NEED, {"c": 0})]


def test_the_call_is_repeated_while_the_winner_is_still_heard_free():
    mid, ctx = robot(2, hears_free=True)
    mid._on_need(ctx, 3, Need(0))
    mid._recruit(ctx)
    mid.pending[0]["z"] = 5
    ctx.tick = mid.pending[0]["close"]
    mid._recruit(ctx)
    assert [s[1] for s in ctx.sent] == [JOIN]
    ctx.tick += 1
    mid.heard[5] = (ctx.tick - 1, chain_body({"r": FREE}))  # the call was lost: still free
    mid._recruit(ctx)
    assert [s[1] for s in ctx.sent] == [JOIN, JOIN]
    ctx.tick += 1
    mid.heard[5] = (ctx.tick - 1, chain_body({"r": NETWORKER, "c": 0, "p": 1, "ch": 2}))  # it joined
    mid._recruit(ctx)
    assert [s[1] for s in ctx.sent] == [JOIN, JOIN]


def _release_race(arrives: int, lost: tuple = ()) -> list[tuple[int, str, int | None]]:
    """Recruit 6 joins at tick 100 between the root and the base 1; 1 first senses it within d_s at ``arrives``.

    REL_CHAIN frames reach the other robot one tick after they are sent, as in lockstep; the base's frames sent
    at the ticks ``lost`` do not reach the recruit. Returns, tick by tick, the recruit's role and the base's parent.
    """
    recruit = Relays([[8.0, 0.0]], root=0)
    recruit.rel = SimpleNamespace(peek=lambda key: None, entry=lambda key: None)  # no plan yet
    rctx = Ctx(6, tick=100, position=(-0.3, -0.3))
    recruit._on_join(rctx, Join(0, 0, 1, "1:1"))
    base, bctx = robot(1, hears_free=False, tick=100)
    said = {}  # what each robot broadcast at the tick before
    seen = []
    for t in range(101, 140):
        rctx.tick = bctx.tick = t
        base.sensed[6] = np.array([0.3, 0.0]) if t >= arrives else np.array([-0.3, -0.3])  # 1.1 m / 1.73 m
        if said:
            base._on_chain(bctx, 6, chain_body(said[6]))
            if t - 1 not in lost:
                recruit._on_chain(rctx, 1, chain_body(said[1]))
        recruit._links(rctx)
        recruit._broadcast(rctx)
        base._broadcast(bctx)
        said = {6: rctx.cast[-1][1], 1: bctx.cast[-1][1]}
        seen.append((t, recruit.role, base.parent))
    return seen


def test_a_recruit_taken_as_its_join_time_runs_out_is_never_a_free_parent():
    """R5: the base takes the recruit in the tick its ``join_time`` (25 ticks) runs out; the ack comes a tick later.

    Before the rule the recruit went free in that very tick, and the base kept a free robot as its parent until it
    heard it (Fig. 6 bottom, chain 11: the chain cut for 2 ticks). Now the recruit first withdraws (names no child)
    for ``recruit_time`` (5 ticks) and hears the ack, or a later one when the first are lost.
    """
    late = 100 + 25 + 1  # the first tick past join_time
    for lost in ((), (late, late + 1)):
        seen = _release_race(arrives=late, lost=lost)
        assert not [(t, role) for t, role, parent in seen if parent == 6 and role == FREE]
        assert seen[-1][1:] == (NETWORKER, 6)  # taken, and it stays
    # a tick later the recruit names no child any more: it is not taken, goes free after 5 ticks, the base keeps
    # the root
    seen = _release_race(arrives=late + 1)
    assert all(parent == 0 for _, _, parent in seen)
    assert [t for t, role, _ in seen if role == FREE][0] == late + 5


def _airborne_robot(rid: int, airborne: float) -> tuple[Relays, Ctx]:
    """Robot ``rid`` of the chain 0-1-2-3 with a plan 20 m long whose last ``airborne`` metres only fly."""
    r, ctx = robot(rid, hears_free=True)
    plan = {"pe": True, "pi": [[0.0, 0.0, 0.7], [20.0, 0.0, 0.7]], "pig": [[0.0, 0.0], [20.0, 0.0]],
            "g": 20.0 - airborne, "n": 15}
    r.rel = SimpleNamespace(peek=lambda key: plan if key == "plan/0" else None)
    return r, ctx


def test_a_slot_needs_a_flying_robot_only_while_the_chain_cannot_cover_the_airborne_part():
    """ceil(airborne / d_s) robots cover the airborne stretch ending at the target.

    Robot k from the worker sits (k - 1) d_s back: the worker alone covers one shorter than d_s, so its first
    recruit may walk.
    """
    head, _ = _airborne_robot(3, 1.0)  # the worker alone, airborne 1.0 m < d_s = 1.4 m
    head.child = None
    assert not head._needs_flying(0, 3, mine=True)
    head, _ = _airborne_robot(3, 2.0)  # airborne 2.0 m: the worker and one flying recruit
    head.child = None
    assert head._needs_flying(0, 3, mine=True)
    mid, _ = _airborne_robot(2, 2.0)
    mid.cnt = 2  # itself and the worker above it: enough
    assert not mid._needs_flying(0, 2, mine=True)
    root, _ = _airborne_robot(1, 2.0)
    root.heard[1] = (100, chain_body({"r": NETWORKER, "n": 1}))  # the base announces a chain of 1 robot
    assert root._needs_flying(0, 1)
    root.heard[1] = (100, chain_body({"r": NETWORKER, "n": 2}))
    assert not root._needs_flying(0, 1)
    ground, _ = _airborne_robot(1, 0.0)
    assert not ground._needs_flying(0, 1)  # a ground plan never asks for flying robots


class _Closed:
    """A flying election that closes at the next step with ``winner`` (the stigmergy's part is tested elsewhere)."""

    def __init__(self, key: str, winner: int):
        self.key, self.winner, self.elected_at = key, winner, None

    def step(self, ctx):
        self.elected_at = ctx.tick


def _flying_robot(rid: int) -> tuple[Relays, Ctx]:
    r = Relays([[8.0, 0.0]], root=0, kind="flying", chains_per_target=2)
    r.rel = SimpleNamespace(peek=lambda key: None, entry=lambda key: None)
    r.vote = None
    r.settled, r.target_pos = {0: 5, 1: 6}, {0: [8.0, 0.0], 1: [8.0, 0.0]}  # the ground workers that stepped down
    r.fly = {0: _Closed("worker/0/fly", 9), 1: _Closed("worker/1/fly", 9)}
    return r, Ctx(rid, tick=50, position=(1.0 + rid / 10, 0.0))


def test_flying_elections_that_close_together_on_one_robot_elect_again_for_the_higher_chain():
    """Fig. 4 with several chains: the same flying robot wins two flying elections at once.

    Chain 0 keeps it; chain 1 elects again (``worker/1/fly1``) among the flying robots not taken.
    """
    r, ctx = _flying_robot(9)
    r._elect_flying(ctx, 10)
    assert r.settled[0] == 9 and r.role == WORKER and r.chain == 0
    assert r.fly[1].key == "worker/1/fly1" and r.fly[1].start == 50 and r.fly[1].elected_at is None
    assert r.fly[1].bid_fn(ctx) is None  # it holds chain 0
    other, octx = _flying_robot(7)
    other._elect_flying(octx, 10)
    assert other.settled[0] == 9 and other.role == FREE and other.fly[1].key == "worker/1/fly1"
    assert other.fly[1].bid_fn(octx) is not None  # a free flying robot bids in the second round
    assert 1 not in other.settled or other.settled[1] == 6  # chain 1 is not settled on robot 9


def test_ask_stretched_a_head_short_of_links_but_not_stretched_does_not_ask():
    """With ask = "stretched" (the default): the head asks only when its own parent link is at d_s."""
    head, ctx = robot(3, hears_free=False)
    ctx.position = [3.6, 0.0]  # 0.8 m from its parent: not stretched; the chain has 3 links of n = 6
    head._recruit(ctx)
    assert ctx.sent == [] and not head.pending


def test_ask_plan_a_head_short_of_links_asks_before_it_is_stretched_and_stops_at_n():
    """With ask = "plan" (Sec. IV): the head asks while the chain holds fewer than n links, whatever its own link."""
    head, ctx = robot(3, hears_free=False)
    head.ask = "plan"
    ctx.position = [3.6, 0.0]  # not stretched; depth 3 < n = 6
    head._recruit(ctx)
    assert ctx.sent == [(2, NEED, {"c": 0})]
    head, ctx = robot(3, hears_free=False)
    head.ask, head.depth = "plan", 6  # the chain has its n links: no request until the head is stretched
    ctx.position = [3.6, 0.0]
    head._recruit(ctx)
    assert ctx.sent == []
    ctx.position = list(X[3])  # stretched: asks as with "stretched" (straight links may fall short of n d_s)
    head._recruit(ctx)
    assert ctx.sent == [(2, NEED, {"c": 0})]


def test_ask_plan_the_recruiter_holding_the_request_still_waits_until_it_is_stretched():
    base, ctx = robot(1, hears_free=True)
    base.ask = "plan"
    ctx.position = [0.9, 0.0]  # 0.9 m from the root: not stretched
    base._on_need(ctx, 2, Need(0))
    base._recruit(ctx)
    assert not base.pending and not ctx.cast
    ctx.position = list(X[1])
    base._recruit(ctx)
    assert base.pending[0]["parent"] == 0


def test_ask_must_be_a_known_value():
    assert Relays.validate({"targets": [[8.0, 0.0]], "ask": "plan"}) is None
    assert "ask = 'early'" in Relays.validate({"targets": [[8.0, 0.0]], "ask": "early"})


def _worker_off_target(parent_at, reached_at=150) -> tuple[Relays, Ctx]:
    """Worker 3 of chain 0 (target (4.4, 0)), pushed 0.3 m off its target; its parent 2 at ``parent_at``."""
    w = Relays([[4.4, 0.0]], root=0, wp=True)
    w.role, w.chain, w.parent, w.child, w.depth = WORKER, 0, 2, None, 3
    w.plan = {"pe": True, "pi": [[0.0, 0.0], [4.4, 0.0]], "pig": [[0.0, 0.0], [4.4, 0.0]], "n": 4}
    w.path = motion.arc_points([[0.0, 0.0], [4.4, 0.0]])
    w.reached_at, w.root_pos = reached_at, np.array([0.0, 0.0])
    w.sensed = {2: np.array(parent_at), 0: np.array([0.0, 0.0])}
    w.heard[2] = (100, chain_body({"r": NETWORKER, "c": 0, "p": 1, "ch": 3, "d": 2}))
    ctx = Ctx(3, 100, (4.4, 0.3))
    ctx.map, ctx.rng, ctx.moved = None, np.random.default_rng(0), []
    ctx.move = ctx.moved.append
    return w, ctx


def test_a_worker_pushed_off_its_target_by_its_own_chain_keeps_it_at_its_target():
    """Fig. 6 T = 4 C WP trials 9 and 27: networkers crowd the reached target and push the worker 0.1-0.5 m off it.

    Its parent link is slack, so no recruit can help: the chain stays ``ok`` and its stretched robots near the
    root do not recruit (before, they took the last free robots from a chain still on its way).
    """
    w, ctx = _worker_off_target((3.9, 0.0))  # parent 0.58 m away: slack
    w._move(ctx)
    assert w.done
    below, bctx = robot(2, hears_free=True, wp=True)  # stretched, hears a free robot, WP
    below._on_chain(bctx, 3, chain_body({"r": WORKER, "c": 0, "p": 2, "ch": None, "d": 3, "ok": w.done}))
    below._recruit(bctx)
    assert not below.pending and not bctx.cast


def test_a_worker_held_off_its_target_by_a_stretched_link_or_never_there_is_not_done():
    w, ctx = _worker_off_target((3.0, 0.3))  # parent 1.4 m away: stretched, a recruit gives it slack
    w._move(ctx)
    assert not w.done
    w, ctx = _worker_off_target((3.9, 0.0), reached_at=None)  # on its way: not at its target yet
    w._move(ctx)
    assert not w.done
