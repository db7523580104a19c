"""Leader-follower navigation without collisions (Sano et al., seed 004): the pure rules, Eqs. 9–24.

No I/O, no numpy: every function maps numbers to numbers, so each rule is unit-tested on its own
(tests/unit/test_leader_follower_rules.py). Names: ``rho`` is ρ_i (the group's sensing range), ``rho1``
ρ′_i, ``rho2`` ρ″_i, ``rho3`` ρ‴_i, ``size`` ρ_i^size (the group's body radius), ``U`` the follower's
maximum speed and ``Up`` U′_i(t) = max |u_ir| so far (Eq. 16). Readings where the extracted text is
garbled are written down in docs/protocols/leader_follower.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

ZETA = 2.253  # ζ of Eq. 18: 2π(1 − e^(−1/ζ))/ζ ≤ 1


@dataclass(frozen=True)
class Params:
    """One follower's constants (Table 1): ρ, ρ′, ρ″, ρ‴, size, U, α, β."""

    rho: float
    rho1: float
    rho2: float
    rho3: float
    size: float
    U: float
    alpha: float = -1.0
    beta: float = 1.0
    zeta: float = ZETA


def order_problem(rho: float, rho1: float, rho2: float, rho3: float, size: float) -> str | None:
    """ρ_size ≤ ρ‴ < ρ″ < ρ′ < ρ (§2.2, Fig. 2), or the first key that breaks it (None: holds)."""
    if not rho3 >= size:
        return f"rho3 = {rho3} must be >= the body radius {size} (rho_size <= rho''')"
    if not rho2 > rho3:
        return f"rho2 = {rho2} must be > rho3 = {rho3} (rho''' < rho'')"
    if not rho1 > rho2:
        return f"rho1 = {rho1} must be > rho2 = {rho2} (rho'' < rho')"
    if not rho > rho1:
        return f"rho1 = {rho1} must be < the sensing range {rho} (rho' < rho)"
    return None


def rho_e_minus(p: Params, Up: float) -> float:
    """ρ^{e−}(t) = ρ″ − (U′/U)(ρ″ − ρ‴) (Eq. 17)."""
    return p.rho2 - Up / p.U * (p.rho2 - p.rho3)


def rho_c(p: Params, Up: float) -> float:
    """ρ^c(t) = ρ′ + (U′/2U)(ρ − ρ′) (Eq. 17)."""
    return p.rho1 + Up / (2 * p.U) * (p.rho - p.rho1)


def rho_e_plus(p: Params, Up: float) -> float:
    """ρ^{e+}(t) = ρ′ + (U′/U)(ρ − ρ′) (Eq. 17)."""
    return p.rho1 + Up / p.U * (p.rho - p.rho1)


def radial(p: Params, r: float) -> float:
    """u_ir of Case II (Eqs. 11, 14, 15): away from the target below ρ″, toward it beyond ρ′, 0 between.

    Outside (ρ‴, ρ) — possible only in discrete time or with noise — the value is clipped to ±U, so that
    ‖u_i‖ ≤ U_i still holds (a choice: the paper's continuous-time proof never leaves that band).
    """
    if r <= p.rho2:
        u = p.U * (r - p.rho2) / (p.rho2 - p.rho3)
    elif r < p.rho1:
        u = 0.0
    else:
        u = p.U * (r - p.rho1) / (p.rho - p.rho1)
    return max(-p.U, min(p.U, u))


def case_of(p: Params, r: float, Up: float) -> str:
    """Which of Case II (a)–(e) applies at distance r (Eqs. 11–15; (a) below ρ^{e−} too, (e) above ρ^{e+})."""
    if r <= p.rho2:
        return "a"
    if r <= (p.rho2 + p.rho1) / 2:
        return "b"
    if r < p.rho1:
        return "c"
    if r <= rho_c(p, Up):
        return "d"
    return "e"


