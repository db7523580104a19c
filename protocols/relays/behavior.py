"""Swarm Relays: the robot side (002 Sec. IV). Imports no oracle.

Message kinds (every rule is a message exchange or a local computation; docs/protocols/relays.md):

* VS_PUT / VS_QUERY / VS_DIGEST - the virtual stigmergy (protocols/stigmergy). Table ``relay``: ``root``
  (the station's position), ``target/<t>`` ({pos, at}, written by the root), ``plan/<t>`` (the worker's
  tuple {pi, pe, pig, n, why}). Table ``elect`` (lowest value wins): ``worker/<t>`` = [distance, id].
* REL_CHAIN - the periodic status broadcast, every tick: {r role, c chain, p parent, ch child, d depth,
  up: ids from the sender towards the root, dn: ids from the sender towards the worker (k each beyond the
  sender), ok: the chain's worker reached its target}. C_local = up + dn of parent and child (Sec. IV-B).
* REL_TASK / REL_BID / REL_JOIN - recruiting by CBAA: the recruiter opens a slot {key, pos, close}; free
  robots that hear it bid 1/(1 + distance to pos) and run max-consensus on (bid, -id) per slot (CBAA's
  auction and consensus phases, one task per robot); at ``close`` the recruiter sends REL_JOIN to the
  winner it holds, which becomes a networker between the recruiter and the root (Prop. 1).
* REL_NEED - without WP prediction, the chain's head asks for a robot (when: ``ask``); the request travels
  parent by parent towards the root, and where it stops is ``route`` (R5).

Rules:

* R1 election - each target gets a worker by the stigmergy election (lowest distance), all targets at once,
  open ``bid_time``; a robot that wins several keeps the lowest target, the others are elected again (key
  ``worker/<t>/<round>``) among the robots not taken; the root never bids.
* R2 plan - ``plan_time`` after winning, the worker plans pi from the root's position to its target on its
  known map (planner.py: flood fill for PE, A* with an iteration budget) and writes the tuple. A target
  inside an obstacle or outside the planning area, or an unreachable one, is written with pe = false and
  the reason; no chain is built for it.
* R3 plan read - a plan entry that is not a well-formed tuple is refused and counted (``refused``), once
  per version; the robot keeps the last good plan.
* R4 motion - motion.py (Eqs. 6-8 with the stated reading of Eq. 8's admissible set, RVO by sampling, the
  safety guard); neighbour velocities from the robot's own consecutive sensings; the root stands still;
  free robots stay within d_s of the root and step aside from chain robots.
* R5 recruiting - with WP prediction every stretched chain robot (link to its parent at d_s - v_max dt,
  ``_stretched``) with free neighbours recruits; without it, only a robot holding a REL_NEED from the head.
  No robot recruits while its chain's worker is at its target (``ok``, propagated down); a worker pushed off
  its target after reaching it still counts as there while its own parent link is not stretched (``_keeps_done``).
  When the head sends it is the parameter ``ask``: "stretched" (default; its own parent link at
  d_s - v_max dt; it then stands still until the recruit's slack arrives) or "plan" (Sec. IV: "the worker
  determines the number of links required to reach the target": while the chain holds fewer than
  n = ceil(d_path / d_s) links, moving on meanwhile; and when stretched, as a fallback). Where the request
  stops is the parameter ``route`` (``keeps_request``): "first" (default, Sec. IV's "passed down the
  networkers towards the root, until a free robot is found") - the first robot counted from the head that has
  free neighbours keeps it, else the base; "base" - every robot passes it on down to the base (the robot
  whose parent is the root). The robot holding it recruits in front of itself once stretched; a base without
  free neighbours asks the root, which recruits in front of it. A recruit its child has not taken within
  ``join_time`` withdraws (its REL_CHAIN names no child) for ``recruit_time``, then goes back to free unless
  its child's ack came meanwhile (``_overdue``).
* R6 link failure - a parent or child not heard for ``link_fail`` is declared failed. A robot that lost
  its parent moves back along pi (Eq. 6 with d_P = inf) until a robot of its C_local up-list (or the root)
  is within d_s, then takes it as parent; a robot that lost its child acts as a temporary worker (moves
  forward, recruits) until a robot names it as parent; a temporary worker that reaches the target becomes
  the worker. A parent that announces itself free (a recruit released as its child took it) is lost too.
* R7 redundant chains - ``chains_per_target`` = C_n: chain c is copy c % C_n of target c // C_n, with its own
  election, plan and links; copy j runs (j - (C_n - 1)/2) * ``spacing`` beside pi (planner.offset).
* R8 re-election - the root watches each chain's base; a worker dead alone (or never heard) gets a successor
  by the election ``worker/<c>/again<k>`` announced in ``again/<c>``.
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
from msgspec.structs import replace

from protocols.relays import motion, planner
from protocols.relays.messages import (
    BID,
    BODIES,
    CHAIN,
    FREE,
    JOIN,
    KINDS,
    NEED,
    NETWORKER,
    ROOT,
    TASK,
    WORKER,
    Bid,
    Chain,
    Join,
    Need,
    Task,
)
from protocols.relays.zones import robots_needed
from protocols.stigmergy.behavior import Election
from protocols.stigmergy.table import KINDS as VS_KINDS
from protocols.stigmergy.table import Stigmergy
from swarmactors import Behavior, Context, Frame
from swarmactors.robot.behavior import is_int, is_num
from swarmactors.robot.inputs import SensedView

ASK = ("stretched", "plan")  # R5 without WP: the head asks when its parent link is at d_s, or while the chain is short
ROUTE = ("first", "base")  # R5 without WP: where the head's request stops (first robot with free neighbours, or base)

__all__ = ["ASK", "BID", "CHAIN", "FREE", "JOIN", "NEED", "NETWORKER", "ROOT", "ROUTE", "TASK", "WORKER", "Relays",
           "keeps_request", "valid_plan"]


def keeps_request(route: str, parent_is_root: bool, can_recruit: bool) -> bool:
    """R5 without WP: whether a chain robot keeps the head's request (True) or passes it to its parent.

    "first" (Sec. IV, the default): the first robot counted from the head that has free neighbours keeps it,
    and the base (whose parent is the root) always does. "base": every robot passes it on down to the base,
    the chain robot nearest the root (the links stretch from the root upwards, so the base is stretched first);
    the base recruits in front of itself once stretched, or asks the root when it has no free neighbours.
    """
    if parent_is_root:
        return True
    return route == "first" and can_recruit


def valid_plan(v) -> str | None:
    """Why a plan tuple read from the stigmergy is malformed, or None when it is well formed."""
    if not isinstance(v, dict):
        return "not a table"
    if not isinstance(v.get("pe"), bool):
        return "pe is not a boolean"
    if not v["pe"]:
        return None
    for key in ("pi", "pig"):
        pts = v.get(key)
        if not isinstance(pts, list) or len(pts) < 2:
            return f"{key} is not a list of at least 2 points"
        for p in pts:
            if not isinstance(p, list) or len(p) not in (2, 3) or not all(is_num(c) for c in p):
                return f"{key} has a point that is not [x, y] or [x, y, z] of finite numbers"
    if not is_int(v.get("n")) or v["n"] < 1:
        return "n is not a positive integer"
    if "g" in v and not is_num(v["g"]):
        return "g is not a number"
    return None


UNHEARD = Chain(role=None)  # a new link's entry in ``heard`` until its first REL_CHAIN


class Relays(Behavior):
    """Self-healing connectivity chains from a root to targets (Swarm Relays, Varadharajan et al. 2020)."""

    name = "relays"
    kinds = (*VS_KINDS, *KINDS)
    plot_field = "role"
    plot_marks = {"targets": "target"}  # the run plot draws the targets (swarmactors.tools.plots)

    def __init__(self, targets: list, root: int = 0, at: int = 1, ds: float = 1.4, dc: float = 1.6,
                 db: float = 1.8, vmax: float = 0.5, rcol: float = 0.25, plan_time: float = 2.0,
                 bid_time: float = 10.0, recruit_time: float = 1.0, forget_time: float = 3.0,
                 link_fail: float = 5.0, k: int = 8, wp: bool = False, resolution: float = 0.25,
                 budget: int = 20000, clearance: float = 0.4, area: list | None = None, lookahead: float = 0.5,
                 kind: str = "ground", altitude: float = 0.7, chains_per_target: int = 1, spacing: float = 0.3,
                 join_time: float | None = None, air: list | None = None, ask: str = "stretched",
                 route: str = "first"):
        self.targets = [[float(c) for c in t] for t in targets]
        self.cn, self.spacing = chains_per_target, spacing  # C_n chains per target, side by side (Sec. III-C)
        self.root, self.at = root, at
        self.ds, self.dc, self.db, self.vmax, self.rcol = ds, dc, db, vmax, rcol
        self.times = {"plan": plan_time, "bid": bid_time, "recruit": recruit_time, "forget": forget_time,
                      "fail": link_fail, "join": link_fail if join_time is None else join_time}
        self.k, self.wp, self.res, self.budget, self.clearance = k, wp, resolution, budget, clearance
        self.ask = ask  # without WP: when the head asks for a robot ("stretched" or "plan", R5)
        self.route = route  # without WP: where its request stops ("first" or "base", R5)
        self.area, self.lookahead = area, lookahead
        self.kind, self.altitude = kind, altitude  # kind repeats the group's: the context does not tell it
        self.air = air  # [z_lo, z_hi]: plan flights in 3-D within these altitudes (None: at ``altitude`` only)
        self.d3 = False  # air and a 3-D world: positions, links and flight in 3-D (set at start)
        self.fly: dict[int, Election] = {}
        self.cnt = 0  # robots from me to the worker (me included), from the child's REL_CHAIN
        self.node = Stigmergy()
        self.role, self.chain, self.parent, self.child, self.depth = FREE, None, None, None, None
        self.up: list[int] = []
        self.dn: list[int] = []
        self.done = False  # the chain's worker is at its target now, or was and is not held off it (propagated down)
        self.heard: dict[int, tuple[int, Chain]] = {}  # neighbour -> (tick, last REL_CHAIN body)
        self.sensed: dict[int, np.ndarray] = {}
        self.seen: tuple | None = None  # (tick, sensed, own position) of the last tick, for the velocities
        self.vel: dict[int, np.ndarray] = {}  # sensed robot -> its velocity estimated from two sensings
        self.u_self: np.ndarray | None = None  # this robot's own velocity over the last tick
        self.elections: dict[int, Election | None] = {}
        self.settled: dict[int, int] = {}  # chain -> its elected worker
        self.settled_at: dict[int, int] = {}  # chain -> tick its worker was (re-)elected
        self.base_seen: dict[int, tuple[int, int]] = {}  # root: chain -> (tick, robots in it) of its base
        self.again: dict[int, tuple[int, Election]] = {}  # chain -> (round, re-election of a dead worker)
        self.rounds: dict[int, int] = {}
        self.target_pos: dict[int, list] = {}
        self.plan: dict | None = None
        self.plan_seen: tuple | None = None
        self.path: tuple[np.ndarray, np.ndarray] | None = None
        self.s: float | None = None
        self.planned_at: int | None = None
        self.won_at: int | None = None
        self.reached_at: int | None = None
        self.plan_status: str | None = None
        self.refused: Counter = Counter()
        self.malformed: Counter = Counter()  # frames that did not decode, by cause
        self.slots: dict[str, dict] = {}  # CBAA: open slots heard {pos, close, y, z, owner, chain}
        self.choice: str | None = None  # the slot this free robot bids on
        self.pending: dict[int, dict] = {}  # chain -> this robot's own open slot
        self.root_asked = -10**9
        self.serial = 0
        self.need_until = -1
        self.need_sent = -10**9
        self.slot_empty_at = -10**9  # the last tick a slot of mine closed without a winner
        self.parent_lost = False
        self.acked = True  # my child has named me as its parent (False for a recruit until it does)
        self.failed: list[list] = []  # [tick, id] links declared failed
        # who recruits (read by the Fig. 6 analysis, not by any rule): requests that stopped here
        # [tick, depth, robots from me to the head, stretched], my slots [opened, depth, robots to the head,
        # stretched, asked tick or None, closed, winner or None, joined tick or None], the head's ticks on its
        # path before its target and those it stood still
        self.asked: list[list] = []
        self.recruits: list[list] = []
        self.head_ticks = self.head_stopped = 0
        self.splices: list[list] = []  # [tick, "parent"|"child", id]
        self.joined: list[list] = []  # [tick, recruited id] (recruiter) or [tick, chain] (recruit)
        self.root_pos: np.ndarray | None = None

    @staticmethod
    def validate(params: dict) -> str | None:
        t = params.get("targets")
        if not isinstance(t, list) or not t or not all(
                isinstance(p, list) and len(p) in (2, 3) and all(is_num(c) for c in p) for p in t):
            return f"targets = {t!r} must be a non-empty list of [x, y] or [x, y, z] points"
        for key in ("ds", "dc", "db", "vmax", "rcol", "plan_time", "bid_time", "recruit_time", "forget_time",
                    "link_fail", "resolution", "clearance", "lookahead", "spacing", "join_time"):
            v = params.get(key)
            if v is not None and (not is_num(v) or v <= 0):
                return f"{key} = {v!r} must be a positive number"
        ds, dc, db = params.get("ds", 1.4), params.get("dc", 1.6), params.get("db", 1.8)
        if not ds < dc < db:
            return f"zones must satisfy ds < dc < db (got ds = {ds}, dc = {dc}, db = {db})"
        for key, low in (("root", 0), ("at", 0), ("k", 1), ("budget", 1), ("chains_per_target", 1)):
            v = params.get(key)
            if v is not None and (not is_int(v) or v < low):
                return f"{key} = {v!r} must be an integer >= {low}"
        a = params.get("area")
        if a is not None and not (isinstance(a, list) and len(a) == 2 and all(
                isinstance(c, list) and len(c) >= 2 and all(is_num(x) for x in c) for c in a)
                and a[0][0] < a[1][0] and a[0][1] < a[1][1]):
            return f"area = {a!r} must be [[x0, y0], [x1, y1]] with x0 < x1 and y0 < y1"
        if not isinstance(params.get("wp", False), bool):
            return "wp must be true or false"
        if params.get("route", "first") not in ROUTE:
            return (f"route = {params.get('route')!r} must be one of {', '.join(ROUTE)} "
                    "(where a head's request stops without WP)")
        if params.get("ask", "stretched") not in ASK:
            return (f"ask = {params.get('ask')!r} must be one of {', '.join(ASK)} "
                    "(when a head without WP asks for a robot)")
        air = params.get("air")
        if air is not None and not (isinstance(air, list) and len(air) == 2 and all(is_num(z) for z in air)
                                    and 0 <= air[0] < air[1]):
            return f"air = {air!r} must be [z_lo, z_hi] with 0 <= z_lo < z_hi (the altitudes a flight may use)"
        if params.get("kind", "ground") not in ("ground", "flying"):
            return f"kind = {params.get('kind')!r} must be ground or flying (the robot group's kind)"
        return None

    # ------------------------------------------------------------------ helpers
    def side(self, chain: int) -> float:
        """Chain c = t C_n + j is copy j of target t; it runs (j - (C_n - 1)/2) * spacing to the left of pi."""
        return (chain % self.cn - (self.cn - 1) / 2) * self.spacing

    def _ticks(self, ctx: Context, what: str) -> int:
        return max(1, round(self.times[what] / ctx.dt))

    def _pos(self, ctx: Context) -> np.ndarray:
        return np.array(ctx.position[:3 if self.d3 else 2], dtype=float)

    def _dist(self, ctx: Context, j: int | None) -> float:
        if j is None:
            return math.inf
        if j == ctx.id:
            return 0.0
        p = self.sensed.get(j)
        return math.inf if p is None else float(np.linalg.norm(p - self._pos(ctx)))

    def _alive(self, ctx: Context, j: int | None) -> bool:
        if j is None:
            return False
        if j == self.root:
            return True if j in self.sensed or j == ctx.id else j in self.heard
        h = self.heard.get(j)
        return h is not None and ctx.tick - h[0] <= self._ticks(ctx, "fail")

    def _publish(self, ctx: Context) -> None:
        ctx.set_status(role=self.role, chain=self.chain, parent=self.parent, child=self.child, depth=self.depth)

    # ------------------------------------------------------------------ receive
    def on_start(self, ctx: Context) -> None:
        self.node.attach(ctx)
        self.rel = self.node.create("relay")
        self.vote = self.node.create("elect", "lower_value")
        self.d3 = self.air is not None and len(ctx.position) == 3
        if ctx.id == self.root:
            self.role, self.depth = ROOT, 0
        self._publish(ctx)

    def on_frame(self, ctx: Context, frame: Frame) -> None:
        if self.node.on_frame(ctx, frame):
            return
        match BODIES.decode(frame, self.malformed):  # None for a body that does not fit, counted by cause
            case Chain() as b:
                self._on_chain(ctx, frame.src, b)
            case Task() as b:
                self._on_task(ctx, frame.src, b)
            case Bid() as b:
                self._on_bid(ctx, b)
            case Join() as b:
                self._on_join(ctx, b)
            case Need() as b:
                self._on_need(ctx, frame.src, b)

    def _on_chain(self, ctx: Context, src: int, b: Chain) -> None:
        """Status broadcast: remember it; take chain, depth and C_local from parent and child."""
        self.heard[src] = (ctx.tick, b)
        if self.role == ROOT and b.parent == ctx.id and b.chain is not None and b.role in (WORKER, NETWORKER):
            self.base_seen[b.chain] = (ctx.tick, b.n)
        if src == self.parent and self.role in (WORKER, NETWORKER) and b.role == FREE and src != self.root:
            self.parent, self.parent_lost = None, True  # a recruit released before it heard me take it (R5)
            return
        if src == self.parent and self.role in (WORKER, NETWORKER):
            self.chain = b.chain if src != self.root else self.chain
            self.depth = b.depth + 1 if b.depth is not None else self.depth
            self.up = [ctx.id] + b.up[: self.k]
        if (self.role in (WORKER, NETWORKER) and self.parent is not None and src not in (self.parent, self.root)
                and b.child == ctx.id and b.parent == self.parent and b.chain == self.chain
                and self._dist(ctx, src) <= self.ds):
            self.parent = src  # Prop. 1: a recruit now sits between my parent and me
            self.depth = b.depth + 1 if b.depth is not None else self.depth
            self.up = [ctx.id] + b.up[: self.k]
        if self.role in (WORKER, NETWORKER) and self.child is not None and (src == self.child or b.parent == ctx.id):
            self._child_moved(ctx)
        if src == self.child:
            self.cnt = b.n + 1
            self.acked = self.acked or b.parent == ctx.id
            self.dn = [ctx.id] + b.dn[: self.k]
            self.done = b.ok
        if (self.role in (WORKER, NETWORKER) and self.child is None and b.parent == ctx.id
                and b.chain == self.chain and src != self.parent):  # R6: a lower robot spliced to me
            self.child = src
            self.splices.append([ctx.tick, "child", src])

    def _on_task(self, ctx: Context, src: int, b: Task) -> None:
        """CBAA: a recruiter opened a slot; a free robot adds it to its task list."""
        if self.role == FREE and b.key not in self.slots and b.close > ctx.tick \
                and (not b.fly or self.kind == "flying"):  # a flying slot takes flying robots only
            self.slots[b.key] = {"pos": [float(v) for v in b.pos[:2]], "close": b.close, "y": -math.inf,
                                 "z": None, "owner": src, "chain": b.chain, "fly": b.fly}

    def _on_bid(self, ctx: Context, b: Bid) -> None:
        """CBAA consensus: keep the larger (bid, -id) per slot; an outbid robot bids again next tick."""
        for key, (y, z) in b.bids.items():
            slot = self.slots.get(key) or next((p for p in self.pending.values() if p["key"] == key), None)
            if slot is None:
                continue
            if (y, -z) > (slot["y"], -(slot["z"] if slot["z"] is not None else 10**9)):
                slot["y"], slot["z"] = float(y), int(z)
                if self.choice == key and z != ctx.id:
                    self.choice = None

    def _on_join(self, ctx: Context, b: Join) -> None:
        """A recruiter's call: a free robot becomes a networker between the root and the recruiter."""
        if self.role != FREE:
            return
        self.role, self.chain, self.parent, self.child = NETWORKER, b.chain, b.parent, b.child
        self.depth = 1
        self.up, self.dn = [ctx.id, self.parent], [ctx.id, self.child]
        self.slots, self.choice = {}, None
        self.joined.append([ctx.tick, self.chain])
        self.acked = False
        for j in (self.parent, self.child):  # a new link starts as heard: it has link_fail to show up
            if j not in self.heard or self.heard[j][0] < ctx.tick:
                self.heard[j] = (ctx.tick, replace(self.heard.get(j, (0, UNHEARD))[1], role=None))
        self._load_plan(ctx)

    def _child_moved(self, ctx: Context) -> None:
        """R5: my child took a recruit x as its parent, and x names me as its parent: x is my child now."""
        h = self.heard.get(self.child)
        x = h[1].parent if h is not None else None
        if x is None or x == ctx.id:
            return
        hx = self.heard.get(x)
        if hx is not None and hx[1].parent == ctx.id and hx[1].child == self.child and hx[1].chain == self.chain:
            self.child = x

    def _on_need(self, ctx: Context, src: int, b: Need) -> None:
        """The head's request for a robot travels towards the root until a robot keeps it (``route``, Sec. IV)."""
        if self.role == ROOT:  # a base without free neighbours: the root recruits in front of it
            c = b.chain
            h = self.heard.get(src)
            if c not in self.pending and h is not None and h[1].parent == ctx.id:
                self._open(ctx, c, src, ctx.id)
            return
        if self.role not in (WORKER, NETWORKER) or src != self.child:
            return
        if keeps_request(self.route, self.parent == self.root, self._can_recruit(ctx)):
            self.need_until = ctx.tick + self._ticks(ctx, "recruit")
            self._log_ask(ctx)
        elif self.parent is not None:
            BODIES.send(ctx, self.parent, Need(self.chain))

    # ------------------------------------------------------------------ tick
    def on_tick(self, ctx: Context, sensed) -> None:
        k = 3 if self.d3 else 2
        if isinstance(sensed, SensedView):  # one array for all, a row each (the same numbers, fewer numpy calls)
            self.sensed = dict(zip(sensed.ids, sensed.positions()[:, :k], strict=True))
        else:
            self.sensed = {s.id: np.array(s.pos[:k], dtype=float) for s in sensed}
        self._velocities(ctx)
        self._root_position(ctx)
        if ctx.id == self.root and ctx.tick == self.at:
            for t, pos in enumerate(self.targets):
                self.rel.put(f"target/{t}", {"pos": pos, "at": ctx.tick})
        self._elect(ctx)
        self._elect_again(ctx)
        if self.role == WORKER and self.plan is None and self.won_at is not None \
                and ctx.tick >= self.won_at + self._ticks(ctx, "plan") and self.plan_status is None:
            self._make_plan(ctx)
        if self.role in (WORKER, NETWORKER):
            self._load_plan(ctx)
            self._links(ctx)
        if self.role in (ROOT, WORKER, NETWORKER):
            self._recruit(ctx)
        if self.role == FREE:
            self._bid(ctx)
        self._move(ctx)
        self._broadcast(ctx)
        self.node.flush(ctx)
        self._publish(ctx)

    def _velocities(self, ctx: Context) -> None:
        """Eq. 8's u_j (and u_i): each from this robot's own sensings of j (its own positions) one tick apart.

        A robot sensed at this tick and the one before gets (pos_now - pos_before)/dt; any other gets none
        (taken as 0 by the RVO). Robots know only what they sense: no velocity is read from the world.
        """
        x = self._pos(ctx)
        before, self.seen = self.seen, (ctx.tick, self.sensed, x)
        if before is None or before[0] != ctx.tick - 1:
            self.vel, self.u_self = {}, None
            return
        both = [j for j in self.sensed if j in before[1]]
        now = np.array([self.sensed[j] for j in both]).reshape(len(both), len(x))
        was = np.array([before[1][j] for j in both]).reshape(len(both), len(x))
        self.vel = dict(zip(both, (now - was) / ctx.dt, strict=True))
        self.u_self = (x - before[2]) / ctx.dt

    def _root_position(self, ctx: Context) -> None:
        if ctx.id == self.root:
            self.root_pos = self._pos(ctx)
            if self.rel.peek("root") is None:
                self.rel.put("root", [float(v) for v in self.root_pos])
        elif self.root in self.sensed:
            self.root_pos = self.sensed[self.root]
        elif self.root_pos is None and isinstance(self.rel.peek("root"), list):
            self.root_pos = np.array((self.rel.peek("root") + [0.0])[:3 if self.d3 else 2], dtype=float)

    def _elect(self, ctx: Context) -> None:
        """R1: the elections of all targets run at once, ``bid_time`` long.

        A robot that wins several keeps the lowest target; the others are elected again among the robots not
        yet taken, in rounds of ``bid_time``.
        """
        bid_ticks = self._ticks(ctx, "bid")
        for t in range(len(self.targets) * self.cn):  # chain t is copy t % C_n of target t // C_n
            if t in self.elections:
                continue
            entry = self.rel.peek(f"target/{t // self.cn}")
            if not isinstance(entry, dict) or not is_int(entry.get("at")):
                break
            pos = entry.get("pos")
            if not isinstance(pos, list) or not all(is_num(c) for c in pos):
                self.refused["target"] += 1
                self.elections[t] = None
                continue
            self.target_pos[t] = pos
            self.elections[t] = Election(self.vote, f"worker/{t}", self._bidder(pos), entry["at"], bid_ticks)
        self._elect_flying(ctx, bid_ticks)
        closed = False
        for _, el in sorted(self.elections.items()):
            if el is not None and el.elected_at is None:
                el.step(ctx)
                closed = closed or el.elected_at is not None
        if not closed or any(el is not None and el.elected_at is None for el in self.elections.values()):
            return
        for t, el in sorted(self.elections.items()):  # the round is over: settle it the same way everywhere
            if el is None or t in self.settled or el.winner is None:
                continue
            if el.winner not in self.settled.values():
                self.settled[t], self.settled_at[t] = el.winner, ctx.tick
                if el.winner == ctx.id and self.role == FREE:
                    self.role, self.chain, self.parent, self.child, self.depth = WORKER, t, self.root, None, 1
                    self.up, self.dn = [ctx.id, self.root], [ctx.id]
                    self.won_at = ctx.tick
                    self.slots, self.choice = {}, None
            else:  # this robot already took a lower target: elect again
                self.rounds[t] = self.rounds.get(t, 0) + 1
                self.elections[t] = Election(self.vote, f"worker/{t}/{self.rounds[t]}",
                                             self._bidder(self.target_pos[t]), ctx.tick, bid_ticks)

    def _elect_flying(self, ctx: Context, bid_ticks: int) -> None:
        """Fig. 4: a plan that leaves the ground, made by a ground worker, opens a flying-only election."""
        for t in sorted(self.settled):
            plan = self.rel.peek(f"plan/{t}")
            if t not in self.fly and isinstance(plan, dict) and is_int(plan.get("fly_at")):
                pos = self.target_pos[t]

                def bid(c: Context, pos=pos) -> float | None:
                    if c.id == self.root or self.role != FREE or self.kind != "flying" \
                            or c.id in self.settled.values():
                        return None
                    return float(math.dist(self._pos(c)[:2], pos[:2]))

                self.fly[t] = Election(self.vote, f"worker/{t}/fly", bid, plan["fly_at"], bid_ticks)
                if self.role == WORKER and self.chain == t:  # the ground worker steps down
                    self.role, self.chain, self.parent, self.child, self.depth = FREE, None, None, None, None
                    self.plan = self.path = self.s = self.plan_seen = None
                    self.up, self.dn = [], []
        for t, el in sorted(self.fly.items()):
            if el.elected_at is None:
                el.step(ctx)
                if el.elected_at is not None and el.winner is not None and el.winner in (
                        w for c, w in self.settled.items() if c != t):  # it won another chain's election first
                    pos, k = self.target_pos[t], int(el.key.rsplit("fly", 1)[1] or 0) + 1

                    def again(c: Context, pos=pos) -> float | None:
                        if c.id == self.root or self.role != FREE or self.kind != "flying" \
                                or c.id in self.settled.values():
                            return None
                        return float(math.dist(self._pos(c)[:2], pos[:2]))

                    self.fly[t] = Election(self.vote, f"worker/{t}/fly{k}", again, ctx.tick, bid_ticks)
                    continue
                if el.elected_at is not None:
                    self.settled_at[t] = ctx.tick
                    if el.winner is not None:
                        self.settled[t] = el.winner
                if el.elected_at is not None and el.winner == ctx.id and self.role == FREE:
                    self.role, self.chain, self.parent, self.child, self.depth = WORKER, t, self.root, None, 1
                    self.up, self.dn = [ctx.id, self.root], [ctx.id]
                    self.won_at, self.plan_status = ctx.tick, "ok"
                    self.slots, self.choice = {}, None
                    self._load_plan(ctx)

    def _elect_again(self, ctx: Context) -> None:
        """R8: a chain whose worker died before it recruited anyone gets a new worker.

        The root watches each elected chain's base (the chain robot whose parent is the root, from its
        REL_CHAIN): when none was heard within ``link_fail`` of the election, or the last one heard was the
        worker alone (n = 1) and it has been silent for ``link_fail``, the worker is dead and nobody carries
        its chain; the root writes ``again/<c>`` = {at, k} and every robot runs the election
        ``worker/<c>/again<k>`` among the free robots (lowest distance to the target). The winner takes the
        chain's plan from the stigmergy, or plans it when there is none. A chain with networkers heals by R6.
        """
        fail = self._ticks(ctx, "fail")
        if self.role == ROOT:
            for c in sorted(self.settled_at):
                since, seen = self.settled_at[c], self.base_seen.get(c)
                busy = (c in self.fly and self.fly[c].elected_at is None) or (
                    c in self.again and self.again[c][1].elected_at is None)
                plan = self.rel.peek(f"plan/{c}")
                if busy or (isinstance(plan, dict) and plan.get("pe") is False):
                    continue
                if (seen is None or seen[0] < since) and ctx.tick - since > fail or (
                        seen is not None and seen[0] >= since and seen[1] == 1 and ctx.tick - seen[0] > fail):
                    k = self.again[c][0] + 1 if c in self.again else 1
                    self.rel.put(f"again/{c}", {"at": ctx.tick + 1, "k": k})
                    self.base_seen.pop(c, None)
                    self.settled_at[c] = ctx.tick + self._ticks(ctx, "bid") + 1
        for c in sorted(self.settled):
            entry = self.rel.peek(f"again/{c}")
            if isinstance(entry, dict) and is_int(entry.get("k")) and is_int(entry.get("at")) \
                    and entry["k"] > (self.again[c][0] if c in self.again else 0):
                pos = self.target_pos[c]

                def bid(cx: Context, pos=pos) -> float | None:
                    if cx.id == self.root or self.role != FREE:
                        return None
                    return float(math.dist(self._pos(cx)[:2], pos[:2]))

                self.again[c] = (entry["k"], Election(self.vote, f"worker/{c}/again{entry['k']}", bid, entry["at"],
                                                      self._ticks(ctx, "bid")))
        for c, (_k, el) in sorted(self.again.items()):
            if el.elected_at is None:
                el.step(ctx)
                if el.elected_at is None or el.winner is None:
                    continue
                self.settled[c], self.settled_at[c] = el.winner, ctx.tick
                if el.winner == ctx.id and self.role == FREE:
                    self.role, self.chain, self.parent, self.child, self.depth = WORKER, c, self.root, None, 1
                    self.up, self.dn = [ctx.id, self.root], [ctx.id]
                    self.won_at, self.plan_status = ctx.tick, None
                    self.slots, self.choice = {}, None
                    self._load_plan(ctx)
                    if self.plan is not None:
                        self.plan_status = "ok"

    def _bidder(self, pos: list):
        def bid(c: Context) -> float | None:
            if c.id == self.root or self.role != FREE or c.id in self.settled.values():
                return None
            return float(math.dist(self._pos(c)[:2], pos[:2]))

        return bid

    def _make_plan(self, ctx: Context) -> None:
        """R2: reachability and A* on the known map, then the tuple <pi, PE, pi_g> into the stigmergy."""
        target = self.targets[self.chain // self.cn] if self.chain // self.cn < len(self.targets) else None
        entry = self.rel.peek(f"target/{self.chain // self.cn}")
        if isinstance(entry, dict):
            target = entry["pos"]
        start = self.root_pos if self.root_pos is not None else self._pos(ctx)
        m = ctx.map
        area = self.area
        if area is None:
            grid = m.grid if m is not None else None
            if grid is not None:
                o, cell = grid.get("origin", [0.0, 0.0]), grid.get("cell", 1.0)
                rows = grid["layers"][0]["rows"] if "layers" in grid else grid["rows"]
                area = [[o[0], o[1]], [o[0] + cell * len(rows[0]), o[1] + cell * len(rows)]]
            else:
                xs = [start[0], target[0]] + [p[0] for ob in (m.obstacles if m else []) for p in ob["xy"]]
                ys = [start[1], target[1]] + [p[1] for ob in (m.obstacles if m else []) for p in ob["xy"]]
                area = [[min(xs) - 3.0, min(ys) - 3.0], [max(xs) + 3.0, max(ys) + 3.0]]
        why, pts = None, []
        inside = (lambda x, y: m.inside([x, y, 0.0])) if m is not None else (lambda x, y: False)
        if not (area[0][0] <= target[0] <= area[1][0] and area[0][1] <= target[1] <= area[1][1]):
            why = "target outside the map"
        elif inside(target[0], target[1]):
            why = "target inside an obstacle"
        else:
            side = self.side(self.chain)
            status, pts, air = self._plan_grid(area, inside, m, start, target, abs(side))
            if side and status == "ok":  # planned with |side| more clearance, so the shifted path keeps its own
                pts = planner.offset(pts, side)
            elif side:  # too narrow for side-by-side chains: this copy follows pi itself
                status, pts, air = self._plan_grid(area, inside, m, start, target, 0.0)
            why = None if status == "ok" else {"outside": "target outside the map", "unreachable": "unreachable",
                                               "budget": "planner budget exhausted"}[status]
        self.plan_status = why or "ok"
        if why is not None:
            value = {"pe": False, "pi": [], "pig": [], "n": 0, "why": why}
        else:
            pig = [p[:2] for p in pts]
            g = planner.ground_reach(pig, inside, self.clearance, body=self.rcol / 2) if air is not None \
                else planner.length(pig)
            pi = [[round(p[0], 4), round(p[1], 4), round(p[2], 4) if len(p) == 3 else 0.0 if air is None else air]
                  for p in pts]
            value = {"pe": True, "pi": pi, "pig": [p[:2] for p in pi], "g": round(g, 4),
                     "n": robots_needed(planner.length(pts), self.ds), "why": None}
            if air is not None and self.kind == "ground":  # Fig. 4: a flying robot takes over
                value["fly_at"] = ctx.tick + 1
                self.plan_status = "handed to a flying robot"
        self.planned_at = ctx.tick
        self.rel.put(f"plan/{self.chain}", value)
        self._load_plan(ctx)

    def _plan_grid(self, area, inside, m, start, target, extra: float):
        """Flood fill + A* on the ground, else (3-D world) in the air; clearance + ``extra``.

        In the air: with ``air`` = [z_lo, z_hi], A* on voxels of side R between those altitudes (planner.Grid3,
        the known map's prisms with their z-extent), so pi climbs and descends (through a window, over a
        wall); without it, on the grid of cells at the one flying ``altitude``.
        """
        grid = planner.Grid(area, self.res, inside, self.clearance + extra)
        status, pts = planner.plan(grid, list(start[:2]), list(target[:2]), self.budget)
        air = None
        if status == "unreachable" and m is not None and m.dims == 3 and self.air is not None:
            lo, hi = float(self.air[0]), float(self.air[1])
            box = [[area[0][0], area[0][1], lo], [area[1][0], area[1][1], hi]]
            grid = planner.Grid3(box, self.res, lambda p: m.inside_all(p, ground=False), self.clearance + extra)

            def at(p):  # the point at its own altitude (the ground when it has none), within [lo, hi)
                z = float(p[2]) if len(p) == 3 else 0.0
                return [float(p[0]), float(p[1]), min(max(z, lo), hi - 1e-6)]

            status, pts = planner.plan(grid, at(start), at(target), self.budget)
            return status, pts, "3d"
        if status == "unreachable" and m is not None and m.dims == 3:  # in R^3, over the obstacles (Sec. IV)
            h = self.altitude
            grid = planner.Grid(area, self.res, lambda x, y: m.inside([x, y, h], ground=False),
                                self.clearance + extra)
            status, pts = planner.plan(grid, list(start), list(target[:2]), self.budget)
            air = h
        return status, pts, air

    def _load_plan(self, ctx: Context) -> None:
        """R3: read this chain's plan tuple; refuse a malformed one (counted once per version)."""
        if self.chain is None:
            return
        e = self.rel.entry(f"plan/{self.chain}")
        if e is None or (e.ts, e.writer) == self.plan_seen:
            return
        self.plan_seen = (e.ts, e.writer)
        why = valid_plan(e.value)
        if why is not None:
            self.refused["plan"] += 1
            ctx.log(f"refused plan/{self.chain} from robot {e.writer}: {why}")
            return
        if e.value.get("pe"):
            self.plan = e.value
            if not self.d3:
                self.path = motion.arc_points([p[:2] for p in e.value["pig"]])
            elif self.kind == "flying":  # follows pi in 3-D
                self.path = motion.arc_points([(list(p) + [0.0])[:3] for p in e.value["pi"]])
            else:  # follows pi_g on the ground
                self.path = motion.arc_points([[p[0], p[1], 0.0] for p in e.value["pig"]])
            self.s = None
        else:
            self.plan = e.value

    def _links(self, ctx: Context) -> None:
        """R6: declare failed links; splice a lost parent to a C_local ancestor within d_s, not one heard free.

        A recruit that its child has not taken as parent within ``join_time`` first withdraws, then goes back
        to free (``_overdue``), so that its child cannot take it in the tick it goes free.
        """
        if self._overdue(ctx) > self._ticks(ctx, "recruit"):
            self.role, self.chain, self.parent, self.child, self.depth = FREE, None, None, None, None
            self.plan = self.path = self.s = self.plan_seen = None
            self.up, self.dn = [], []
            self.joined.append([ctx.tick, "released"])
            return
        if self.parent is not None and not self._alive(ctx, self.parent) and self.parent != self.root:
            self.failed.append([ctx.tick, self.parent])
            self.parent_lost, self.parent = True, None
        if self.child is not None and not self._alive(ctx, self.child):
            self.failed.append([ctx.tick, self.child])
            self.child = None
            self.dn = [ctx.id]
        if self.parent_lost:
            for j in self.up[1:] + [self.root]:
                if j != ctx.id and self._alive(ctx, j) and self._dist(ctx, j) <= self.ds and not self._free(j):
                    self.parent, self.parent_lost = j, False
                    self.splices.append([ctx.tick, "parent", j])
                    break
        if self.role == NETWORKER and self.child is None and self.plan and self.plan.get("pe") \
                and self.s is not None and self.path is not None and self.s >= self.path[1][-1] - self.rcol:
            self.role = WORKER  # a temporary worker that reached the target

    def _overdue(self, ctx: Context) -> int:
        """R5's release of a recruit: the ticks it is past ``join_time`` untaken (0 or less: in time or taken).

        Past ``join_time`` it withdraws for ``recruit_time``: it stays in the chain but its REL_CHAIN names no
        child, so its child can no longer take it; then it goes back to free unless its child took it meanwhile.
        A child takes a recruit on a REL_CHAIN sent a tick earlier, and its ack (its own REL_CHAIN naming the
        recruit as parent, every tick from then on) arrives a tick later: a recruit that went free when
        ``join_time`` ran out could be taken in that very tick, and the chain hung on a free robot until the
        child heard it (Fig. 6 bottom, chain 11). Withdrawing for more than a tick lets a lost ack be made up by
        the next ones.
        """
        if self.role != NETWORKER or self.acked:
            return 0
        return ctx.tick - self.joined[-1][0] - self._ticks(ctx, "join")

    def _free(self, j: int) -> bool:
        """Robot j's last status said free: no chain robot, so never a parent to splice to (R6).

        ``up`` still names a recruit that was released before its child's ack reached it (R5); splicing to it
        would make a free robot the parent again, and the chain stays cut for as long as the run lasts.
        """
        h = self.heard.get(j)
        return h is not None and h[1].role == FREE

    def _free_neighbours(self, ctx: Context) -> list[int]:
        f = self._ticks(ctx, "forget")
        return sorted(j for j, (t, b) in self.heard.items() if b.role == FREE and ctx.tick - t <= f)

    def _can_recruit(self, ctx: Context) -> bool:
        """A chain robot recruits itself when it heard a free robot within ``forget_time`` (Sec. IV).

        Not a recruit its child has not taken yet (not a link yet); not while its last own slot closed without
        a winner within ``forget_time`` (the free robots it heard
        could not take the slot: out of reach of its call, taken by other slots, or not flying when the slot
        needs a flying robot); then it passes requests on towards the root.
        """
        return (self.role in (WORKER, NETWORKER) and self.parent is not None and not self.parent_lost and self.acked
                and ctx.tick - self.slot_empty_at > self._ticks(ctx, "forget") and bool(self._free_neighbours(ctx)))

    def _recruit(self, ctx: Context) -> None:
        """R5: recruiting; the CBAA slots on the recruiter's side.

        The head's NEED travels down to the robot that keeps it (``route``: the first with free neighbours, or
        the base), which opens a slot in front of itself (between its parent and itself) once stretched; a base
        without free neighbours asks the root.
        """
        for chain in sorted(self.pending):
            self._run_slot(ctx, chain)
        if self.role == ROOT or self.plan is None or not self.plan.get("pe") or self.parent_lost:
            return
        head = self.child is None
        stretched = self._stretched(ctx)
        every = self._ticks(ctx, "recruit")
        if head and not self.wp and self._asks(stretched) and not self._at_target() and self.parent is not None \
                and ctx.tick - self.need_sent >= every:
            self.need_sent = ctx.tick
            if keeps_request(self.route, self.parent == self.root, self._can_recruit(ctx)):
                self.need_until = ctx.tick + every
                self._log_ask(ctx)
            else:
                BODIES.send(ctx, self.parent, Need(self.chain))
        if self.chain in self.pending:
            return
        want = stretched and not self.done and (self.wp or ctx.tick <= self.need_until)
        if want and self._can_recruit(ctx):  # Sec. IV: the first chain robot with free neighbours recruits
            self._open(ctx, self.chain, ctx.id, self.parent)
            return
        if not want or self.parent != self.root or self.root_pos is None:
            return
        if ctx.tick - self.root_asked >= every:  # the root, where free robots wait, recruits in front of me
            self.root_asked = ctx.tick
            BODIES.send(ctx, self.root, Need(self.chain))

    def _asks(self, stretched: bool) -> bool:
        """Whether the head (without WP) asks for a robot now (R5, parameter ``ask``).

        "stretched": when its parent link is at d_s (the head then stands still by Eq. 8 until the slack of a
        recruit reaches it). "plan" (Sec. IV: "the worker robot determines the number of links required to
        reach the target and elects the necessary networkers"): while the chain holds fewer links (the head's
        depth) than n = ceil(d_path / d_s) of the plan, whatever its own link, so that the request travels and
        the recruiter, once stretched, recruits while the head moves on; also when stretched (a path whose
        straight links fall short of n * d_s).
        """
        if stretched or self.ask == "stretched":
            return stretched
        n = self.plan.get("n") if self.plan else None
        return is_int(n) and is_int(self.depth) and self.depth < n

    def _open(self, ctx: Context, chain: int, child: int, parent: int) -> None:
        """Open a CBAA slot: a free robot to sit between ``parent`` and ``child`` (one of them is me).

        The slot's position, which free robots bid on, is the parent's: the recruit goes there first.
        """
        self.serial += 1
        key = f"{ctx.id}:{self.serial}"
        close = ctx.tick + self._ticks(ctx, "recruit")
        self.pending[chain] = {"key": key, "close": close, "y": -math.inf, "z": None, "child": child,
                               "parent": parent}
        if parent == self.root:
            pos = self.root_pos if self.root_pos is not None else self._pos(ctx)
        else:
            pos = self.sensed.get(parent, self._pos(ctx))
        BODIES.broadcast(ctx, Task(key, [float(v) for v in pos], close, chain,
                                   self._needs_flying(chain, child, child == ctx.id)))
        if self.role == ROOT:  # the root opens a slot when a base asks it, in front of that base
            self.pending[chain]["log"] = [ctx.tick, 0, None, True, ctx.tick, None, None, None]
        else:
            asked = self.need_until - self._ticks(ctx, "recruit") if ctx.tick <= self.need_until else None
            self.pending[chain]["log"] = [ctx.tick, self.depth, self.cnt - 1 if self.child is not None else 0,
                                          self._stretched(ctx), asked, None, None, None]
        self.recruits.append(self.pending[chain]["log"])

    def _stretched(self, ctx: Context) -> bool:
        """R5's stretched test, the one place it is made: my parent link is at d_s - v_max dt or longer.

        With WP a stretched robot recruits; without it the head's ``ask`` and the robot that keeps the request
        use it; the recruiting records log it. False without a parent.
        """
        return self.parent is not None and self._dist(ctx, self.parent) >= self.ds - self.vmax * ctx.dt

    def _log_ask(self, ctx: Context) -> None:
        self.asked.append([ctx.tick, self.depth, self.cnt - 1 if self.child is not None else 0,
                           self._stretched(ctx)])

    def _needs_flying(self, chain: int, base: int, mine: bool = False) -> bool:
        """A recruit must fly while the chain holds fewer robots than the airborne part of pi needs."""
        plan = self.rel.peek(f"plan/{chain}")
        if valid_plan(plan) is not None or not plan.get("pe") or "g" not in plan:
            return False
        total = planner.length([p[:2] for p in plan["pig"]])
        if plan["g"] >= total - 1e-3:
            return False
        airborne = total - plan["g"]
        if self.d3:  # pi's own 3-D length after the point above g
            pi = [(list(p) + [0.0])[:3] for p in plan["pi"]]
            airborne = planner.length(pi) - planner.arc_3d(pi, plan["g"])
        if mine:  # the recruit goes in front of me: me and the robots above me
            have = 1 if self.child is None else self.cnt
        else:
            h = self.heard.get(base)
            have = h[1].n if h is not None else 0
        return have < math.ceil(airborne / self.ds)

    def _run_slot(self, ctx: Context, chain: int) -> None:
        """Close a slot: call the winner; forget the slot once it joined, or when the call goes unanswered.

        The call is repeated every tick while the winner is still heard announcing itself free (a lost
        REL_JOIN would otherwise cost ``join_time``; a robot that is no longer free ignores it).
        """
        p = self.pending[chain]
        call = Join(chain, p["parent"], p["child"], p["key"])
        if p.get("called") is None:
            if ctx.tick >= p["close"]:
                p["log"][5] = ctx.tick
                if p["z"] is None:
                    del self.pending[chain]
                    self.slot_empty_at = ctx.tick
                else:
                    p["log"][6] = p["z"]
                    BODIES.send(ctx, p["z"], call)
                    p["called"] = p["z"]
            return
        w = self.heard.get(p["called"])
        if w is not None and w[1].role == FREE and ctx.tick - w[0] <= 1:
            BODIES.send(ctx, p["called"], call)
        if p["child"] == ctx.id:
            childs_parent = self.parent
        else:
            h = self.heard.get(p["child"])
            childs_parent = h[1].parent if h is not None else None
        if childs_parent == p["called"]:  # the child took the recruit as its parent
            self.joined.append([ctx.tick, p["called"]])
            p["log"][7] = ctx.tick
            del self.pending[chain]
        elif ctx.tick > p["close"] + self._ticks(ctx, "join"):
            del self.pending[chain]

    def _bid(self, ctx: Context) -> None:
        """CBAA auction phase on a free robot: bid on the best slot it can win; share the slot table."""
        self.slots = {k: s for k, s in self.slots.items() if s["close"] >= ctx.tick}
        if self.choice not in self.slots:
            self.choice = None
        if self.choice is None:
            best = None
            for key, s in sorted(self.slots.items()):
                d = math.dist(self._pos(ctx)[:2], s["pos"])
                if d > self.ds:  # too far from the recruit's parent to be linked to it at once
                    continue
                c = 1.0 / (1.0 + d)
                if self.kind == "flying" and not s["fly"]:
                    c *= 0.1  # a flying robot takes a ground slot only when no ground robot bids
                if (c, -ctx.id) > (s["y"], -(s["z"] if s["z"] is not None else 10**9)) and (
                        best is None or c > best[0]):
                    best = (c, key)
            if best is not None:
                self.choice = best[1]
                self.slots[best[1]]["y"], self.slots[best[1]]["z"] = best[0], ctx.id
        if self.slots:
            BODIES.broadcast(ctx, Bid({k: (s["y"], s["z"]) for k, s in self.slots.items() if s["z"] is not None}))

    def _at_target(self) -> bool:
        return self.path is not None and self.s is not None and self.s >= self.path[1][-1] - 1e-6 \
            and self.child is None

    # ------------------------------------------------------------------ motion
    def _move(self, ctx: Context) -> None:
        x = self._pos(ctx)
        others = list(self.sensed.values())
        u, links = np.zeros(len(x)), []
        if self.role == FREE and self.root_pos is not None:
            v = self.root_pos - x
            d = float(np.linalg.norm(v))
            if d > self.ds:
                u = v / d * min(self.vmax, (d - self.ds) / ctx.dt + 1e-9)
            for j, (_t, b) in self.heard.items():  # step aside from chain robots
                if b.role in (WORKER, NETWORKER) and j in self.sensed:
                    w = x - self.sensed[j]
                    dw = float(np.linalg.norm(w))
                    if 1e-9 < dw < 2 * self.rcol + 0.3:
                        u = u + w / dw * self.vmax
            n = float(np.linalg.norm(u))
            if n > self.vmax:
                u = u / n * self.vmax
        elif self.role in (WORKER, NETWORKER) and self.path is not None:
            p, cum = self.path
            if self.s is None:
                self.s = motion.project(p, cum, x)
            else:
                self.s = motion.project(p, cum, x, self.s - 1.0, self.s + 1.0)
            dp = self._dist(ctx, self.parent) if not self.parent_lost else math.inf
            dch = None if self.child is None else self._dist(ctx, self.child)
            back = False
            if self.child is None:
                self.done = False
            if self.role == WORKER and self.child is None and float(np.linalg.norm(x - p[-1])) <= self.rcol / 2 \
                    and dp <= self.ds:
                if self.reached_at is None:
                    self.reached_at = ctx.tick
                self.done = True
                u = np.zeros(len(x))
            else:
                if self._keeps_done(ctx):
                    self.done = True  # R5: jostled off its target, not held there by its link: no recruit needed
                ahead = self.lookahead
                if self.kind == "ground" and self.plan.get("g", math.inf) < cum[-1] - 1e-3:
                    ahead = min(ahead, self.plan["g"] - self.s)  # a ground robot stops where pi leaves the ground
                uf = motion.u_path(p, cum, self.s, x, True, self.vmax, ctx.dt, ahead) if ahead > 0 else np.zeros(len(x))
                ub = motion.u_path(p, cum, self.s, x, False, self.vmax, ctx.dt, self.lookahead)
                tc = self.sensed[self.child] - x if self.child in self.sensed else None
                if tc is None and not self.acked:  # a recruit heading for a child it does not sense yet
                    tc = uf
                u = motion.preferred(uf, ub, dp, dch, self.ds, tc)
                back = dp > self.ds
                if not self.acked and back and self.parent in self.sensed:  # a recruit on its way to its slot
                    v = self.sensed[self.parent] - x
                    u, back = v / float(np.linalg.norm(v)) * self.vmax, False
            pending = not self.acked and dch is not None and dch > self.ds  # not a link yet: Eq. 4 does not bind
            links = [(self.sensed[j], self.dc if j == self.child and back else self.ds)
                     for j in (self.parent, self.child) if j is not None and j in self.sensed
                     and not (j == self.child and pending)]
        vel = [self.vel.get(j) for j in self.sensed]
        if self.role == ROOT:  # the ground station is fixed: it takes no part in the avoidance
            u = np.zeros(len(x))
        else:
            u = motion.constrain(u, x, links, others, self.rcol, ctx.dt, self.vmax, u_self=self.u_self, v_others=vel,
                                 vertical=self.kind == "flying", rng=ctx.rng)
        u = self._clear_of_walls(ctx, x, u, lambda v: motion.bound(v, x, links, others, self.rcol, ctx.dt))
        if self.role == WORKER and self.child is None and self.path is not None and self.reached_at is None:
            self.head_ticks += 1
            self.head_stopped += float(np.linalg.norm(u)) < 0.1 * self.vmax
        ctx.move([float(v) for v in u] if len(u) == 3 else
                 [float(u[0]), float(u[1])] + ([0.0] if len(ctx.position) == 3 else []))

    def _keeps_done(self, ctx: Context) -> bool:
        """R5: whether a worker pushed off its target after reaching it still counts its chain as at its target.

        It does while its parent link is not stretched. Once the worker stands on its target, the networkers
        whose parent links have slack keep moving forward along pi (Eq. 6-7) and crowd its end; the collision
        avoidance (Eq. 8) then pushes the worker 0.1-0.5 m off its target (the test is r_col/2). No recruit can
        bring it back: its own link is slack, and Eq. 6 takes it back by itself once there is room. Before this
        rule ``done`` dropped whenever it was pushed off, the chain's links at d_s near the root counted as
        stretched, and with WP the chain recruited again (Fig. 6, T = 4 with the C, trials 9 and 27: chains that
        had reached their targets took the last free robots, up to 13 robots for a path of n = 8 links, and
        another chain's head stood still at d_s for 36-50 s). A worker held off its target by a stretched parent
        link still drops ``done``, so that its chain recruits.
        """
        return (self.role == WORKER and self.child is None and self.reached_at is not None
                and self.parent is not None and not self.parent_lost and not self._stretched(ctx))

    def _clear_of_walls(self, ctx: Context, x: np.ndarray, u: np.ndarray, fix) -> np.ndarray:
        """Keep the body (radius r_col/2) off the known obstacles.

        A step whose end disc touches one is replaced by its part along a free axis (bounded again by
        ``fix``, Eq. 8 and the collision rule), else by standing still.
        """
        m = ctx.map
        if m is None or not float(np.linalg.norm(u)):
            return u
        r = self.rcol / 2 + 0.03
        ring = [np.array([math.cos(a), math.sin(a)]) * r for a in np.linspace(0, 2 * math.pi, 8, endpoint=False)]

        z = float(ctx.position[2]) if len(ctx.position) == 3 else 0.0
        ground = self.kind == "ground"
        if len(x) == 3:  # 3-D (air): the body is a cylinder of radius and half-height r round the end point
            ring = [np.append(q, dz) for dz in (-r, 0.0, r) for q in [np.zeros(2), *ring]]

            def clear(v):
                return not m.inside_all(x + v * ctx.dt + np.array(ring), ground=ground).any()
        else:
            offsets = np.array([np.zeros(2), *ring])

            def clear(v):
                ends = x + v * ctx.dt + offsets  # the end point and its ring, at the robot's height
                return not m.inside_all(np.column_stack([ends, np.full(len(ends), z)]), ground=ground).any()

        if clear(u):
            return u
        for v in np.diag(u):  # its part along each axis
            v = fix(v)
            if clear(v):
                return v
        return np.zeros(len(u))

    def _broadcast(self, ctx: Context) -> None:
        if self.role == ROOT:
            self.up, self.dn = [ctx.id], [ctx.id]
        child = None if self._overdue(ctx) > 0 else self.child  # R5: a recruit about to go free withdraws
        BODIES.broadcast(ctx, Chain(self.role, self.chain, self.parent, child, self.depth, self.up[: self.k + 1],
                                    self.dn[: self.k + 1], self.done, 1 if self.child is None else self.cnt))

    # ------------------------------------------------------------------ report
    def report(self) -> dict:
        return {
            "role": self.role, "chain": self.chain, "parent": self.parent, "child": self.child, "depth": self.depth,
            "won_at": self.won_at, "planned_at": self.planned_at, "plan_status": self.plan_status,
            "reached_at": self.reached_at,
            "path": self.plan["pi"] if self.plan and self.plan.get("pe") and self.role == WORKER else None,
            "n": self.plan.get("n") if self.plan else None, "kind": self.kind,
            "refused": dict(self.refused), "malformed": dict(self.malformed), "failed": self.failed,
            "splices": self.splices, "joined": self.joined,
            "asked": self.asked, "recruits": self.recruits, "head_ticks": self.head_ticks,
            "head_stopped": self.head_stopped,
            "stigmergy": self.node.counters(),
        }

    @classmethod
    def metrics(cls, reports: dict[int, dict]) -> dict:
        reached = [r["reached_at"] for r in reports.values() if r.get("reached_at") is not None]
        return {"robots": len(reports), "reached": len(reached), "last_reached": max(reached, default=None),
                "refused": sum(sum(r.get("refused", {}).values()) for r in reports.values()),
                "malformed": sum(sum(r.get("malformed", {}).values()) for r in reports.values()),
                "in_chains": sum(r["role"] in (WORKER, NETWORKER) for r in reports.values())}
