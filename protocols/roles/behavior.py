"""Role switching for continuous connectivity (Kobayashi, Higuchi & Ueno 2022): the robot behaviours.

``RoleSwitching`` (``roles``) is the paper's robot: base station, repeater, local leader or explorer;
Algorithm 1 made safe under loss; Algorithm 2 with CONNECT / DISCONNECT requests; the motion of Eqs. 1-7;
the recovery of Sec. III-D; and the patrol's target relay. ``AATWalk`` (``aat``) is the preliminary
experiment's explorer (Sec. IV-A): a random walk with Algorithm 2 or the every-tick baseline.

The rules, their numbering and every chosen value are in docs/protocols/roles.md; the module docstring of
``protocols.roles`` summarises them. Robots know only what they sensed (ids and positions within d_s) and
what they were told; nothing here uses an oracle.
"""

from __future__ import annotations

import math
import time
from typing import Any

import msgspec
import numpy as np

from protocols.roles import messages as msg
from protocols.roles.aat import MODES, PROPOSED, Connections
from protocols.roles.messages import (
    ACK,
    ARRIVED,
    BODIES,
    CONNECT,
    DISCONNECT,
    HELP,
    KINDS,
    LL_INFO,
    NACK,
    REQUEST,
    STATE,
    TARGET,
    WHERE,
)
from protocols.roles.params import RoleParams
from protocols.roles.rules import (
    BS,
    EX,
    EXTEND,
    LL,
    REMEMBERED,
    RETRACT,
    RP,
    Candidate,
    answer_request,
    cap,
    explorer_input,
    head_to,
    hold,
    leader_input,
    repeater_input,
    role_change_request,
)
from swarmactors import Behavior, Context, Frame
from swarmactors.robot.behavior import is_int, is_num
from swarmactors.robot.bodies import UNSET

# ------------------------------------------------------------------ roles and message kinds
ROLE_CODE = {BS: 0, RP: 1, LL: 2, EX: 3}
LINKABLE = (LL, EX)




def _r(v: np.ndarray, digits: int = 6) -> list[float]:
    return [round(float(v[0]), digits), round(float(v[1]), digits)]


class _Timed:
    """Mix-in: wall time spent in this robot's hooks, total and by role (the paper's 'processing time')."""

    def _clock_in(self) -> float:
        return time.perf_counter()

    def _clock_out(self, t0: float, role: str) -> None:
        dt = time.perf_counter() - t0
        self.cpu += dt
        self.cpu_role[role] = self.cpu_role.get(role, 0.0) + dt