def tracking(p: Params, r: float, sigma: float, Up: float) -> tuple[float, float, float]:
    """Tracking mode, Case II (Eqs. 11–16): (u_ir, u_iθ, new U′) at distance r to the target's closest point.

    U′ is updated first (Eq. 16 takes the maximum over τ ≤ t, now included), then the case is chosen.
    """
    ur = radial(p, r)
    Up = max(Up, abs(ur))
    case = case_of(p, r, Up)
    if case == "a":
        ut = 0.0
    elif case == "b":
        ut = 2 * sigma * Up / (p.rho1 - p.rho2) * (r - p.rho2)
    elif case == "c":
        ut = 2 * sigma * Up / (p.rho1 - p.rho2) * (p.rho1 - r)
    elif case == "d":
        ut = sigma * ur
    else:
        ut = sigma * (Up - ur)
    return ur, ut, Up


def compose(x: tuple[float, float], ur: float, ut: float) -> tuple[float, float]:
    """u_i = u_ir e_ir + u_iθ e_iθ (Eq. 9): e_ir = x / |x|, e_iθ = e_ir turned by +π/2."""
    r = math.hypot(x[0], x[1])
    if r == 0.0:
        return 0.0, 0.0
    ex, ey = x[0] / r, x[1] / r
    return ur * ex - ut * ey, ur * ey + ut * ex


def switch_period(p: Params) -> float:
    """T_i = h_i / (ζ U_i), h_i = min(ρ − ρ′, ρ″ − ρ‴) (Eq. 18), seconds."""
    return min(p.rho - p.rho1, p.rho2 - p.rho3) / (p.zeta * p.U)


def blend(uj: tuple[float, float], uk: tuple[float, float], delta: float) -> tuple[float, float]:
    """Switching-target mode (Eq. 18): u_i = u^j + δ (u^k − u^j), δ = (t − t_start)/T clipped to [0, 1]."""
    d = max(0.0, min(1.0, delta))
    return uj[0] + d * (uk[0] - uj[0]), uj[1] + d * (uk[1] - uj[1])


def side(x_target: tuple[float, float], x_other: tuple[float, float]) -> int:
    """+1 when the other agent is in S^r, −1 in S^l, 0 on the target's line (Eq. 21).

    φ is read as the angle from x_k to x_j (so φ > 0 when k lies clockwise of the target, on the right as i
    faces its target); σ > 0 then moves i counter-clockwise, away from k.
    """
    cross = x_other[0] * x_target[1] - x_other[1] * x_target[0]
    return 1 if cross > 0 else -1 if cross < 0 else 0


def theta_next(theta: float, events: int, event: int) -> float:
    """θ^des after one more R (+1) or L (−1) event, ``events`` = n^r + n^l before it (Eqs. 22–24).

    The first event sets ±π/4 (Eq. 22); every later one halves toward the other side (Eqs. 23–24), read as
    applying from the second event on (the extracted text leaves n^r + n^l = 2 undefined otherwise).
    """
    q = math.pi / 4
    if events == 0 or theta == 0.0:
        return q * event
    if event > 0:
        return -theta / 2 if theta < 0 else (q + theta) / 2
    return (-q + theta) / 2 if theta < 0 else -theta / 2


def sigma_step(sigma: float, target: float, alpha: float, beta: float, dt: float) -> float:
    """σ moves toward σ^des at rate β (up) or α (down) per second, not past it, kept in [−1, 1] (Eq. 20)."""
    if sigma < target:
        sigma = min(target, sigma + beta * dt)
    elif sigma > target:
        sigma = max(target, sigma + alpha * dt)
    return max(-1.0, min(1.0, sigma))


def crossed(r_before: float, r_now: float, p: Params) -> bool:
    """§3.2: r − ρ′ or r − ρ″ changed sign (or reached 0) between two samples."""
    return any((r_before - c) * (r_now - c) <= 0 and r_before != r_now for c in (p.rho1, p.rho2))
