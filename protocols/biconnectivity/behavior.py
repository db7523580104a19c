"""Biconnectivity: the robot side (CR-FILL, DCR-FILL, the check, joins and removals). Imports no oracle."""

from __future__ import annotations

import math
from collections import Counter, defaultdict

import numpy as np

from protocols.biconnectivity.geometry import _region_problem, join_position, prox, removal_distance
from protocols.biconnectivity.messages import (
    BODIES,
    BUDGET,
    CHECK_REQUEST,
    CR,
    DC_FALSE,
    DC_TRUE,
    DCR,
    HELLO,
    KINDS,
    LEAVE,
    MOVE,
    POS_REPLY,
    POS_REQUEST,
    VERDICT,
    Budget,
    Cr,
    DcFalse,
    Dcr,
    DcTrue,
    Hello,
    Leave,
    Move,
    PosReply,
    PosRequest,
    Request,
    Row,
    Stamped,
    Verdict,
)
from swarmactors import Behavior, Context, Frame
from swarmactors.robot.behavior import is_int, is_num

# the frame kinds, for the tests and the oracle that name them from here
__all__ = ["BUDGET", "CHECK_REQUEST", "CR", "DCR", "DC_FALSE", "DC_TRUE", "HELLO", "KINDS", "LEAVE", "MOVE",
           "POS_REPLY", "POS_REQUEST", "VERDICT", "Biconnectivity"]