# ================================================================== the paper's robot
class RoleSwitching(Behavior, _Timed):
    """A robot of Kobayashi et al.'s patrol: role switching, connection management, motion and recovery."""

    name = "roles"
    kinds = KINDS
    plot_field = "role"  # categorical: base station, repeater, local leader, explorer (rc holds a numeric code)

    def __init__(self, **params):
        self.p = RoleParams.of(params)  # the scenario's keys, validated in one place (params.py)
        # the paper's d_c and d_s are the robot's radio and sensing ranges: read from the context in on_start
        self.d_c = self.d_s = math.nan
        self.conn = Connections(self.p.aat, self.p.eta_c, math.nan, circles=self.p.circles)
        self.role = EX
        self.role_changed = True  # Algorithm 2 line 4: the first tick counts as a change
        self.parent: int | None = None
        self.child: int | None = None
        self.epoch = 0  # leadership epoch held (local leader) or the highest known (others)
        self.issued = 0  # the highest epoch this robot put in a request
        self.nbr: dict[int, dict] = {}  # latest STATE per robot
        self.known_role: dict[int, str] = {}
        self.repair: set[int] = set()  # robots that believe they are linked to us (STATE received)
        self.u = np.zeros(2)
        self.prev_pos: np.ndarray | None = None
        self.vel = np.zeros(2)
        # mission
        self.goal: list[float] | None = None
        self.goal_k = -1
        self.arrived_k = -1
        self.last_arrived_sent = -10**9
        self.targets: list[list[float]] = []
        self.target_i = 0
        self.reached: list[list] = []  # base station: [target index, tick]
        self.last_target_sent = -10**9
        # flooding of u_LL, x_LL (rules F1-F3 of protocols/flooding.py)
        self.flood_seq = 0
        self.seen: dict[tuple[int, int], float] = {}
        self.info: dict | None = None  # freshest {e, o, s, x, u}
        self.last_info = 0
        self.flood_stats = {"received": 0, "forwarded": 0, "expired": 0, "duplicates": 0}
        # Algorithm 1 hand-over
        self.ho: dict | None = None  # as requester
        self.pending: dict | None = None  # as candidate (accepted, waiting for the switch tick)
        self.took_over: dict | None = None  # how we became local leader (to revert if our epoch loses)
        self.handovers: list[dict] = []
        self.accepted: list[dict] = []
        self.refused: dict[str, int] = {}
        self.nacked: dict[int, int] = {}  # candidate -> tick it refused (skip it for a while)
        self.decided: dict[tuple[int, int], str] = {}  # (requester, epoch) -> why we refused it
        self.stepdowns = 0
        # recovery
        self.lost = False
        self.lost_episodes: list[list[int]] = []
        self.head: dict | None = None  # {id, role, pos, via}
        self.temp: int | None = None
        self.temps: list[list] = []  # [tick, robot connected to temporarily, its child, the child's role]
        self.last_help = -10**9
        self.helps = 0
        # accounting
        self.role_log: list[list] = []
        self.received = 0
        self.received_kind: dict[str, int] = {}
        self.ticks = 0
        self.ticks_role: dict[str, int] = {}
        self.cpu = 0.0
        self.cpu_role: dict[str, float] = {}
        self.frame_cpu = 0.0
        self.malformed: dict[str, int] = {}  # frames that did not decode, by cause
        self.stall = 0

    # ---------------------------------------------------------- parameters
    @staticmethod
    def validate(params: dict) -> str | None:
        """What is wrong with a scenario's parameters (``RoleParams.problem``), or None."""
        return RoleParams.problem(params)

    # ---------------------------------------------------------- helpers
    def _set_role(self, ctx: Context, role: str) -> None:
        if role != self.role:
            self.role = role
            self.role_changed = True
            self.role_log.append([ctx.tick, role])

    def _links_all(self) -> set[int]:
        """A_i: chain links plus the Algorithm 2 links."""
        out = set(self.conn.links)
        if self.role in (RP, LL) and self.parent is not None:
            out.add(self.parent)
        if self.role in (RP, BS) and self.child is not None:
            out.add(self.child)
        return out

    def _participants(self) -> tuple[list[int], np.ndarray]:
        """Return the sensed robots that take part in Algorithm 2 (its R_k and R_l).

        Every sensed robot not known to be a repeater or the base station ("all robots' roles are either
        local leaders or explorers in Algorithm 2"). A robot whose role we do not know yet counts: it can
        only remove links.
        """
        kr = self.known_role
        ids = self._sensed_ids
        idx = [k for k, r in enumerate(ids) if kr.get(r, EX) in LINKABLE]
        if len(idx) == len(ids):
            return ids, self._sensed_pos
        return [ids[k] for k in idx], self._sensed_pos[idx]

    def _send_to(self, ctx: Context, body: Any, dsts: set[int]) -> None:
        """Send to the robots ``dsts`` only.

        Addressed frames to one or two, else one radio broadcast with every other robot in range excluded.
        """
        if not dsts:
            return
        if len(dsts) <= 2 or self.d_s < self.d_c:  # robots beyond d_s but in radio range cannot be excluded
            for d in sorted(dsts):
                BODIES.send(ctx, d, body)
            return
        BODIES.broadcast(ctx, body, exclude=[r for r in self._sensed_ids if r not in dsts])

    def _where(self, rid: int | None) -> np.ndarray | None:
        """Return a robot's position: sensed this tick if it is in range, else from its last STATE."""
        if rid is None:
            return None
        k = self._sensed_index.get(rid)
        if k is not None:
            return self._sensed_pos[k]
        st = self.nbr.get(rid)
        return np.array(st.pos) if st else None

    def _key(self) -> tuple[int, int]:
        return (self.epoch, self.id)

    def _refuse(self, reason: str, src: int | None = None, epoch: int | None = None) -> None:
        self.refused[reason] = self.refused.get(reason, 0) + 1
        if src is not None:
            self.decided[(src, epoch)] = reason
            if len(self.decided) > 64:
                self.decided.pop(next(iter(self.decided)))

    # ---------------------------------------------------------- start
    def on_start(self, ctx: Context) -> None:
        self.id = ctx.id
        self.d_c, self.d_s = ctx.range, ctx.sensing  # the scenario's ranges (the robot group's range, sensing)
        self.conn.d_c = min(self.d_s, self.d_c)  # links need both: sensed (R_k, R_l) and within radio range
        self._sensed_ids: list[int] = []
        self._sensed_index: dict[int, int] = {}
        self._sensed_pos = np.zeros((0, 2))
        if ctx.id == self.p.base:
            self.role = BS
            self.child = self.p.leader
            self.targets = self._draw_targets()
        elif ctx.id == self.p.leader:
            self.role = LL
            self.parent = self.p.base
        self.known_role[self.p.base] = BS
        self.known_role[self.p.leader] = LL
        self.role_log.append([ctx.tick, self.role])

    def _draw_targets(self) -> list[list[float]]:
        t = self.p.targets
        if t is None:
            return []
        if isinstance(t, dict):
            rng = np.random.default_rng(t.get("seed", 0))
            lo, hi = float(t.get("lo", 0.0)), float(t.get("hi", 1.0))
            return np.round(rng.uniform(lo, hi, size=(int(t.get("count", 0)), 2)), 4).tolist()
        return [list(map(float, p)) for p in t]

    # ---------------------------------------------------------- frames
    def on_frame(self, ctx: Context, frame: Frame) -> None:
        t0 = time.perf_counter()
        self.received += 1
        kind = frame.kind
        self.received_kind[kind] = self.received_kind.get(kind, 0) + 1
        # a request that does not decode is refused (and not answered); any other kind is counted in malformed
        body = BODIES.decode(frame, self.refused if kind == REQUEST else self.malformed)
        if body is not None:
            _HANDLERS[kind](self, ctx, frame.src, body)
        self.frame_cpu += time.perf_counter() - t0  # charged to the role at the next tick

    def _on_state(self, ctx: Context, src: int, b: msg.State) -> None:
        self.nbr[src] = b
        role = b.role
        self.known_role[src] = role
        if role == LL:
            self._heard_leader(ctx, src, b.epoch, b.parent)
        if self.role in LINKABLE:
            if role in LINKABLE:
                if src not in self.conn.links and src not in (self.parent, self.child):
                    self.repair.add(src)  # it thinks we are linked: test it (Algorithm 2) at our next tick
            elif src in self.conn.links:
                self.conn.links.discard(src)  # a repeater or the base station: no explorer links with it
        elif role in LINKABLE and src not in (self.parent, self.child):
            BODIES.send(ctx, src, msg.Disconnect(self.role, "role"))  # repeaters link only parent and child

    def _heard_leader(self, ctx: Context, src: int, epoch: int, parent: int | None = None,
                      flood: bool = False) -> None:
        """Another robot claims the local leader role with ``epoch``: the larger (epoch, id) wins (rule H5).

        A local leader that hears of a larger one steps down into the role the chain gives it: repeater (its
        child: that leader) when that leader names it as parent, explorer otherwise. ``parent`` comes with a
        STATE; a flood carries none, so a flood is acted on only when its origin is not a robot we link
        (that one's STATE tells us more, one tick later).
        """
        if epoch > self.epoch and self.role != LL:
            self.epoch = epoch
        if self.role != LL or src == self.id or (epoch, src) <= self._key():
            return
        if flood and (src in self.conn.links or src == self.parent):
            return
        ho = self.ho
        if ho is not None and ho["to"] == src and ho["epoch"] == epoch:
            if ho.get("acked") is None:
                ho["acked"] = ctx.tick
                ho["evidence"] = "state"
            self._finish_handover(ctx)  # the candidate already leads: step down now
            return
        self.stepdowns += 1
        if ho is not None:
            ho["outcome"], ho["end"] = "superseded", ctx.tick
        if parent == self.id:  # it took the lead from us (an extension we did not see completed)
            self.child = src
            self.known_role[src] = LL
            self._drop_all_links(ctx, keep=())
            self._set_role(ctx, RP)
        else:  # our parent took the lead back (a retraction), or an unrelated leader
            if src == self.parent:
                self.conn.links.add(src)
            self.parent = None
            self._set_role(ctx, EX)
            self.last_info = ctx.tick
        self.epoch = epoch
        self.took_over = None
        self.ho = None

    def _on_ll_info(self, ctx: Context, src: int, b: msg.LeaderInfo) -> None:
        o, s, dl, h, e = b.origin, b.seq, b.deadline, b.hop, b.epoch
        if ctx.now > dl:  # F1: expired copies are ignored
            self.flood_stats["expired"] += 1
            return
        key = (o, s)
        if key in self.seen:  # F2: the first copy only
            self.flood_stats["duplicates"] += 1
            return
        self.seen[key] = dl
        self.flood_stats["received"] += 1
        if e > self.epoch and self.role != LL:
            self.epoch = e
        if self.role == LL and o != self.id:
            self._heard_leader(ctx, o, e, flood=True)
        cur = self.info
        if cur is None or (e, o) > (cur["e"], cur["o"]) or ((e, o) == (cur["e"], cur["o"]) and s > cur["s"]):
            self.info = {"e": e, "o": o, "s": s, "x": b.x, "u": b.u}
            self.last_info = ctx.tick
            if o != self.id:
                self.known_role[o] = LL  # the newest leader (a former repeater, after a retraction)
        if self.role in LINKABLE:  # F3: forward to every linked robot but the sender, while not expired
            dsts = self.conn.links - {src}
            if dsts:
                self._send_to(ctx, msgspec.structs.replace(b, hop=h + 1), dsts)
                self.flood_stats["forwarded"] += 1

    def _on_connect(self, ctx: Context, src: int, b: msg.Connect) -> None:
        self.known_role[src] = b.role
        if self.role in LINKABLE and b.role in LINKABLE and src not in (self.parent, self.child):
            self.conn.links.add(src)  # Algorithm 2 decided on src's side; we comply (and test it next tick)
            self.repair.add(src)
        elif src not in (self.parent, self.child):
            BODIES.send(ctx, src, msg.Disconnect(self.role, "role"))

    def _on_disconnect(self, ctx: Context, src: int, b: msg.Disconnect) -> None:
        self.known_role[src] = b.role
        self.conn.links.discard(src)
        self.repair.discard(src)

    # ---------------------------------------------------------- Algorithm 1 messages
    def _on_request(self, ctx: Context, src: int, b: msg.Request) -> None:
        """Answer a ROLE_REQUEST (``rules.answer_request``, rules H2-H3); accepting makes it pending."""
        p = self.pending
        ans = answer_request(b, src, self.role, self.epoch, src in self.conn.links or src in (self.parent, self.child),
                             self.child, (p["from"], p["epoch"]) if p is not None else None,
                             self.took_over["from"] if self.took_over else None, self.decided)
        if ans.why is not None and ans.new:
            self._refuse(ans.why, *((src, b.epoch) if ans.why in REMEMBERED else ()))
        if ans.reply == "nack":
            BODIES.send(ctx, src, msg.Nack(b.epoch, ans.why))
        elif ans.reply == "ack":
            if ans.new:  # H3: accepted; we switch at tick T
                goal = None if b.goal is UNSET or b.goal is None else list(b.goal)
                self.pending = {"from": src, "epoch": b.epoch, "T": b.at, "kind": b.kind, "goal": goal,
                                "gk": -1 if b.goal_k is UNSET else b.goal_k, "at": ctx.tick}
                self.accepted.append({"from": src, "epoch": b.epoch, "tick": ctx.tick, "T": b.at, "kind": b.kind})
            BODIES.send(ctx, src, msg.Ack(b.epoch))

    def _on_ack(self, ctx: Context, src: int, b: msg.Ack) -> None:
        ho = self.ho
        if ho is not None and ho["to"] == src and ho["epoch"] == b.epoch and ho.get("acked") is None:
            ho["acked"] = ctx.tick
            ho["evidence"] = "ack"

    def _on_nack(self, ctx: Context, src: int, b: msg.Nack) -> None:
        ho = self.ho
        if ho is not None and ho["to"] == src and ho["epoch"] == b.epoch and ho.get("acked") is None:
            ho["outcome"] = f"refused:{b.why}"
            ho["end"] = ctx.tick
            self.ho = None
            self.nacked[src] = ctx.tick

    # ---------------------------------------------------------- mission relay and recovery messages
    def _on_target(self, ctx: Context, src: int, b: msg.Target) -> None:
        if src != self.parent or self.role not in (RP, LL):
            return
        if b.k >= self.goal_k:
            self.goal, self.goal_k = list(b.x), b.k
        if self.role == RP and self.child is not None:
            BODIES.send(ctx, self.child, b)

    def _on_arrived(self, ctx: Context, src: int, b: msg.Arrived) -> None:
        if src != self.child:
            return
        if self.role == RP and self.parent is not None:
            BODIES.send(ctx, self.parent, b)
        elif self.role == BS and b.k == self.target_i and self.target_i < len(self.targets):
            self.reached.append([self.target_i, ctx.tick])
            self.target_i += 1
            self.last_target_sent = -10**9  # announce the next one at once

    def _on_help(self, ctx: Context, src: int, b: msg.Help) -> None:
        if self.role in (RP, BS) and self.child is not None:
            pos = self._where(self.child)
            if pos is not None:
                BODIES.send(ctx, src, msg.Where(self.role, self.child, self.known_role.get(self.child, RP), _r(pos)))

    def _on_where(self, ctx: Context, src: int, b: msg.Where) -> None:
        self.known_role[src] = b.role
        self.known_role[b.child] = b.child_role
        if self.role == EX and self.lost:
            h = self.head
            # take the first answer; then only the answer of the child we were sent to (one step further down
            # the chain: the temporary connection moves to it), or any answer that names the local leader
            if h is None or b.child_role == LL or (src == h["id"] and h["role"] != LL):
                self.head = {"id": b.child, "role": b.child_role, "pos": list(b.child_pos), "via": src}
                if self.temp != src:
                    self.temps.append([ctx.tick, src, b.child, b.child_role])
                self.temp = src

    # ---------------------------------------------------------- tick
    def on_tick(self, ctx: Context, sensed) -> None:
        t0 = self._clock_in() - self.frame_cpu  # this tick's frames count with its processing
        self.frame_cpu = 0.0
        self.ticks += 1
        self.ticks_role[self.role] = self.ticks_role.get(self.role, 0) + 1
        ids = sensed.ids
        self._sensed_ids = ids
        self._sensed_index = {rid: k for k, rid in enumerate(ids)}
        self._sensed_pos = sensed.positions()[:, :2] if ids else np.zeros((0, 2))
        x = np.asarray(ctx.position[:2], dtype=float)
        if self.prev_pos is not None:
            self.vel = x - self.prev_pos
        self.prev_pos = x
        self.u = np.zeros(2)
        self._handover_timers(ctx)
        if self.role == BS:
            self._tick_base(ctx)
        elif self.role == RP:
            self._tick_repeater(ctx, x)
        elif self.role == LL:
            self._tick_leader(ctx, x)
        else:
            self._tick_explorer(ctx, x)
        if self.role != BS:
            ctx.move((self.u / ctx.dt).tolist())  # u is per tick (the paper's timestep), velocity per second
        self._send_state(ctx, x)
        if ctx.tick % 20 == 0 and self.seen:
            self.seen = {k: dl for k, dl in self.seen.items() if dl >= ctx.now}
        ctx.set_status(role=self.role, rc=ROLE_CODE[self.role], conn=sorted(self._links_all()),
                       parent=self.parent if self.role in (RP, LL) else None,
                       child=self.child if self.role in (RP, BS) else None,
                       lost=self.lost, temp=self.temp, ep=self.epoch)
        if self.role == BS:
            ctx.set_status(target=self.target_i, reached=len(self.reached))
        self._clock_out(t0, self.role)

    def _send_state(self, ctx: Context, x: np.ndarray) -> None:
        dsts = self._links_all()
        if dsts:
            self._send_to(ctx, msg.State(self.role, _r(x), _r(self.vel), _r(self.u), len(dsts), self.epoch,
                                         self.parent if self.role in (RP, LL) else None), dsts)

    # ---------------------------------------------------------- Algorithm 1, made safe (rules H1-H6)
    def _handover_timers(self, ctx: Context) -> None:
        p = self.pending
        if p is not None and ctx.tick >= p["T"]:
            self._take_over(ctx)
        ho = self.ho
        if ho is None:
            return
        if ho.get("acked") is not None:
            if ctx.tick >= ho["T"]:
                self._finish_handover(ctx)
            return
        if ctx.tick > ho["T"] + self.p.lease:  # H4: lease expired without any answer - keep the lead
            ho["outcome"] = "timeout"
            ho["end"] = ctx.tick
            self.issued = max(self.issued, ho["epoch"]) + 1
            self.epoch = self.issued  # outrank a candidate that took over unheard (H5 steps it down)
            self.ho = None
            return
        self._send_request(ctx, ho)  # H2: retry every tick until acknowledged

    def _send_request(self, ctx: Context, ho: dict) -> None:
        ho["sent"] += 1
        BODIES.send(ctx, ho["to"], msg.Request(role=LL, epoch=ho["epoch"], at=ho["T"], kind=ho["kind"],
                                               goal=self.goal, goal_k=self.goal_k))

    def _start_handover(self, ctx: Context, to: int, kind: str) -> None:
        # every request gets an epoch never used before, so that a refused or abandoned one cannot tie
        self.issued = max(self.issued, self.epoch) + 1
        ho = {"to": to, "kind": kind, "epoch": self.issued, "t": ctx.tick, "T": ctx.tick + self.p.switch_delay,
              "sent": 0, "acked": None, "evidence": None, "outcome": None, "end": None}
        self.ho = ho
        self.handovers.append(ho)
        self._send_request(ctx, ho)

    def _finish_handover(self, ctx: Context) -> None:
        ho = self.ho
        self.ho = None
        ho["outcome"] = "done"
        ho["end"] = ctx.tick
        self.epoch = ho["epoch"]
        self.took_over = None
        c = ho["to"]
        if ho["kind"] == EXTEND:  # Algorithm 1 line 3: local leader -> repeater, its child leads
            self.child = c
            self.known_role[c] = LL
            self._drop_all_links(ctx, keep=())
            self._set_role(ctx, RP)
        else:  # line 6: local leader -> explorer, its parent leads
            self.known_role[c] = LL
            self.conn.links.add(c)
            self.parent = None
            self._set_role(ctx, EX)
            self.last_info = ctx.tick

    def _drop_all_links(self, ctx: Context, keep=()) -> None:
        drop = self.conn.links - set(keep)
        for j in sorted(drop):
            BODIES.send(ctx, j, msg.Disconnect(RP, "role"))
        self.conn.links = set(keep)

    def _take_over(self, ctx: Context) -> None:
        p = self.pending
        self.pending = None
        prev = {"from": p["from"], "role": self.role, "parent": self.parent, "kind": p["kind"]}
        self.epoch = p["epoch"]
        if p["kind"] == EXTEND:  # we were an explorer linked to the leader; it becomes our parent
            self.parent = p["from"]
            self.conn.links.discard(p["from"])
        else:  # we were its parent repeater; it becomes one of our explorers
            self.child = None
            self.conn.links.add(p["from"])
        self.known_role[p["from"]] = RP if p["kind"] == EXTEND else EX
        if p["goal"] is not None and p["gk"] >= self.goal_k:
            self.goal, self.goal_k = p["goal"], p["gk"]
        self.took_over = prev
        self.lost = False
        self.head = self.temp = None
        self._set_role(ctx, LL)

    def _algorithm1(self, ctx: Context, x: np.ndarray) -> None:
        """Algorithm 1 (``rules.role_change_request``): ask a linked explorer or the parent to lead."""
        xp = self._where(self.parent)
        if xp is None:
            return
        cands = []
        for c in self.conn.links:
            st = self.nbr.get(c)
            cands.append(Candidate(c, self._where(c), st.links if st and st.role in LINKABLE else 0,
                                   self.nacked.get(c)))
        req = role_change_request(ctx.tick, x, xp, self.parent, self.parent == self.p.base,
                                  self.nacked.get(self.parent), cands, self.goal, self.p, self.d_c)
        if req is None:
            return
        if req.to is None:
            self.stall += 1
        else:
            self._start_handover(ctx, req.to, req.kind)

    # ---------------------------------------------------------- roles' ticks
    def _tick_base(self, ctx: Context) -> None:
        if self.target_i < len(self.targets) and self.child is not None:
            if ctx.tick - self.last_target_sent >= self.p.target_every:
                BODIES.send(ctx, self.child, msg.Target(self.target_i, self.targets[self.target_i]))
                self.last_target_sent = ctx.tick
            self.goal, self.goal_k = self.targets[self.target_i], self.target_i

    def _tick_repeater(self, ctx: Context, x: np.ndarray) -> None:
        xp, xc = self._where(self.parent), self._where(self.child)
        if xp is None or xc is None:
            return
        u = repeater_input(x, xp, xc, self.known_role.get(self.child) == LL, self.p, self.d_c)  # Eqs. 1-2
        self.u = cap(hold(u, x, xp, self.p, self.d_c, xc), self.p.vmax)

    def _tick_leader(self, ctx: Context, x: np.ndarray) -> None:
        if self.ho is None and self.pending is None:
            self._algorithm1(ctx, x)
        if self.role != LL:
            return
        self._algorithm2(ctx, x)
        u = leader_input(x, self.goal, self.p)  # Eq. 3
        self.u = cap(hold(u, x, self._where(self.parent), self.p, self.d_c), self.p.vmax)
        # flood u_LL and x_LL to the explorers (message expiration, Sec. III-C)
        self.flood_seq += 1
        self.seen[(self.id, self.flood_seq)] = ctx.now + self.p.expiry
        self.info = {"e": self.epoch, "o": self.id, "s": self.flood_seq, "x": _r(x), "u": _r(self.u)}
        self.last_info = ctx.tick
        if self.conn.links:
            self._send_to(ctx, msg.LeaderInfo(self.id, self.flood_seq, ctx.now + self.p.expiry, 1, self.epoch, _r(x),
                                              _r(self.u)), self.conn.links)
        if self.goal is not None and float(np.hypot(*(x - np.array(self.goal)))) <= self.p.arrive:
            if self.arrived_k != self.goal_k:
                self.arrived_k = self.goal_k
                self.last_arrived_sent = -10**9
        if self.arrived_k == self.goal_k >= 0 and ctx.tick - self.last_arrived_sent >= self.p.target_every:
            BODIES.send(ctx, self.parent, msg.Arrived(self.goal_k))
            self.last_arrived_sent = ctx.tick

    def _tick_explorer(self, ctx: Context, x: np.ndarray) -> None:
        attached = ctx.tick - self.last_info <= self.p.lost_after
        if not attached and not self.lost:
            self.lost = True
            self.lost_episodes.append([ctx.tick, None])
        elif attached and self.lost:
            self.lost = False
            self.lost_episodes[-1][1] = ctx.tick
            self.head = self.temp = None
        self._algorithm2(ctx, x)
        if self.lost:
            self.u = self._recover(ctx, x)
            return
        links = sorted(self.conn.links)
        link_u = [st.u if (st := self.nbr.get(j)) is not None else None for j in links]
        link_x = [self._where(j) for j in links]
        leader = (self.info["u"], self.info["x"]) if self.info is not None else None
        self.u = explorer_input(x, link_u, link_x, leader, self.p)  # Eqs. 4-7

    def _recover(self, ctx: Context, x: np.ndarray) -> np.ndarray:
        """Sec. III-D: head to the origin; ask repeaters / the base station where their child is; go there."""
        if ctx.tick - self.last_help >= self.p.help_every:
            h = self.head
            if h is not None and h["role"] == RP and h["id"] in self._sensed_index:
                BODIES.send(ctx, h["id"], msg.Help())  # switch the temporary connection to the found repeater
            else:
                BODIES.broadcast(ctx, msg.Help())
            self.last_help = ctx.tick
            self.helps += 1
        h = self.head
        if h is not None:
            k = self._sensed_index.get(h["id"])
            goal = self._sensed_pos[k] if k is not None else np.array(h["pos"])
            if k is None and float(np.hypot(*(goal - x))) < 0.1:
                self.head = self.temp = None  # nobody at the place we were sent to: back to the origin
            else:
                return head_to(x, goal, self.p.vmax)
        return head_to(x, None, self.p.vmax)

    # ---------------------------------------------------------- Algorithm 2
    def _algorithm2(self, ctx: Context, x: np.ndarray) -> None:
        extra = sorted(self.repair)
        self.repair.clear()
        chain = {r for r in (self.parent, self.child, self.p.base) if r is not None}
        if self.p.witnesses == "all":  # the paper's line 2 as printed: every sensed robot witnesses
            ids, pos = self._sensed_ids, self._sensed_pos
            chain |= {r for r in ids if self.known_role.get(r, EX) not in LINKABLE}
        else:
            ids, pos = self._participants()
        added, removed, rejected = self.conn.refresh(
            x, ids, pos, chain, self.role_changed,
            force_all=self.lost, extra=extra, fixed=1 if self.role == LL else 0)
        self.role_changed = False
        for j in added:
            BODIES.send(ctx, j, msg.Connect(self.role))
        for j in sorted(set(removed) | set(rejected)):
            if j in self._sensed_index:
                BODIES.send(ctx, j, msg.Disconnect(self.role, "aat"))

    # ---------------------------------------------------------- reports
    def report(self) -> dict:
        ticks = max(self.ticks, 1)
        return {
            "role": self.role,
            "roles": self.role_log,
            "connections": sorted(self._links_all()),
            "parent": self.parent,
            "child": self.child,
            "epoch": self.epoch,
            "ticks": self.ticks,
            "ticks_by_role": self.ticks_role,
            "received": self.received,
            "received_by_kind": self.received_kind,
            "received_per_tick": self.received / ticks,
            "cpu_s": self.cpu,
            "cpu_by_role": self.cpu_role,
            "cpu_us_per_tick": 1e6 * self.cpu / ticks,
            "aat": self.conn.report(),
            "handovers": [{k: v for k, v in h.items()} for h in self.handovers],
            "accepted": self.accepted,
            "refused": self.refused,
            "stepdowns": self.stepdowns,
            "stall_ticks": self.stall,
            "lost_episodes": self.lost_episodes,
            "helps": self.helps,
            "temps": self.temps,
            "flood": self.flood_stats,
            "malformed": self.malformed,
            "targets": self.targets if self.role == BS else [],
            "reached": self.reached,
        }

    @classmethod
    def metrics(cls, reports: dict[int, dict]) -> dict:
        reps = [r for r in reports.values() if "role" in r]
        if not reps:
            return {}
        n = len(reps)
        hos = [h for r in reps for h in r["handovers"]]
        cpu_role: dict[str, float] = {}
        ticks_role: dict[str, int] = {}
        for r in reps:
            for k, v in r["cpu_by_role"].items():
                cpu_role[k] = cpu_role.get(k, 0.0) + v
            for k, v in r["ticks_by_role"].items():
                ticks_role[k] = ticks_role.get(k, 0) + v
        tests = sum(r["aat"]["tests"] for r in reps)
        base = sum(r["aat"]["baseline_tests"] for r in reps)
        refused: dict[str, int] = {}
        for r in reps:
            for k, v in r["refused"].items():
                refused[k] = refused.get(k, 0) + v
        return {
            "robots": n,
            "targets_reached": sum(len(r["reached"]) for r in reps),
            "handovers": len(hos),
            "handovers_done": sum(h["outcome"] == "done" for h in hos),
            "handovers_extend": sum(h["kind"] == EXTEND and h["outcome"] == "done" for h in hos),
            "handovers_retract": sum(h["kind"] == RETRACT and h["outcome"] == "done" for h in hos),
            "handover_requests_sent": sum(h["sent"] for h in hos),
            "role_changes": sum(len(r["roles"]) - 1 for r in reps),
            "repeaters_final": sum(r["role"] == RP for r in reps),
            "lost_episodes": sum(len(r["lost_episodes"]) for r in reps),
            "received_per_robot_tick": sum(r["received_per_tick"] for r in reps) / n,
            "cpu_us_per_robot_tick": sum(r["cpu_us_per_tick"] for r in reps) / n,
            "cpu_us_per_tick_by_role": {k: 1e6 * cpu_role[k] / ticks_role[k] for k in cpu_role if ticks_role.get(k)},
            "aat_tests": tests,
            "aat_tests_baseline": base,
            "aat_saving": 1 - tests / base if base else None,
            "refused": refused,
            "malformed": sum(sum(r["malformed"].values()) for r in reps),
        }


