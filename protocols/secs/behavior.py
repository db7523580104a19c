"""Robot side of the Robot Navigation Controller (Panerati et al., ICRA 2018, §III-B); imports no oracle.

SECS prominences, rendez-vous and flocking.

Every robot, every tick, broadcasts two messages:

- ``SECS_T`` {"a": arm, "T": ∠T (its arm's direction in its own frame, or null), "al": aligned, "d": its
  estimated distance to the master along the swarm, "v": its velocity in its own frame, and, relayed from the
  master, "p" (arm probabilities), "rv" (rendez-vous δ), "fl" (flocking) and, when the master runs a
  schedule, "ph" (the phase: how many behaviour changes the master has made)}; the master's "T" is the list
  of its tasks' directions, one per arm.
- ``SECS_M`` {"M": [[i, ∠M_ji], ...]}: the bearing, in its own frame, at which it sees each neighbour i (one
  frame for all neighbours; each i reads its own entry).

A receiver i takes ∠O_ij from ``frame.rab`` (send-tick positions, as j measured ∠M_ji) turned into its own
frame by its heading at the send tick, and composes ∠T_i = ∠T_j + ∠O_ij − ∠M_ji + π (rules.compose_target).
"Own frame" is the frame of ``ctx.pose``: fixed for a robot, turned from the world's by its unknown offset.
Angles on the wire must be finite and in [0, 2π); a frame with any other value is refused and counted.

With a ``schedule`` (the master's input only: the task subsets of the TSC, §III-C), the master is also the
BMU: per slot it leads the flock to the deployment point, erupts one prominence per task of the slot for the
slot's duration, then calls a rendez-vous (rules.bmu_next). Each change raises the phase "ph"; every robot
follows the highest phase it hears and relays it, and draws a new arm at each eruption.
"""

from __future__ import annotations

import math

from protocols.secs import rules
from protocols.secs.messages import BODIES, M_KIND, T_KIND, Bearings, Target
from swarmactors import Behavior
from swarmactors.robot.bodies import UNSET

STALE = 5  # ticks after which a neighbour's last message is not used
CLOSE = 0.4  # m: a circling robot also feels the Lennard-Jones push of robots closer than this
HOLD_BAND = 0.25  # m: with hold_tasks, an aligned robot this close to its task's distance stops