# ================================================================ the behaviour
class Biconnectivity(Behavior):
    """CR-FILL, DCR-FILL and the check of Ahmadi & Stone, with adding and removing robots."""

    name = "biconnectivity"
    kinds = KINDS
    plot_field = "biconnected"

    def __init__(self, N: int = 16, c: float = 1, initiator: int | list[int] | None = None, at: int | list[int] = 0,
                 every: int | None = None, budget: int = 20000, flood_verdict: bool = False,
                 hello: int = 2, silence: int = 6, region: float = 0.0, margin: float = 0.02,
                 speed: float = 0.05, d_step: float | None = None, d_more: float | None = None,
                 max_rounds: int = 10, joiner: bool = False,
                 placement: str = "heuristic", leave: list | None = None, maintain: bool = True,
                 repeat: int = 1, graph: str = "radio", agree: int = 1, max_periods: int = 4):
        self.N, self.c = int(N), float(c)
        self.repeat = int(repeat)  # initiating messages per kind and period (R13; 1 = the paper)
        self.agree = int(agree)  # R15: periods whose conclusions must agree before a verdict (1 = the paper)
        self.max_periods = int(max_periods)  # R15: periods a check may run before it gives up (agree > 1)
        self.graph = graph  # R14: the fills run over the radio graph or over the structure-neighbour graph
        ids = [] if initiator is None else ([initiator] if isinstance(initiator, int) else list(initiator))
        ats = at if isinstance(at, list) else [at] * len(ids)
        self.start_at = dict(zip(ids, ats, strict=True))  # initiator id -> tick of its first check
        self.every = every
        self.budget, self.flood_verdict = budget, flood_verdict
        self.hello, self.silence = hello, silence
        self.region, self.margin, self.speed = float(region), float(margin), float(speed)
        self.d_step_param, self.d_more_param = d_step, d_more
        # derived from the robot's radio range (ctx.range) in on_start (_configure)
        self.reach: float | None = None  # structure-neighbour distance between centres
        self.safe: float | None = None  # what placement and the leader's model use
        self.d_step: float | None = None
        self.d_more: float | None = None
        self.max_rounds, self.joiner, self.placement, self.maintain = max_rounds, joiner, placement, maintain
        self.leave = {int(r): int(t) for r, t in (leave or [])}
        self.W = 3 * self.N * self.c  # the fills' wait (3Nc)
        self.bound = 6 * self.N * self.c + 2 * self.c  # the check's bound (6Nc + 2c), per period of a check
        # the whole check's bound: one period (the paper), or at most max_periods of them (R15)
        self.check_bound = self.bound if self.agree == 1 else self.max_periods * self.bound
        # fills
        self.period = -1
        self.joined: float | None = None
        self.cr: set[int] = set()
        self.dcr: set[int] = set()
        self.periods: dict[int, dict] = {}
        self.poisoned: set[int] = set()  # periods over budget
        self.budget_flooded: set[int] = set()
        self.malformed: Counter = Counter()
        self.stale: Counter = Counter()
        self.other: Counter = Counter()  # frames of the other kinds received
        # check
        self.check: dict | None = None
        self.checks: list[dict] = []
        self.dc_heard: dict[int, dict[str, set[int]]] = defaultdict(lambda: {"true": set(), "false": set()})
        self.evaluated: dict[int, bool] = {}  # period -> own DC answer, once evaluated
        self.next_check: int | None = None
        self.session: tuple | None = None  # (initiator id, request time) of the current check (R15)
        self.round_started: float | None = None  # when the current period of the check started here
        self.answer_only: int | None = None  # R15: a period to answer in after this robot's verdict
        self.biconnected: bool | None = None
        self.reason: str | None = None
        self.decided_at: int | None = None
        self.verdicts_seen: set[tuple] = set()
        # structure maintenance
        self.table: dict[int, list] = {}  # id -> [x, y, stamp tick, neighbour ids]
        self.heard: dict[int, int] = {}  # neighbour id -> tick of its last HELLO
        self.removed: set[int] = set()
        self.moves_seen: set[tuple] = set()
        self.motion: dict | None = None
        self.move_queue: list[dict] = []
        self.removals: list[dict] = []
        self.leading: dict | None = None
        self.join: dict | None = None
        self.jstate: dict | None = None
        self.left = False
        self.settled = not joiner

    # ------------------------------------------------------------ parameters
    @staticmethod
    def validate(params: dict, group: dict | None = None) -> str | None:
        """Why ``params`` cannot run, or None.

        ``group`` is the robot group as the scenario resolved it (its ``range`` is the robots' radio range):
        two regions must fit in it.
        """
        for key in ("N", "budget", "repeat", "agree", "max_periods"):
            if key in params and (not is_int(params[key]) or params[key] < 1):
                return f"{key} = {params[key]!r} must be an integer >= 1"
        at = params.get("at", 0)
        ini = params.get("initiator")
        if isinstance(at, list):
            if not all(is_int(a) and a >= 0 for a in at):
                return f"at = {at!r} must be a tick or a list of ticks"
            if not isinstance(ini, list) or len(ini) != len(at):
                return "a list of ticks in 'at' needs a list of initiators of the same length"
        elif not is_int(at) or at < 0:
            return f"at = {at!r} must be an integer >= 0 (a tick)"
        for key in ("hello", "silence", "max_rounds"):
            if key in params and (not is_int(params[key]) or params[key] < 0):
                return f"{key} = {params[key]!r} must be an integer >= 0"
        if params.get("every") is not None and (not is_int(params["every"]) or params["every"] < 1):
            return f"every = {params['every']!r} must be an integer >= 1 (ticks)"
        for key in ("c", "speed"):
            if key in params and (not is_num(params[key]) or params[key] <= 0):
                return f"{key} = {params[key]!r} must be a number > 0"
        for key in ("region", "margin"):
            if key in params and (not is_num(params[key]) or params[key] < 0):
                return f"{key} = {params[key]!r} must be a number >= 0"
        if is_num(params.get("margin", 0)) and params.get("margin", 0) >= 1:
            return "margin must be < 1"
        for key in ("d_step", "d_more"):
            if params.get(key) is not None and (not is_num(params[key]) or params[key] <= 0):
                return f"{key} = {params[key]!r} must be a number > 0"
        region = params.get("region", 0.0)
        if group is not None and is_num(region):
            problem = _region_problem(float(group["range"]), region)
            if problem:
                return problem
        if ini is not None and not (is_int(ini) or (isinstance(ini, list) and all(is_int(i) for i in ini))):
            return f"initiator = {ini!r} must be a robot id or a list of ids"
        if params.get("max_periods", 4) < params.get("agree", 1):
            return f"max_periods = {params.get('max_periods', 4)!r} must be >= agree = {params.get('agree', 1)!r}"
        if params.get("graph", "radio") not in ("radio", "structure"):
            return "graph must be 'radio' or 'structure'"
        if params.get("placement", "heuristic") not in ("heuristic", "min_intersection"):
            return "placement must be 'heuristic' or 'min_intersection'"
        lv = params.get("leave")
        if lv is not None and not (isinstance(lv, list) and all(
                isinstance(e, list) and len(e) == 2 and all(is_int(x) for x in e) for e in lv)):
            return "leave must be a list of [robot id, tick] pairs"
        if params.get("joiner") and params.get("hello", 2) == 0:
            return "a joiner needs hello > 0 (positions travel in HELLO tables)"
        return None

    # ------------------------------------------------------------ helpers
    def _configure(self, ctx: Context) -> None:
        """Derive the structure's distances from the robot's radio range (the scenario's, ``ctx.range``)."""
        problem = _region_problem(ctx.range, self.region)
        if problem:
            raise ValueError(f"biconnectivity: {problem}")
        self.reach = max(0.0, ctx.range - 2 * self.region)
        self.safe = self.reach * (1 - self.margin)
        self.d_step = self.d_step_param if self.d_step_param is not None else self.reach / 100
        self.d_more = self.d_more_param if self.d_more_param is not None else self.reach / 20

    def _tick_len(self, ctx: Context) -> float:
        """Clock units per tick: 1 in lockstep (c in ticks), dt seconds in realtime."""
        return 1.0 if ctx.clock == "lockstep" else ctx.dt

    def _stats(self, p: int) -> dict:
        st = self.periods.get(p)
        if st is None:
            st = self.periods[p] = {"joined": None, "joined_tick": None, "received": Counter(),
                                    "relayed": Counter(), "sent": Counter(), "over_budget": False}
        return st

    def _set_verdict(self, ctx: Context, value: bool | None, reason: str | None) -> None:
        self.biconnected, self.reason, self.decided_at = value, reason, ctx.tick
        ctx.set_status(biconnected=value, reason=reason)

    # ------------------------------------------------------------ fills (R1-R4)
    def _join_period(self, ctx: Context, p: int) -> None:
        self.period = p
        self.joined = ctx.now
        self.cr, self.dcr = set(), set()
        st = self._stats(p)
        st["joined"], st["joined_tick"] = ctx.now, ctx.tick
        ck = self.check
        if ck is not None and not ck["evaluated"]:
            ck["period"] = p  # a newer fill supersedes: the check evaluates on it
        ctx.set_status(period=p)
        for _ in range(self.repeat):  # R13: repeat > 1 sends independent copies (the relay treats each alike)
            for body in (Cr(p, [ctx.id]), Dcr(p, [ctx.id])):
                BODIES.broadcast(ctx, body)
                st["sent"][body.KIND] += 1

    def _see_period(self, ctx: Context, p: int, kind: str) -> bool:
        """Join a newer period; False (and counted stale) for an older one."""
        if p < self.period:
            self.stale[kind] += 1
            return False
        if p > self.period:
            self._join_period(ctx, p)
        return True

    def _stamps_fit(self, body: Stamped, src: int) -> bool:
        """R9: at most N stamps, the last one the sender's; False (counted by cause) otherwise."""
        if len(body.stamps) > self.N:
            self.malformed["more_than_n_stamps"] += 1
            return False
        if body.stamps[-1] != src:
            self.malformed["last_stamp_not_sender"] += 1
            return False
        return True

    def _structure_neighbour(self, ctx: Context, src: int) -> bool:
        """R14: ``src``'s region centre, as this robot's table knows it, within the structure-neighbour distance."""
        row = self.table.get(src)
        return row is not None and float(np.linalg.norm(np.array(row[:2]) - np.array(ctx.position[:2], dtype=float))
                                        ) <= self.reach * (1 + 1e-9)

    def _on_stamped(self, ctx: Context, frame: Frame, body: Stamped) -> None:
        if not self._stamps_fit(body, frame.src):
            return
        if self.graph == "structure" and not self._structure_neighbour(ctx, frame.src):
            self.other["not-structure-neighbour"] += 1
            return
        p, s = body.period, body.stamps
        if not self._see_period(ctx, p, frame.kind):
            return
        st = self.periods[p]
        st["received"][frame.kind] += 1
        me = ctx.id
        if isinstance(body, Cr):
            self.cr.update(x for x in s if x != me)  # R2
        elif me in s:  # R3 (Algorithm 2, lines 6-8)
            s2 = s[s.index(me) + 1:]
            if len(s2) > 1:
                self.dcr.update(s2)
        if me in s or p in self.poisoned:  # R1: never relay own-stamped; R7: a poisoned period is not relayed
            return
        if sum(st["relayed"].values()) >= self.budget:
            self._poison(ctx, p)
            return
        BODIES.broadcast(ctx, type(body)(p, s + [me]))
        st["relayed"][frame.kind] += 1
        st["sent"][frame.kind] += 1

    def _poison(self, ctx: Context, p: int) -> None:
        self.poisoned.add(p)
        self._stats(p)["over_budget"] = True
        if p not in self.budget_flooded:
            self.budget_flooded.add(p)
            BODIES.broadcast(ctx, Budget(p))
        if self.check is None or self.check["period"] != p:
            if self.biconnected is None:
                self.reason = "budget"

    # ------------------------------------------------------------ the check (R5-R8)
    def _start_check(self, ctx: Context, initiator: bool, p: int, t_request: float, by) -> None:
        old = self.check
        if old is not None and not old["done"]:  # a new check replaces one still waiting
            old.update(done=True, reason="superseded", decided=ctx.now, decided_at=ctx.tick)
        self.check = {"period": p, "initiator": initiator, "requested": t_request, "started": ctx.now,
                      "started_tick": ctx.tick, "evaluated": False, "own": None, "verdict": None,
                      "reason": None, "decided": None, "decided_at": None, "done": False}
        if self.agree > 1:
            self.check["rounds"] = []  # R15: [period, conclusion, reason] per period
        self.checks.append(self.check)
        self.session, self.round_started, self.answer_only = (by, t_request), t_request, None
        self.biconnected, self.reason, self.decided_at = None, None, None
        ctx.set_status(biconnected=None, reason=None)

    def _initiate(self, ctx: Context) -> None:
        fresh = self.joined is not None and ctx.now - self.joined < self.W
        if not fresh:
            self._join_period(ctx, max(ctx.tick, self.period + 1))
        p = self.period
        self._start_check(ctx, True, p, ctx.now, ctx.id)
        ctx.set_status(role="initiator")
        BODIES.broadcast(ctx, Request(p, ctx.now, ctx.id))

    def _answer(self, ctx: Context, p: int) -> None:
        """Algorithm 3, line 3: broadcast this robot's DC answer for period ``p``."""
        BODIES.broadcast(ctx, DcTrue(p) if self.evaluated[p] else DcFalse(p))

    def _on_request(self, ctx: Context, body: Request) -> None:
        p, t_req, by = body.period, body.requested, body.by
        if p > self.period:
            self._join_period(ctx, p)
        p = self.period  # an older request runs on the current fill
        ck = self.check
        if body.index is not None:  # R15: a further period of a running check; robots not running it only join (R4)
            if ck is None or self.session != (by, float(t_req)):
                return
            if p in self.evaluated:
                self._answer(ctx, p)
            elif ck["done"]:
                self.answer_only = p  # decided already: answer in p, keep the verdict
            return  # undecided: its check continues on p when its current period concludes
        if p in self.evaluated:  # already answered this period: repeat the answer for the new asker
            self._answer(ctx, p)
            return
        if ck is not None and not ck["done"] and ck["period"] == p:
            return  # already running it
        self._start_check(ctx, False, p, float(t_req), by)

    def _evaluate(self, ctx: Context) -> None:
        ck = self.check
        p = ck["period"]
        ck["evaluated"] = True
        ck["evaluated_at"] = ctx.now
        ck["cr"], ck["dcr"] = sorted(self.cr), sorted(self.dcr)
        if p in self.poisoned:
            self._decide(ctx, None, "budget")
            return
        own = len(self.dcr) == len(self.cr)  # Algorithm 3, line 3
        ck["own"] = own
        self.evaluated[p] = own
        self._answer(ctx, p)
        if not own:
            self._decide(ctx, False, "not doubly connected to all")  # line 7
        elif not self.cr:
            self._decide(ctx, False, "alone")
        else:
            self._try_decide(ctx)

    def _try_decide(self, ctx: Context) -> None:
        ck = self.check
        if ck is None or ck["done"] or not ck["evaluated"]:
            return
        heard = self.dc_heard[ck["period"]]
        if heard["false"]:
            self._decide(ctx, False, "a neighbour is not doubly connected to all")  # line 9
        elif heard["true"] and ck["own"]:
            self._decide(ctx, True, "this robot and a neighbour are doubly connected to all")  # lines 10-11

    def _next_period(self, ctx: Context, value: bool | None, reason: str) -> tuple[bool, bool | None, str]:
        """R15: record a period's conclusion; (final, verdict, reason), or start the check's next period.

        The verdict is final when the last ``agree`` periods concluded alike (true or false); after
        ``max_periods`` periods without that, it is null (``reason = "no agreement"``). Otherwise the robot
        runs the next period: the newer one it has already joined (a neighbour asked first), else a new
        one it starts itself (R4), and asks its neighbours to run it with the same check's request.
        """
        ck = self.check
        rounds = ck["rounds"]
        rounds.append([ck["period"], value, reason])
        last = [r[1] for r in rounds[-self.agree:]]
        if len(last) == self.agree and last[0] is not None and all(v == last[0] for v in last):
            return True, value, reason
        if reason == "budget":  # over budget is no accident of loss: another period would be too
            return True, None, reason
        if len(rounds) >= self.max_periods:
            return True, None, "no agreement"
        ck["evaluated"], ck["own"] = False, None
        self.round_started = ctx.now
        if self.period > ck["period"] and ctx.now - self.joined < self.W:
            ck["period"] = self.period
        else:
            self._join_period(ctx, max(ctx.tick, self.period + 1))  # moves the check to the new period
        by, t_req = self.session
        BODIES.broadcast(ctx, Request(self.period, t_req, by, len(rounds) + 1))
        return False, None, reason

    def _decide(self, ctx: Context, value: bool | None, reason: str) -> None:
        ck = self.check
        if self.agree > 1:
            final, value, reason = self._next_period(ctx, value, reason)
            if not final:
                return
        ck.update(done=True, verdict=value, reason=reason, decided=ctx.now, decided_at=ctx.tick)
        self._set_verdict(ctx, value, reason)
        if ck["initiator"] and self.flood_verdict and value is not None:
            key = (ck["period"], ctx.id)
            self.verdicts_seen.add(key)
            BODIES.broadcast(ctx, Verdict(ck["period"], ctx.id, value, reason))
        lead = self.leading
        if lead is not None and lead.get("checking") and ck["initiator"]:
            self._leader_verdict(ctx, value)

    def _on_dc(self, ctx: Context, src: int, body: DcTrue | DcFalse) -> None:
        self.dc_heard[body.period]["true" if isinstance(body, DcTrue) else "false"].add(src)
        self._try_decide(ctx)

    def _on_verdict(self, ctx: Context, body: Verdict) -> None:
        p = body.period
        key = (p, body.by)
        if key in self.verdicts_seen:
            return
        self.verdicts_seen.add(key)
        BODIES.broadcast(ctx, body)
        running = self.check is not None and not self.check["done"] and self.check["period"] == p
        if self.biconnected is None and not running:
            self._set_verdict(ctx, body.value, "flooded")

    def _on_budget(self, ctx: Context, body: Budget) -> None:
        p = body.period
        if not self._see_period(ctx, p, BUDGET):
            return
        if p not in self.poisoned:
            self._poison(ctx, p)

    # ------------------------------------------------------------ hooks
    def on_start(self, ctx: Context) -> None:
        self._configure(ctx)
        if ctx.id in self.start_at:
            self.next_check = self.start_at[ctx.id]
        if self.joiner:
            self.jstate = {"phase": "ask", "until": None, "asked": 0}
            ctx.set_status(role="joiner")

    def on_frame(self, ctx: Context, frame: Frame) -> None:
        if self.left:
            return
        if frame.kind not in (CR, DCR):
            self.other[frame.kind] += 1
        match BODIES.decode(frame, self.malformed):  # None for a body that does not fit, counted by cause
            case Stamped() as body:
                self._on_stamped(ctx, frame, body)
            case Request() as body:
                self._on_request(ctx, body)
            case DcTrue() | DcFalse() as body:
                self._on_dc(ctx, frame.src, body)
            case Budget() as body:
                self._on_budget(ctx, body)
            case Verdict() as body:
                self._on_verdict(ctx, body)
            case Hello(rows=rows):
                if frame.src not in self.removed:
                    self._merge(ctx, rows)
                    if self.settled:
                        self.heard[frame.src] = ctx.tick
            case PosRequest():
                if self.settled:
                    BODIES.send(ctx, frame.src, PosReply(self._table_rows(ctx)))
            case PosReply(rows=rows):
                self._merge(ctx, rows)
            case Leave():
                if self.maintain and self.settled:
                    self._lost(ctx, frame.src, "leave")
            case Move() as body:
                self._accept_move(ctx, body)

    def on_tick(self, ctx: Context, sensed) -> None:
        if self.left:
            return
        if self.leave.get(ctx.id) == ctx.tick:
            BODIES.broadcast(ctx, Leave(ctx.id))
            self.left = True
            ctx.move([0.0, 0.0])
            ctx.set_status(role="left")
            return
        ck = self.check
        if ck is not None and not ck["done"]:
            if not ck["evaluated"] and self.joined is not None and ctx.now >= self.joined + self.W:
                self._evaluate(ctx)
            elif ck["evaluated"] and ctx.now - self.round_started >= self.bound:
                self._decide(ctx, None, "timeout")
        if self.answer_only is not None and self.joined is not None and ctx.now >= self.joined + self.W:
            p, self.answer_only = self.answer_only, None  # R15: answer in a period after this robot's verdict
            if p == self.period and p not in self.evaluated:
                self.evaluated[p] = len(self.dcr) == len(self.cr)
                self._answer(ctx, p)
        if self.next_check is not None and ctx.tick >= self.next_check:
            self.next_check = None if self.every is None else self.next_check + self.every
            self._initiate(ctx)
        self._motion_tick(ctx)
        if self.jstate is not None:
            self._joiner_tick(ctx)
        if self.hello and self.settled and ctx.tick % self.hello == 0:
            self._send_hello(ctx)
        if self.maintain and self.hello and self.settled:
            for r, t in list(self.heard.items()):
                if ctx.tick - t > self.silence and r not in self.removed:
                    self._lost(ctx, r, "silence")
        if self.leading is not None:
            self._leader_tick(ctx)

    # ------------------------------------------------------------ positions (R10)
    def _neighbours(self, ctx: Context) -> list[int]:
        return sorted(r for r, t in self.heard.items() if ctx.tick - t <= self.silence and r not in self.removed)

    def _table_rows(self, ctx: Context) -> list[Row]:
        x, y = (float(v) for v in ctx.position[:2])
        self.table[ctx.id] = [x, y, ctx.tick, self._neighbours(ctx)]
        return [Row(rid, *row) for rid, row in sorted(self.table.items()) if rid not in self.removed]

    def _send_hello(self, ctx: Context) -> None:
        BODIES.broadcast(ctx, Hello(self._table_rows(ctx)))

    def _merge(self, ctx: Context, rows: list[Row]) -> None:
        """R10: take every row newer than the one this robot knows."""
        for row in rows:
            if row.rid == ctx.id or row.rid in self.removed:
                continue
            old = self.table.get(row.rid)
            if old is None or row.stamp > old[2]:
                self.table[row.rid] = [float(row.x), float(row.y), row.stamp, list(row.neighbours)]

    # ------------------------------------------------------------ removal (R12)
    def _lost(self, ctx: Context, r: int, how: str) -> None:
        if r in self.removed:
            return
        self.removed.add(r)
        self.heard.pop(r, None)
        entry = self.table.pop(r, None)
        if entry is None:
            return
        pos = np.array(entry[:2])
        here = [float(x) for x in ctx.position[:2]]
        centres = {v: (here if v == ctx.id else self.table[v][:2])
                   for v in set(entry[3]) | {ctx.id} if v != r and v not in self.removed
                   and (v == ctx.id or v in self.table)}
        # G_r: r's *structure* neighbours (their regions can talk to r's from anywhere), not every robot r heard:
        # with regions (region > 0) the radio reaches further than the structure-neighbour distance
        nbrs = {v for v, c in centres.items() if np.linalg.norm(np.array(c) - pos) <= self.reach * (1 + 1e-9)}
        if ctx.id not in nbrs or min(nbrs) != ctx.id or (self.leading is not None and self.leading["ended"] is None):
            return
        ids = sorted(nbrs)
        pts = [centres[v] for v in ids]
        d = removal_distance(np.array(pts), pos, self.safe, self.d_step)
        self.leading = {"removed": r, "how": how, "pos": pos.tolist(), "neighbours": ids, "d": [], "rounds": 0,
                        "started": ctx.tick, "verdict": None, "ended": None, "checking": False, "check_at": None}
        self.removals.append(self.leading)
        ctx.set_status(role="leader")
        ctx.log(f"leading the removal of {r} ({how}); d = {d:.4f}")
        self._flood_move(ctx, d)

    def _flood_move(self, ctx: Context, d: float) -> None:
        lead = self.leading
        lead["rounds"] += 1
        lead["d"].append(d)
        c_ticks = math.ceil(self.N * self.c / self._tick_len(ctx) - 1e-9)
        start = ctx.tick + c_ticks + 1
        body = Move(ctx.id, lead["rounds"], lead["removed"], lead["pos"], d, start, self.speed)
        move_ticks = math.ceil(d / (self.speed * ctx.dt) - 1e-9) if d > 0 else 0
        lead["check_at"] = start + move_ticks + 1
        self._accept_move(ctx, body)

    def _accept_move(self, ctx: Context, body: Move) -> None:
        key = (body.leader, body.round, body.removed)
        if key in self.moves_seen:
            return
        self.moves_seen.add(key)
        BODIES.broadcast(ctx, body)  # forward once
        removed = body.removed
        if removed not in self.removed:
            self.removed.add(removed)
            self.heard.pop(removed, None)
            self.table.pop(removed, None)
        if body.d > 0 and self.settled:
            self.move_queue.append({"pos": np.array(body.pos, dtype=float), "d": float(body.d),
                                    "start": int(body.start), "speed": float(body.speed), "x0": None})

    def _motion_tick(self, ctx: Context) -> None:
        """Follow the current MOVE: after k ticks the robot is at prox(x0, pos, min(k·speed·dt, d))."""
        m = self.motion
        if m is not None and m.get("arrived"):
            ctx.move([0.0, 0.0])
            self.motion = m = None
            ctx.set_status(moving=False)
        if m is None and self.move_queue and ctx.tick >= self.move_queue[0]["start"]:
            self.motion = m = self.move_queue.pop(0)
            ctx.set_status(moving=True)
        if m is None:
            return
        if m["x0"] is None:
            m["x0"] = np.array(ctx.position[:2], dtype=float)
            m["dist0"] = float(np.linalg.norm(m["x0"] - m["pos"]))
            m["goal"] = min(m["d"], m["dist0"])
        s = min((ctx.tick - m["start"] + 1) * m["speed"] * ctx.dt, m["goal"])
        target = prox(m["x0"], m["pos"], s)
        here = np.array(ctx.position[:2], dtype=float)
        ctx.move(((target - here) / ctx.dt).tolist())
        if s >= m["goal"]:
            m["arrived"] = True

    def _leader_tick(self, ctx: Context) -> None:
        lead = self.leading
        if lead["ended"] is not None:
            return
        if not lead["checking"] and lead["check_at"] is not None and ctx.tick >= lead["check_at"]:
            lead["checking"] = True
            self._initiate(ctx)

    def _leader_verdict(self, ctx: Context, value: bool | None) -> None:
        lead = self.leading
        lead["checking"] = False
        lead["verdict"] = value
        if value is True or value is None or lead["rounds"] >= self.max_rounds:
            lead["ended"] = ctx.tick
            ctx.set_status(role="leader-done")
            return
        self._flood_move(ctx, self.d_more)

    # ------------------------------------------------------------ joining (R11)
    def _known_centres(self, ctx: Context) -> tuple[list[int], np.ndarray]:
        ids = sorted(r for r in self.table if r != ctx.id and r not in self.removed)
        return ids, np.array([self.table[r][:2] for r in ids], dtype=float).reshape(-1, 2)

    def _go(self, ctx: Context, target: np.ndarray) -> bool:
        """Command a step towards ``target``; True once there."""
        here = np.array(ctx.position[:2], dtype=float)
        delta = target - here
        dist = float(np.linalg.norm(delta))
        if dist < 1e-5:  # poses come rounded to 1e-6
            ctx.move([0.0, 0.0])
            return True
        step = min(dist, self.speed * ctx.dt)
        ctx.move((delta / dist * step / ctx.dt).tolist())
        return False

    def _joiner_tick(self, ctx: Context) -> None:
        js = self.jstate
        wait = 2 * self.c + self._tick_len(ctx)
        phase = js["phase"]
        if phase in ("ask", "ask2"):
            if js["until"] is None:
                BODIES.broadcast(ctx, PosRequest(ctx.id))
                js["asked"] += 1
                js["until"] = ctx.now + wait
                return
            if ctx.now < js["until"]:
                return
            js["until"] = None
            ids, centres = self._known_centres(ctx)
            if not ids:
                return  # nobody answered: ask again
            if phase == "ask":
                got = join_position(centres, self.safe, method=self.placement, rho=self.region, rng=ctx.rng)
                if got is None:
                    return
                pos, value, closest = got
                js.update(first=pos.tolist(), first_value=value, nr=[ids[i] for i in closest])
                js["phase"] = "approach"
            else:
                nr = [r for r in js["nr"] if r in ids]
                must = [ids.index(r) for r in nr]
                got = join_position(centres, self.safe, must=must, method=self.placement, rho=self.region,
                                    rng=ctx.rng) or join_position(centres, self.safe, method=self.placement,
                                                                  rho=self.region, rng=ctx.rng)
                if got is None:
                    return
                pos, value, closest = got
                js.update(final=pos.tolist(), value=value, phase="go")
        elif phase == "approach":
            nr1 = js["nr"][0]
            if nr1 not in self.table:
                js["phase"] = "ask2"
                return
            c1 = np.array(self.table[nr1][:2])
            here = np.array(ctx.position[:2], dtype=float)
            if np.linalg.norm(here - c1) <= self.safe / 2:
                ctx.move([0.0, 0.0])
                js["phase"] = "ask2"
                return
            # head for nr1, stopping half the neighbour distance short of its centre
            d = np.linalg.norm(here - c1)
            self._go(ctx, c1 + (here - c1) / d * (self.safe / 2) * 0.999)
        elif phase == "go":
            if self._go(ctx, np.array(js["final"])):
                js["phase"] = "settled"
                self.settled = True
                self.heard = {}
                ids, centres = self._known_centres(ctx)
                self.join = {"position": js["final"], "value": js["value"], "nr": js["nr"],
                             "first_target": js["first"], "first_value": js["first_value"],
                             "requests": js["asked"], "settled_at": ctx.tick, "placement": self.placement}
                ctx.set_status(role="joined")
                self._send_hello(ctx)
                self.jstate = None

    # ------------------------------------------------------------ report and metrics
    def report(self) -> dict:
        periods = {str(p): {"joined": st["joined"], "joined_tick": st["joined_tick"],
                            "received": dict(st["received"]), "relayed": dict(st["relayed"]),
                            "sent": dict(st["sent"]), "over_budget": st["over_budget"]}
                   for p, st in sorted(self.periods.items())}
        checks = [{k: v for k, v in ck.items() if k != "done"} for ck in self.checks]
        return {
            "period": self.period if self.period >= 0 else None,
            "cr": sorted(self.cr),
            "dcr": sorted(self.dcr),
            "biconnected": self.biconnected,
            "reason": self.reason,
            "decided_at": self.decided_at,
            "checks": checks,
            "periods": periods,
            "malformed": sum(self.malformed.values()),
            "malformed_reasons": dict(self.malformed),
            "stale": dict(self.stale),
            "other_received": dict(self.other),
            "bounds": {"fill": self.W, "check": self.check_bound},
            "neighbours": sorted(self.heard),
            "removed": sorted(self.removed),
            "removals": [{k: v for k, v in r.items() if k not in ("checking", "check_at")} for r in self.removals],
            "join": self.join,
        }

    @classmethod
    def metrics(cls, reports: dict[int, dict]) -> dict:
        per = defaultdict(lambda: {"robots": 0, "received": Counter(), "relayed": Counter(), "sent": Counter()})
        for r in reports.values():
            for p, st in r.get("periods", {}).items():
                agg = per[p]
                agg["robots"] += 1
                for key in ("received", "relayed", "sent"):
                    agg[key].update(st[key])
        periods = {}
        for p, agg in sorted(per.items(), key=lambda kv: int(kv[0])):
            n = agg["robots"]
            periods[p] = {"robots": n, **{f"mean_{key}": {k: v / n for k, v in agg[key].items()}
                                          for key in ("received", "relayed", "sent")}}
        decided = [r for r in reports.values() if r.get("decided_at") is not None]
        return {
            "robots": len(reports),
            "periods": periods,
            "decided": len(decided),
            "verdicts": dict(Counter(str(r["biconnected"]) for r in decided)),
            "budget_hits": sum(1 for r in reports.values() if r.get("reason") == "budget"),
            "malformed": sum(r.get("malformed", 0) for r in reports.values()),
            "removals": [dict(r, leader=rid) for rid, rep in reports.items() for r in rep.get("removals", [])],
            "joins": {rid: rep["join"] for rid, rep in reports.items() if rep.get("join")},
        }
