"""Leader-follower navigation without collisions (Sano et al., seed 004): the robot side. Imports no oracle.

A sensing-only protocol: no frame is sent. Each follower uses only the vectors it senses to the closest
point of the other bodies within its sensing range ρ_i (Eqs. 4–5: the group's ``sensing_to = "surface"``),
told apart by their ids (the paper's AR markers). Global sensing: the vector is the sensed point minus the
follower's own position; local sensing: the body-frame vector turned by the odometry heading into the
robot's own frame, where its commands are given.

* Leader (``Leader``): moves along ``waypoints`` at speed ``U`` ≤ min U_i (Assumption 2, Eq. 8), from
  ``start`` seconds on; it senses nothing.
* Follower (``Follower``), rules.py for every equation:
  - Case I (Eq. 10): at rest until it has a target. Target determination (§3.2): the first *moving* agent
    (its sensed point moved more than ``move_eps`` since first seen; the follower itself is still, so that
    is the other's motion) whose distance r crosses ρ′ or ρ″ between two samples; ties: the lowest id.
  - Tracking mode, Case II (a)–(e) (Eqs. 9, 11–17).
  - Switching-target mode, Case III (Eqs. 18–19): when the nearest non-target agent k is within ρ″
    (d_i ≤ ρ″), k becomes the target; for T = h/(ζU) the input blends from the frozen u^j to u_ir e_ir
    toward k; then σ, θ^des, n^r, n^l reset and tracking resumes (t_i := now). An agent entering S″ during
    a switch starts no second switch (Assumption 3 says it does not happen; the oracle reports it).
  - σ (§3.4, Eqs. 20–24): events R/L from the nearest non-target agent (rules.side), θ^des by
    rules.theta_next, σ toward tan θ^des at rates α, β (rules.sigma_step).
  - ``method = "prior"`` ([17]): the same without switching-target mode (Case II whatever d_i).
  A target out of sensing range (possible only in discrete time or with noise): the follower stops and
  waits for it to reappear (status ``mode = "lost"``).

Status fields: ``target`` (id, −1 before one is chosen), ``mode`` (``wait``, ``track``, ``switch``,
``lost``) and ``sigma`` (3 decimals). The report carries the switches and the largest commanded speed.
"""

from __future__ import annotations

import math

from protocols.leader_follower import rules
from swarmactors import Behavior

NAME = "leader_follower"
METHODS = ("proposed", "prior")