def _finite(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def parse_t(body) -> tuple[dict | None, str | None]:
    """A SECS_T body, decoded as ``messages.Target`` and its angles checked: (body, None) or (None, cause).

    The cause is the decoder's (``not_a_map``, ``missing_field``, ``bad_field``) or ``angle`` for a bad angle.
    """
    causes: dict[str, int] = {}
    t = BODIES.decode_body(T_KIND, body, causes)
    if t is None:
        return None, next(iter(causes))
    if t.arm < 0:
        if not isinstance(t.target, list) or not all(rules.angle_ok(x) for x in t.target):
            return None, "angle" if isinstance(t.target, list) else "bad_field"
    elif t.target is not None and t.target is not UNSET and not rules.angle_ok(t.target):
        return None, "angle"
    return body, None


def parse_m(body, me: int) -> tuple[float | None, str | None]:
    """This robot's ∠M_ji from a SECS_M body (``messages.Bearings``): (angle or None, None) or (None, cause)."""
    causes: dict[str, int] = {}
    m = BODIES.decode_body(M_KIND, body, causes)
    if m is None:
        return None, next(iter(causes))
    for i, angle in m.seen:
        if i == me:
            return (angle, None) if rules.angle_ok(angle) else (None, "angle")
    return None, None


def schedule_problem(sch) -> str | None:
    """What is wrong with a ``schedule`` parameter, or None.

    {robots = |N|, slots = [{deployment = [x, y], duration = s, tasks = [{id, position = [x, y]}, ...]}, ...]},
    lengths in m (the master's frame), durations in s.
    """
    if not isinstance(sch, dict) or not isinstance(sch.get("slots"), list) or not sch["slots"]:
        return f"schedule must be a table with a non-empty list slots, got {sch!r}"
    n = sch.get("robots")
    if n is not None and not (isinstance(n, int) and not isinstance(n, bool) and n >= 2):
        return f"schedule.robots must be an integer >= 2, got {n!r}"

    def point(v) -> bool:
        return isinstance(v, list) and len(v) == 2 and all(_finite(x) for x in v)

    for k, slot in enumerate(sch["slots"]):
        where = f"schedule.slots[{k}]"
        if not isinstance(slot, dict):
            return f"{where} must be a table, got {slot!r}"
        if not point(slot.get("deployment")):
            return f"{where}.deployment must be [x, y], got {slot.get('deployment')!r}"
        if not (_finite(slot.get("duration")) and slot["duration"] > 0):
            return f"{where}.duration must be a positive number of seconds, got {slot.get('duration')!r}"
        tasks = slot.get("tasks")
        if not isinstance(tasks, list) or not tasks:
            return f"{where}.tasks must be a non-empty list, got {tasks!r}"
        for i, t in enumerate(tasks):
            if not isinstance(t, dict) or not point(t.get("position")):
                return f"{where}.tasks[{i}].position must be [x, y], got {t!r}"
    return None


class SECS(Behavior):
    """Master (id ``master``) and backbone robots of the RNC.

    The master stays put (or leads a flock) and tells its neighbours the direction of each task (the world
    objects named ``task*`` it knows, in its own frame; it needs global sensing to know them). Backbone robots
    draw an arm, spiral round their informer until aligned with ∠T_i, then follow the Lennard-Jones forces
    (δ, ε) of all their neighbours; a robot with no informer of its arm keeps close with δ_close. After
    ``rendezvous_at`` seconds the master floods a smaller δ and every robot moves by Lennard-Jones only;
    after ``flock_at`` seconds it leads the flock (Eq. 3) towards ``flock_to``.

    Opt-in variants, all OFF by default (docs/protocols/secs.md, "Why our arm differs from Table I"):
    ``align_release`` (alignment lost beyond that many ``align_tol``, default 2; rules.still_aligned),
    ``turn_rate`` (rad/s: differential-drive bodies, rules.unicycle_step), ``walk_back`` (a robot that loses
    its alignment out of the master's sight walks back to it, rules.walk_back), ``strip`` (m: also aligned
    within that distance of the informer's arm line, rules.in_strip), ``hold_tasks`` (scheduled runs: the
    master floods each task's distance and an aligned robot stops there, rules.hold_velocity).
    """

    name = "secs"
    kinds = (T_KIND, M_KIND)
    frames = ("global", "local")
    plot_field = "arm"

    def __init__(self, master: int = 0, delta: float = 240.0, epsilon: float = 1e6, delta_close: float = 120.0,
                 v_max: float = 0.15, align_tol: float = 0.087, rendezvous_at: float | None = None,
                 delta_rv: float = 90.0, flock_at: float | None = None, flock_to: list | None = None,
                 flock_speed: float = 0.05, task_prefix: str = "task", schedule: dict | None = None,
                 settle_max: float = 60.0, arrive_tol: float = 0.1, align_release: float = 2.0,
                 turn_rate: float | None = None, walk_back: bool = False, strip: float | None = None,
                 hold_tasks: bool = False):
        self.master, self.delta, self.epsilon, self.delta_close = master, delta, epsilon, delta_close
        self.v_max, self.align_tol = v_max, align_tol
        self.rendezvous_at, self.delta_rv = rendezvous_at, delta_rv
        self.flock_at, self.flock_to, self.flock_speed = flock_at, flock_to, flock_speed
        self.task_prefix = task_prefix
        self.schedule, self.settle_max, self.arrive_tol = schedule, settle_max, arrive_tol
        # opt-in variants, OFF by default (docs/protocols/secs.md, "Why our arm differs from Table I"):
        # hysteresis factor, differential-drive turn rate (rad/s), walk back to the master, strip half-width (m)
        self.align_release, self.turn_rate, self.walk_back, self.strip = align_release, turn_rate, walk_back, strip
        self.hold_tasks = hold_tasks  # opt-in, OFF by default: arms stop at their task's distance
        self.reach: list | None = None  # each task's distance from the master (hold_tasks only)
        self.walking = False
        self.body_heading = 0.0
        self.ph: int | None = None  # the phase followed (scheduled runs only)
        self.stage: str | None = None  # the master's BMU stage, slot, and since when (s)
        self.slot = 0
        self.stage_at = 0.0
        self.arrived_at: float | None = None
        self.stages: list = []  # [tick, slot (1-based), stage] at each change: the master's log
        self.heads: dict[int, float] = {}
        self.info: dict[int, tuple[int, dict]] = {}  # j -> (sent tick, SECS_T body)
        self.seen_by: dict[int, tuple[int, float, float]] = {}  # j -> (sent tick, ∠M_ji, ∠O_ij)
        self.arm: int | None = None
        self.probs: list | None = None
        self.target: float | None = None
        self.aligned = False
        self.informer: int | None = None
        self.dist = math.inf
        self.mode = "secs"
        self.rv: float | None = None
        self.v = (0.0, 0.0)
        self.refused: dict[str, int] = {}
        self.radius = 1.0
        self.first_aligned: int | None = None
        self.realigned = 0
        self.odo: list | None = None
        self.at: int | None = None

    @staticmethod
    def validate(params: dict) -> str | None:
        for key in ("delta", "delta_close", "delta_rv", "epsilon", "v_max", "align_tol"):
            if key in params and not (_finite(params[key]) and params[key] > 0):
                return f"{key} must be a positive number, got {params[key]!r}"
        for key in ("settle_max", "arrive_tol", "align_release"):
            if key in params and not (_finite(params[key]) and params[key] > 0):
                return f"{key} must be a positive number, got {params[key]!r}"
        for key in ("turn_rate", "strip"):
            if params.get(key) is not None and not (_finite(params[key]) and params[key] > 0):
                return f"{key} must be a positive number or absent, got {params[key]!r}"
        for key in ("walk_back", "hold_tasks"):
            if key in params and not isinstance(params[key], bool):
                return f"{key} must be true or false, got {params[key]!r}"
        if params.get("schedule") is not None:
            problem = schedule_problem(params["schedule"])
            if problem:
                return problem
            if params.get("flock_at") is not None or params.get("rendezvous_at") is not None:
                return "schedule drives flocking and rendez-vous: give no flock_at / rendezvous_at with it"
        ft = params.get("flock_to")
        if ft is not None and not (isinstance(ft, list) and len(ft) == 2 and all(_finite(x) for x in ft)):
            return f"flock_to must be [x, y], got {ft!r}"
        return None

    # ----------------------------------------------------------------------------------------------- hooks
    def on_start(self, ctx) -> None:
        far = self._far()
        self.radius = float(ctx.rng.uniform(0.5, 1.0)) * far  # the spiral's randomised radius
        if ctx.id == self.master:
            self.dist = 0.0
            self.arm = -1
        elif self.turn_rate is not None:  # drawn only in this variant: the default runs' draws are unchanged
            self.body_heading = float(ctx.rng.uniform(0.0, 2 * math.pi))

    def _far(self) -> float:
        return min(1.2 * self.delta / 100.0, 2.5)

    def _tick_of(self, ctx, sent: float) -> int:
        return int(sent) if ctx.clock == "lockstep" else int(round(sent / ctx.dt))

    def on_frame(self, ctx, frame) -> None:
        sent = self._tick_of(ctx, frame.sent)
        if frame.kind == T_KIND:
            body, bad = parse_t(frame.body)
            if bad:
                self.refused[bad] = self.refused.get(bad, 0) + 1
                return
            self.info[frame.src] = (sent, body)
            return
        m, bad = parse_m(frame.body, ctx.id)
        if bad:
            self.refused[bad] = self.refused.get(bad, 0) + 1
            return
        if m is None or frame.rab is None:
            return
        head = self.heads.get(sent, ctx.pose[-1])
        self.seen_by[frame.src] = (sent, m, rules.wrap(head + frame.rab[1]))

    def _neighbours(self, ctx, sensed) -> dict[int, tuple[float, float]]:
        """{id: (distance, bearing in the own frame)} of the sensed robots."""
        out = {}
        if ctx.sensing_frame == "local":
            h = float(ctx.pose[-1])
            for s in sensed:
                out[s.id] = (float(s.range), rules.wrap(h + float(s.bearing)))
        else:
            x, y = float(ctx.position[0]), float(ctx.position[1])
            for s in sensed:
                dx, dy = float(s.pos[0]) - x, float(s.pos[1]) - y
                out[s.id] = (math.hypot(dx, dy), rules.wrap(math.atan2(dy, dx)))
        return out

    def _fresh(self, ctx, j: int) -> dict | None:
        got = self.info.get(j)
        return got[1] if got and ctx.tick - got[0] <= STALE else None

    def on_tick(self, ctx, sensed) -> None:
        tick = ctx.tick
        self.heads[tick] = float(ctx.pose[-1])
        self.heads.pop(tick - 2 * STALE, None)
        nb = self._neighbours(ctx, sensed)
        if ctx.id != self.master:
            body = self._backbone_tick(ctx, nb)
        elif self.schedule is not None:
            body = self._bmu_tick(ctx, nb)
        else:
            body = self._master_tick(ctx, nb)
        if self.turn_rate is not None and ctx.id != self.master:
            self.body_heading, self.v = rules.unicycle_step(self.body_heading, self.v, self.turn_rate, ctx.dt)
        ctx.move(list(self.v))
        body["v"] = [round(self.v[0], 6), round(self.v[1], 6)]
        BODIES.broadcast(ctx, Target.of(body))
        BODIES.broadcast(ctx, Bearings(seen=[[j, nb[j][1]] for j in sorted(nb)]))
        self.odo, self.at = [float(c) for c in ctx.position[:2]], tick
        ctx.set_status(arm=self.arm, aligned=self.aligned, mode=self.mode)

    def _master_tick(self, ctx, nb) -> dict:
        now = ctx.tick * ctx.dt
        x, y = float(ctx.position[0]), float(ctx.position[1])
        tasks = sorted((k, v) for k, v in ctx.objects.items() if k.startswith(self.task_prefix))
        angles = [rules.wrap(math.atan2(p[1] - y, p[0] - x)) for _, p in tasks]
        self.probs = rules.arm_probabilities([math.hypot(p[0] - x, p[1] - y) for _, p in tasks])
        body = {"a": -1, "T": angles, "al": True, "d": 0.0, "p": self.probs}
        if self.rendezvous_at is not None and now >= self.rendezvous_at:
            self.mode, self.rv = "rendezvous", self.delta_rv
            body["rv"] = self.delta_rv
        self.v = (0.0, 0.0)  # the master stays in the swarm
        if self.flock_at is not None and now >= self.flock_at and self.mode != "rendezvous":
            self.mode = "flocking"
            body["fl"] = 1
            if self.flock_to is not None:
                dx, dy = self.flock_to[0] - x, self.flock_to[1] - y
                if math.hypot(dx, dy) > 0.05:
                    self.v = rules.clip((dx * 10, dy * 10), self.flock_speed)
        return body

    def _enter(self, ctx, stage: str, slot: int) -> None:
        self.ph = 0 if self.ph is None else self.ph + 1
        self.stage, self.slot, self.stage_at, self.arrived_at = stage, slot, ctx.tick * ctx.dt, None
        self.stages.append([ctx.tick, slot + 1, stage])

    def _bmu_tick(self, ctx, nb) -> dict:
        """The master as the BMU of §III-C: its schedule's slots in order, one stage at a time (rules.bmu_next)."""
        now = ctx.tick * ctx.dt
        x, y = float(ctx.position[0]), float(ctx.position[1])
        slots = self.schedule["slots"]
        if self.stage is None:
            self._enter(ctx, "flocking", 0)
        tx, ty = slots[self.slot]["deployment"]
        if self.stage == "flocking" and self.arrived_at is None and math.hypot(tx - x, ty - y) <= self.arrive_tol:
            self.arrived_at = now
        size = self.schedule.get("robots")
        stage, slot = rules.bmu_next(
            self.stage, self.slot, now - self.stage_at, last=self.slot == len(slots) - 1,
            duration=float(slots[self.slot]["duration"]), gathered=size is not None and len(nb) >= size - 1,
            waited=None if self.arrived_at is None else now - self.arrived_at, settle_max=self.settle_max)
        if (stage, slot) != (self.stage, self.slot):
            self._enter(ctx, stage, slot)
        self.mode = self.stage
        body = {"a": -1, "T": [], "al": True, "d": 0.0, "ph": self.ph}
        self.v = (0.0, 0.0)  # the master stays in the swarm, but while it leads the flock
        if self.stage == "flocking":
            body["fl"] = 1
            tx, ty = slots[self.slot]["deployment"]
            if math.hypot(tx - x, ty - y) > 0.05:
                self.v = rules.clip(((tx - x) * 10, (ty - y) * 10), self.flock_speed)
        elif self.stage == "secs":
            tasks = [t["position"] for t in slots[self.slot]["tasks"]]
            body["T"] = [rules.wrap(math.atan2(p[1] - y, p[0] - x)) for p in tasks]
            self.probs = rules.arm_probabilities([math.hypot(p[0] - x, p[1] - y) for p in tasks])
            body["p"] = self.probs
            if self.hold_tasks:
                body["r"] = [round(math.hypot(p[0] - x, p[1] - y), 6) for p in tasks]
        else:
            self.rv = self.delta_rv
            body["rv"] = self.delta_rv
        return body

    def _follow_phase(self, ctx, phased: list) -> None:
        """Adopt the highest phase heard, if newer than ours: its mode, and at an eruption a new arm."""
        best = max(phased, key=lambda b: b["ph"], default=None)
        if best is None or (self.ph is not None and best["ph"] <= self.ph):
            return
        self.ph, self.arm, self.probs, self.rv = best["ph"], None, None, None
        self.reach = list(best["r"]) if self.hold_tasks and best.get("r") else None
        self.target, self.aligned, self.informer = None, False, None
        if best.get("rv") is not None:
            self.mode, self.rv = "rendezvous", float(best["rv"])
        elif best.get("fl"):
            self.mode = "flocking"
        else:
            self.mode = "secs"
            if best.get("p"):
                self.probs = list(best["p"])
                self.arm = rules.draw_arm(self.probs, float(ctx.rng.random()))

    def _backbone_tick(self, ctx, nb) -> dict:
        fresh = {j: b for j in nb if (b := self._fresh(ctx, j)) is not None}
        ds = [b["d"] + nb[j][0] for j, b in fresh.items() if b.get("d") is not None]
        self.dist = min(ds, default=math.inf)
        phased = [b for b in fresh.values() if b.get("ph") is not None]
        if phased or self.ph is not None:  # a scheduled run: follow the master's phases
            self._follow_phase(ctx, phased)
            fresh = {j: b for j, b in fresh.items() if b.get("ph") == self.ph}
        else:
            for b in fresh.values():
                if b.get("p") and self.probs is None:
                    self.probs = list(b["p"])
                    self.arm = rules.draw_arm(self.probs, float(ctx.rng.random()))
                if b.get("rv") is not None:
                    self.mode, self.rv = "rendezvous", float(b["rv"])
                elif b.get("fl") and self.mode == "secs":
                    self.mode = "flocking"
        body = {"a": self.arm if self.arm is not None else 0,
                "T": None, "al": False, "d": None if math.isinf(self.dist) else round(self.dist, 6)}
        if self.ph is not None:
            body["ph"] = self.ph
        if self.probs is not None:
            body["p"] = self.probs
        if self.reach is not None:
            body["r"] = self.reach
        if self.mode == "rendezvous":
            body["rv"] = self.rv
            self.target, self.aligned = None, False
            up = [(b["d"] + nb[j][0], j) for j, b in fresh.items() if b.get("d") is not None]
            parent = min(up)[1] if up else None
            self.v = rules.lj_velocity(rules.gather_pulls(nb, parent, self.rv), self.rv, self.v_max, self.epsilon)
            return body
        if self.mode == "flocking":
            body["fl"] = 1
            self.target, self.aligned = None, False
            self.v = rules.flocking_velocity(self._flock_inputs(nb, fresh), self.v_max)
            return body
        self._secs(ctx, nb, fresh)
        if self.target is not None:
            body["T"], body["al"] = self.target, self.aligned
        return body

    def _flock_inputs(self, nb, fresh) -> list:
        out = []
        for j, (d, b) in nb.items():
            v = fresh.get(j, {}).get("v", [0.0, 0.0])
            seen = self.seen_by.get(j)
            if seen is None:
                out.append((d, b, (0.0, 0.0)))
                continue
            rot = rules.rotation(seen[2], seen[1])
            c, s = math.cos(rot), math.sin(rot)
            out.append((d, b, (c * v[0] - s * v[1], s * v[0] + c * v[1])))
        return out

    def _secs(self, ctx, nb, fresh) -> None:
        """Pick the informer, compose ∠T_i, spiral or follow Lennard-Jones."""
        arm = self.arm
        sees_master = self.master in fresh and arm is not None and arm < len(fresh[self.master]["T"])
        cands = [(j, b["d"]) for j, b in fresh.items()
                 if j != self.master and b["a"] == arm and b.get("T") is not None and b.get("d") is not None]
        informer = rules.pick_informer(sees_master, cands, self.dist) if arm is not None else None
        j = self.master if informer == -1 else informer
        seen = self.seen_by.get(j) if j is not None else None
        if j is None or seen is None or ctx.tick - seen[0] > STALE:
            self.informer, self.target, self.aligned = None, None, False
            self.v = rules.lj_velocity(list(nb.values()), self.delta_close, self.v_max, self.epsilon)
            return
        sent_t, b = self.info[j]
        t_j = b["T"][arm] if j == self.master else b["T"]
        _, m_ji, o_ij = seen
        self.informer = j
        self.target = rules.compose_target(t_j, o_ij, m_ji)
        offset = rules.diff(m_ji, t_j)
        was = self.aligned
        # hysteresis: aligned within align_tol, lost beyond align_release times that
        self.aligned = rules.still_aligned(offset, self.align_tol, was, self.align_release)
        if not self.aligned and self.strip is not None and j in nb:
            self.aligned = rules.in_strip(offset, nb[j][0], self.strip)
        if self.walk_back:
            self.walking = rules.walk_back(self.aligned, was, self.walking, sees_master)
        if self.aligned:
            if self.first_aligned is None:
                self.first_aligned = ctx.tick
            self.v = rules.lj_velocity(list(nb.values()), self.delta, self.v_max, self.epsilon)
            if self.reach is not None and 0 <= arm < len(self.reach):  # opt-in: hold the task, not pass it
                up = [(b["d"] + nb[k][0], k) for k, b in fresh.items() if b.get("d") is not None and k in nb]
                parent = nb[min(up)[1]] if up else None
                self.v = rules.hold_velocity(self.dist, float(self.reach[arm]), HOLD_BAND, parent, self.v,
                                             self.v_max)
        elif self.walking:  # back towards the master along the swarm: to the parent
            self.realigned += bool(was)
            up = [(b["d"] + nb[k][0], k) for k, b in fresh.items() if b.get("d") is not None and k in nb]
            parent = min(up)[1] if up else j
            self.v = rules.lj_velocity(rules.gather_pulls(nb, parent, self.delta_close), self.delta_close,
                                       self.v_max, self.epsilon)
        else:
            self.realigned += bool(was)
            d_now, o_now = nb[j]
            v = rules.spiral_velocity(o_now, d_now, offset, self.radius, self.v_max, far=self._far())
            close = [nb[k] for k in nb if nb[k][0] < CLOSE]
            if close:  # keep the bodies apart while circling: the short-range part of Lennard-Jones
                w = rules.lj_velocity(close, self.delta, self.v_max, self.epsilon)
                v = rules.clip((v[0] + w[0], v[1] + w[1]), self.v_max)
            self.v = v

    def report(self) -> dict:
        return {"arm": self.arm, "target": self.target, "aligned": self.aligned, "informer": self.informer,
                "dist": None if math.isinf(self.dist) else self.dist, "mode": self.mode, "odo": self.odo,
                "at": self.at, "first_aligned": self.first_aligned, "lost_alignment": self.realigned,
                "refused": dict(self.refused), "master": self.master, "ph": self.ph, "stages": self.stages}

    @classmethod
    def metrics(cls, reports) -> dict:
        return {"aligned": sum(bool(r.get("aligned")) for r in reports.values()),
                "refused": sum(sum(r.get("refused", {}).values()) for r in reports.values()),
                "arms": sorted({r["arm"] for r in reports.values() if r.get("arm") is not None and r["arm"] >= 0})}
