"""CBAA: the robot side. Imports no oracle."""

from __future__ import annotations

from collections import Counter

from protocols.cbaa.messages import BODIES, Bid
from protocols.cbaa.rules import KIND, NEG_INF, RESET, SCORES, UPDATE, decide, pair, score_row
from swarmactors import Behavior, Context, Frame
from swarmactors.robot.behavior import is_int, is_num
from swarmactors.robot.bodies import UNSET


# ------------------------------------------------------------------ the behaviour
class CBAA(Behavior):
    """Consensus-based auction: one task per robot, one robot per task."""

    name = "cbaa"
    kinds = (KIND,)
    plot_field = "task"
    plot_marks = {"tasks": "task"}  # the run plot draws the tasks; ``task`` indexes them (swarmactors.tools.plots)

    def __init__(self, tasks: list, at: int = 0, score: str = "inverse", scale: float = 1.0,
                 scores: list | None = None, consensus: str = "auto", every: int = 1,
                 quiet_after: int | None = None):
        self.tasks = [list(map(float, t)) for t in tasks]
        self.m = len(self.tasks)
        self.at, self.score_name, self.scale, self.matrix = at, score, float(scale), scores
        self.consensus, self.every, self.quiet_after = consensus, every, quiet_after
        self.mode = "max"
        self.id = -1
        self.started = False
        self.c: list[float] = [0.0] * self.m
        self.x: int | None = None
        self.y: list[float] = [0.0] * self.m
        self.z: list[int | None] = [None] * self.m
        self.s: dict[int, float] = {}
        self.changed_at: int | None = None
        self.changed_time: float | None = None
        self.last_sent: int | None = None
        self.dirty = False
        self.sent = 0
        self.received = 0
        self.dropped: Counter = Counter()
        self.bids_made = 0
        self.actions: Counter = Counter()

    @staticmethod
    def validate(params: dict) -> str | None:
        tasks = params.get("tasks")
        if not isinstance(tasks, list) or not tasks:
            return "tasks must be a non-empty list of [x, y] points"
        for i, t in enumerate(tasks):
            if not isinstance(t, list) or len(t) not in (2, 3) or not all(is_num(v) for v in t):
                return f"tasks[{i}] = {t!r} must be [x, y] or [x, y, z]"
        problem = SCORES.problem(params.get("score", "inverse"))
        if problem:
            return problem
        scale = params.get("scale", 1.0)
        if not is_num(scale) or scale <= 0:
            return f"scale = {scale!r} must be a positive number"
        scores = params.get("scores")
        if scores is not None:
            if not isinstance(scores, list) or not all(
                isinstance(r, list) and len(r) == len(tasks) and all(is_num(v) for v in r) for r in scores
            ):
                return f"scores must be a list of rows (one per robot id) of {len(tasks)} numbers"
        if params.get("consensus", "auto") not in ("auto", "max", "table"):
            return "consensus must be auto, max or table"
        for key in ("at", "every"):
            v = params.get(key, 1)
            if not is_int(v) or v < (1 if key == "every" else 0):
                return f"{key} = {v!r} must be an integer >= {1 if key == 'every' else 0}"
        q = params.get("quiet_after")
        if q is not None and (not is_int(q) or q < 1):
            return f"quiet_after = {q!r} must be a positive integer (or absent)"
        return None

    # -- hooks
    def on_start(self, ctx: Context) -> None:
        self.id = ctx.id
        self.mode = self.consensus if self.consensus != "auto" else ("table" if ctx.clock == "realtime" else "max")
        ctx.set_status(task=None)

    def _begin(self, ctx: Context) -> None:
        self.started = True
        if self.matrix is not None:
            row = self.matrix[ctx.id] if ctx.id < len(self.matrix) else [0.0] * self.m
            self.c = [float(v) for v in row]
        else:
            self.c = score_row(list(ctx.position), self.tasks, self.score_name, self.scale)

    def on_tick(self, ctx: Context, sensed) -> None:
        if ctx.tick < self.at:
            return
        if not self.started:
            self._begin(ctx)
        before = self._state()
        if self.x is None:
            self._auction()
        self._note(ctx, before)
        quiet = self.quiet_after is not None and self.changed_at is not None and \
            ctx.tick - self.changed_at > self.quiet_after
        due = self.last_sent is None or ctx.tick - self.last_sent >= self.every
        if self.dirty or (due and not quiet):  # A2
            seen = [[k, v] for k, v in self.s.items()] if self.mode == "table" else UNSET
            BODIES.broadcast(ctx, Bid(task=self.x, bids=self.y, winners=self.z, seen=seen))
            self.sent += 1
            self.last_sent = ctx.tick
            self.dirty = False
        ctx.set_status(task=self.x)

    def _auction(self) -> None:
        best = None
        for j in range(self.m):
            if self.c[j] > 0 and pair(self.c[j], self.id) > pair(self.y[j], self.z[j]):
                if best is None or self.c[j] > self.c[best]:
                    best = j
        if best is not None:  # A1: bid on the best task this robot can still win
            self.x, self.y[best], self.z[best] = best, self.c[best], self.id
            self.bids_made += 1

    def _state(self) -> tuple:
        return (self.x, tuple(self.y), tuple(self.z))

    def _note(self, ctx: Context, before: tuple) -> None:
        if self._state() != before:
            self.changed_at, self.changed_time = ctx.tick, ctx.now
            self.dirty = True

    def _parse(self, frame: Frame) -> tuple | None:
        b = BODIES.decode(frame, self.dropped)
        if not isinstance(b, Bid):
            return None
        y, z, t = b.bids, b.winners, b.task
        if len(y) != self.m or len(z) != self.m:
            self.dropped["wrong_length"] += 1
            return None
        if t is not None and not t < self.m:
            self.dropped["unknown_task"] += 1
            return None
        if any((w is None) != (v == 0) for v, w in zip(y, z, strict=True)) or (t is not None and z[t] != frame.src):
            self.dropped["inconsistent"] += 1
            return None
        s = {k: float(v) for k, v in ([] if b.seen is UNSET else b.seen)}
        return [float(v) for v in y], z, s

    def on_frame(self, ctx: Context, frame: Frame) -> None:
        parsed = self._parse(frame)
        if parsed is None:
            return
        self.received += 1
        yk, zk, sk = parsed
        k, i = frame.src, self.id
        before = self._state()
        if self.mode == "max":
            for j in range(self.m):
                if pair(yk[j], zk[j]) > pair(self.y[j], self.z[j]):  # M1: keep the larger (bid, -id) pair
                    self.y[j], self.z[j] = yk[j], zk[j]
        else:
            for j in range(self.m):
                action = decide(i, k, yk[j], zk[j], self.y[j], self.z[j], self.s, sk)  # T1
                self.actions[action] += 1
                if action == UPDATE:
                    self.y[j], self.z[j] = yk[j], zk[j]
                elif action == RESET:
                    self.y[j], self.z[j] = 0.0, None
            self.s[k] = float(ctx.now)  # T1: direct information from k is as fresh as now
            for m, t in sk.items():
                if m != i and m != k and t > self.s.get(m, NEG_INF):  # T1: relayed freshness
                    self.s[m] = t
        if self.x is not None and self.z[self.x] != i:  # X1: outbid on its task: drop it
            self.x = None
        self._note(ctx, before)

    def report(self) -> dict:
        return {
            "task": self.x,
            "bids": self.y,
            "winners": self.z,
            "changed_at": self.changed_at,
            "changed_time": self.changed_time,
            "scores": self.c,
            "score": self.c[self.x] if self.x is not None else 0.0,
            "sent": self.sent,
            "received": self.received,
            "dropped": dict(self.dropped),
            "bids_made": self.bids_made,
            "actions": dict(self.actions),
            "mode": self.mode,
        }

    @classmethod
    def metrics(cls, reports: dict[int, dict]) -> dict:
        held = Counter(r["task"] for r in reports.values() if r.get("task") is not None)
        tables = {tuple(r.get("winners", [])) for r in reports.values()}
        changes = [r["changed_at"] for r in reports.values() if r.get("changed_at") is not None]
        n = len(reports)
        sent = sum(r.get("sent", 0) for r in reports.values())
        dropped: Counter = Counter()
        for r in reports.values():
            dropped.update(r.get("dropped", {}))
        return {
            "robots": n,
            "assigned": sum(held.values()),
            "conflicts": sum(1 for c in held.values() if c > 1),
            "total_score": sum(r.get("score", 0.0) for r in reports.values()),
            "agreed": len(tables) == 1,
            "last_change": max(changes, default=None),
            "messages": sent,
            "messages_per_robot": sent / n if n else 0.0,
            "dropped": dict(dropped),
        }


# ------------------------------------------------------------------ oracle