def _num(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


class Leader(Behavior):
    """The leader: waypoints at speed U (Eq. 8), from ``start`` seconds on; then it stops."""

    name = NAME
    frames = ("global",)

    def __init__(self, waypoints: list, U: float = 0.2, start: float = 0.0, follower_U_min: float | None = None):
        self.waypoints = [tuple(float(c) for c in w) for w in waypoints]
        self.U, self.start, self.follower_U_min = float(U), float(start), follower_U_min
        self.next = 0
        self.travelled = 0.0

    @staticmethod
    def validate(params: dict, group: dict) -> str | None:
        wps = params.get("waypoints")
        if not isinstance(wps, list) or not wps or not all(
                isinstance(w, list) and len(w) == 2 and all(_num(c) for c in w) for w in wps):
            return "waypoints must be a non-empty list of [x, y]"
        U = params.get("U", 0.2)
        if not _num(U) or U <= 0:
            return f"U = {U!r} must be a number > 0"
        if group.get("speed") is not None and U > group["speed"]:
            return f"U = {U} must be <= the group's speed {group['speed']}"
        fmin = params.get("follower_U_min")
        if fmin is not None and (not _num(fmin) or U > fmin):
            return f"U = {U} must be <= follower_U_min = {fmin} (Assumption 2, Eq. 8: U_leader <= min U_i)"
        start = params.get("start", 0.0)
        if not _num(start) or start < 0:
            return f"start = {start!r} must be a number >= 0"
        return None

    def on_start(self, ctx) -> None:
        ctx.set_status(role="leader")

    def on_tick(self, ctx, sensed) -> None:
        t = ctx.tick * ctx.dt
        if t < self.start - 1e-9 or self.next >= len(self.waypoints):
            ctx.move([0.0, 0.0])
            return
        x, y = float(ctx.position[0]), float(ctx.position[1])
        step = self.U * ctx.dt
        while self.next < len(self.waypoints):
            wx, wy = self.waypoints[self.next]
            d = math.hypot(wx - x, wy - y)
            if d > 1e-9:
                break
            self.next += 1
        if self.next >= len(self.waypoints):
            ctx.move([0.0, 0.0])
            return
        v = self.U if d >= step else d / ctx.dt
        self.travelled += v * ctx.dt
        ctx.move([v * (wx - x) / d, v * (wy - y) / d])
        if d <= step:
            self.next += 1

    def report(self) -> dict:
        return {"role": "leader", "U": self.U, "waypoints_reached": self.next, "travelled": round(self.travelled, 4)}


class Follower(Behavior):
    """A follower: target determination, tracking mode, switching-target mode, σ rule (Eqs. 9–24)."""

    name = NAME
    frames = ("global", "local")  # only relative vectors are used; local: in the body frame, as ctx.move
    plot_field = "target"

    def __init__(self, rho1: float, rho2: float, rho3: float, U: float, alpha: float = -1.0, beta: float = 1.0,
                 zeta: float = rules.ZETA, method: str = "proposed", move_eps: float = 0.01):
        self.rho1, self.rho2, self.rho3, self.U = float(rho1), float(rho2), float(rho3), float(U)
        self.alpha, self.beta, self.zeta, self.method, self.move_eps = alpha, beta, zeta, method, move_eps
        self.p: rules.Params | None = None
        self.target: int | None = None
        self.mode = "wait"
        self.Up = 0.0
        self.sigma = self.theta = 0.0
        self.events = 0
        self.first: dict[int, tuple[float, float]] = {}  # first sensed vector of each agent (still follower)
        self.last_r: dict[int, float] = {}
        self.prev_near: tuple[int, int] | None = None  # (id, side) of the last nearest non-target agent
        self.u = (0.0, 0.0)
        self.uj = (0.0, 0.0)
        self.switch_tick = 0
        self.switches: list[list] = []  # [tick, old target, new target]
        self.chosen_at: int | None = None
        self.max_speed = 0.0
        self.lost_ticks = 0

    @staticmethod
    def validate(params: dict, group: dict) -> str | None:
        for key in ("rho1", "rho2", "rho3", "U", "alpha", "beta", "zeta", "move_eps"):
            if key in params and not _num(params[key]):
                return f"{key} = {params[key]!r} must be a number"
        if params.get("method", "proposed") not in METHODS:
            return f"method = {params.get('method')!r} must be one of {list(METHODS)}"
        if group.get("sensing_to") != "surface":
            return 'the group must set sensing_to = "surface" (Eqs. 4-5: vectors to the closest point of a body)'
        problem = rules.order_problem(group["sensing"], params["rho1"], params["rho2"], params["rho3"],
                                      group.get("body_radius") or 0.0)
        if problem:
            return problem
        if params["U"] <= 0:
            return f"U = {params['U']} must be > 0"
        if group.get("speed") is not None and params["U"] > group["speed"]:
            return f"U = {params['U']} must be <= the group's speed {group['speed']}"
        if not params.get("alpha", -1.0) < 0 < params.get("beta", 1.0):
            return "alpha must be < 0 < beta (Eq. 20)"
        if params.get("zeta", rules.ZETA) <= 0 or 2 * math.pi * (1 - math.exp(-1 / params.get("zeta", rules.ZETA))) \
                / params.get("zeta", rules.ZETA) > 1:
            return "zeta must satisfy 2*pi*(1 - exp(-1/zeta))/zeta <= 1 (Eq. 18)"
        return None

    def on_start(self, ctx) -> None:
        self.p = rules.Params(ctx.sensing, self.rho1, self.rho2, self.rho3, 0.0, self.U, self.alpha, self.beta,
                              self.zeta)
        ctx.set_status(role="follower", target=-1, mode="wait", sigma=0.0)

    # ------------------------------------------------------------------ per tick
    def on_tick(self, ctx, sensed) -> None:
        if ctx.sensing_frame == "local":  # body-frame vectors turned into the robot's own frame (ctx.move's)
            c, s_ = math.cos(float(ctx.pose[-1])), math.sin(float(ctx.pose[-1]))
            vec = {s.id: (c * float(s.pos[0]) - s_ * float(s.pos[1]), s_ * float(s.pos[0]) + c * float(s.pos[1]))
                   for s in sensed if s.id != ctx.id}
        else:
            me = ctx.position
            vec = {s.id: (float(s.pos[0] - me[0]), float(s.pos[1] - me[1])) for s in sensed if s.id != ctx.id}
        dist = {i: math.hypot(*v) for i, v in vec.items()}
        if self.target is None:
            self._determine(ctx, vec, dist)
        if self.target is not None:
            self._control(ctx, vec, dist)
        self.last_r = dist
        speed = math.hypot(*self.u)
        self.max_speed = max(self.max_speed, speed)
        ctx.move(list(self.u))
        ctx.set_status(target=-1 if self.target is None else self.target, mode=self.mode,
                       sigma=round(self.sigma, 3))

    def _determine(self, ctx, vec, dist) -> None:
        """§3.2: the first moving agent whose closest point crosses ∂S′ or ∂S″; ties: the lowest id."""
        for i, v in vec.items():
            self.first.setdefault(i, v)
        for i in sorted(vec):
            f = self.first[i]
            moving = math.hypot(vec[i][0] - f[0], vec[i][1] - f[1]) > self.move_eps
            if moving and i in self.last_r and rules.crossed(self.last_r[i], dist[i], self.p):
                self.target, self.chosen_at, self.mode = i, ctx.tick, "track"
                self._reset_sigma(vec, dist)
                return

    def _nearest_other(self, vec, dist) -> int | None:
        others = [i for i in dist if i != self.target]
        return min(others, key=lambda i: (dist[i], i)) if others else None

    def _reset_sigma(self, vec, dist) -> None:
        """T = t_i: σ = σ^des = n^r = n^l = 0, then R^1/L^1 from the side of the nearest other agent."""
        self.sigma = self.theta = 0.0
        self.events = 0
        k = self._nearest_other(vec, dist)
        self.prev_near = None
        if k is not None:
            s = rules.side(vec[self.target], vec[k])
            if s:
                self.theta = rules.theta_next(self.theta, self.events, s)
                self.events += 1
            self.prev_near = (k, s)

    def _sigma_events(self, vec, dist, k) -> None:
        """R^2/L^2: the nearest other agent came from outside S_i; R^3/L^3: it changed from one side's agent."""
        if k is None:
            self.prev_near = None
            return
        s = rules.side(vec[self.target], vec[k])
        new_in_range = k not in self.last_r
        changed = self.prev_near is not None and self.prev_near[0] != k and self.prev_near[1] == -s
        if s and (new_in_range or changed):
            self.theta = rules.theta_next(self.theta, self.events, s)
            self.events += 1
        self.prev_near = (k, s)

    def _control(self, ctx, vec, dist) -> None:
        p = self.p
        if self.target not in vec:
            self.mode, self.u = "lost", (0.0, 0.0)
            self.lost_ticks += 1
            return
        if self.mode == "lost":
            self.mode = "track"
        k = self._nearest_other(vec, dist)
        if self.mode == "switch":
            elapsed = (ctx.tick - self.switch_tick) * ctx.dt
            T = rules.switch_period(p)
            if elapsed >= T - 1e-9:
                self.mode = "track"
                self._reset_sigma(vec, dist)
            else:
                ur = rules.radial(p, dist[self.target])
                self.Up = max(self.Up, abs(ur))
                self.u = rules.blend(self.uj, rules.compose(vec[self.target], ur, 0.0), elapsed / T)
                return
        if self.method == "proposed" and k is not None and dist[k] <= p.rho2:
            self.switches.append([ctx.tick, self.target, k])
            self.mode, self.target, self.switch_tick, self.uj = "switch", k, ctx.tick, self.u
            ur = rules.radial(p, dist[k])
            self.Up = max(self.Up, abs(ur))
            self.u = self.uj  # δ = 0 at t_start
            return
        self._sigma_events(vec, dist, k)
        self.sigma = rules.sigma_step(self.sigma, math.tan(self.theta), p.alpha, p.beta, ctx.dt)
        ur, ut, self.Up = rules.tracking(p, dist[self.target], self.sigma, self.Up)
        self.u = rules.compose(vec[self.target], ur, ut)

    def report(self) -> dict:
        return {"role": "follower", "method": self.method, "target": self.target, "chosen_at": self.chosen_at,
                "switches": self.switches, "max_speed": round(self.max_speed, 6), "U": self.U,
                "lost_ticks": self.lost_ticks}

    @classmethod
    def metrics(cls, reports: dict[int, dict]) -> dict:
        fol = [r for r in reports.values() if r.get("role") == "follower"]
        return {"switches": sum(len(r["switches"]) for r in fol),
                "undetermined": sum(r["target"] is None for r in fol),
                "lost_ticks": sum(r["lost_ticks"] for r in fol)}


Leader.metrics = Follower.metrics  # both report under leader_follower: the same run-level metrics