_HANDLERS = {
    STATE: RoleSwitching._on_state,
    LL_INFO: RoleSwitching._on_ll_info,
    CONNECT: RoleSwitching._on_connect,
    DISCONNECT: RoleSwitching._on_disconnect,
    REQUEST: RoleSwitching._on_request,
    ACK: RoleSwitching._on_ack,
    NACK: RoleSwitching._on_nack,
    TARGET: RoleSwitching._on_target,
    ARRIVED: RoleSwitching._on_arrived,
    HELP: RoleSwitching._on_help,
    WHERE: RoleSwitching._on_where,
}


# ================================================================== the preliminary experiment's explorer
class AATWalk(Behavior, _Timed):
    """Sec. IV-A: explorers on a random walk forming links by Algorithm 2 or by the every-tick baseline.

    Constant step, uniform direction; links by Algorithm 2 (``mode = "proposed"``, with CONNECT / DISCONNECT
    requests) or by the baseline that runs the acute angle test on every detectable robot every tick
    (``mode = "baseline"``, symmetric, no messages needed).
    The walk draws only from ``ctx.rng``, so both modes move the robots identically for one seed.
    """

    name = "aat"
    kinds = (CONNECT, DISCONNECT)
    plot_field = "degree"

    def __init__(self, mode: str = PROPOSED, eta_c: int = 3, step: float = 1.0, walk_until: int | None = None,
                 circles: bool = True):
        self.mode, self.step, self.walk_until = mode, step, walk_until
        self.conn = Connections(mode, eta_c, math.nan, circles=circles)  # d_c from the context in on_start
        self.first = True
        self.frame_cpu = 0.0
        self.received = 0
        self.malformed: dict[str, int] = {}  # frames that did not decode, by cause
        self.ticks = 0
        self.cpu = 0.0
        self.cpu_role: dict[str, float] = {}

    @staticmethod
    def validate(params: dict) -> str | None:
        if params.get("mode", PROPOSED) not in MODES:
            return f"mode = {params.get('mode')!r} must be one of {MODES}"
        if "step" in params and (not is_num(params["step"]) or params["step"] <= 0):
            return f"step = {params['step']!r} must be a positive number"
        if "eta_c" in params and (not is_int(params["eta_c"]) or params["eta_c"] < 0):
            return f"eta_c = {params['eta_c']!r} must be a non-negative integer"
        if "circles" in params and not isinstance(params["circles"], bool):
            return f"circles = {params['circles']!r} must be true or false"
        return None

    def on_start(self, ctx: Context) -> None:
        self.conn.d_c = min(ctx.sensing, ctx.range)  # the paper's d_c = d_s: the robot's sensing and radio ranges

    def on_frame(self, ctx: Context, frame: Frame) -> None:
        self.received += 1
        if BODIES.decode(frame, self.malformed) is None:
            return
        if frame.kind == CONNECT:
            self.conn.links.add(frame.src)
        else:
            self.conn.links.discard(frame.src)

    def on_tick(self, ctx: Context, sensed) -> None:
        t0 = self._clock_in() - self.frame_cpu  # this tick's frames count with its processing
        self.frame_cpu = 0.0
        self.ticks += 1
        ids = sensed.ids
        pos = sensed.positions()[:, :2] if ids else np.zeros((0, 2))
        x = np.asarray(ctx.position[:2], dtype=float)
        added, removed, _ = self.conn.refresh(x, ids, pos, (), self.first)
        self.first = False
        if self.mode == PROPOSED:  # the decision is no longer symmetric: tell the other side
            for j in added:
                BODIES.send(ctx, j, msg.Connect(EX))
            for j in removed:
                if j in ids:
                    BODIES.send(ctx, j, msg.Disconnect(EX, "aat"))
        if self.walk_until is None or ctx.tick < self.walk_until:
            a = float(ctx.rng.uniform(0.0, 2 * math.pi))
            ctx.move([self.step * math.cos(a) / ctx.dt, self.step * math.sin(a) / ctx.dt])  # a step per tick
        else:
            ctx.move([0.0, 0.0])
        ctx.set_status(role=EX, conn=sorted(self.conn.links), degree=len(self.conn.links))
        self._clock_out(t0, EX)

    def report(self) -> dict:
        rep = {"role": EX, "connections": sorted(self.conn.links), "aat": self.conn.report(),
               "received": self.received, "ticks": self.ticks, "cpu_s": self.cpu}
        if self.malformed:
            rep["malformed"] = self.malformed
        return rep

    @classmethod
    def metrics(cls, reports: dict[int, dict]) -> dict:
        reps = list(reports.values())
        if not reps:
            return {}
        n = len(reps)
        return {
            "robots": n,
            "aat_tests_per_robot": sum(r["aat"]["tests"] for r in reps) / n,
            "aat_tests_baseline_per_robot": sum(r["aat"]["baseline_tests"] for r in reps) / n,
            "aat_wall_s_per_robot": sum(r["aat"]["wall_s"] for r in reps) / n,
            "aat_runs_per_robot": sum(r["aat"]["runs"] for r in reps) / n,
        }
