"""Pure rules of the Robot Navigation Controller (Panerati et al., ICRA 2018, §III-B): no I/O, no oracle.

Angles are radians, counter-clockwise, in a robot's own frame; distances in metres except the Lennard-Jones
parameters, which are the paper's centimetres (δ ∈ {90, 120, 240, 275} cm, ε = 10⁶). docs/protocols/secs.md
gives every reading of a garbled formula and every value the paper leaves unstated.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

TWO_PI = 2.0 * math.pi


def wrap(a: float) -> float:
    """``a`` mod 2π, in [0, 2π)."""
    r = math.fmod(a, TWO_PI)
    if r < 0:
        r += TWO_PI
    return 0.0 if r >= TWO_PI else r


def diff(a: float, b: float) -> float:
    """The signed difference a − b, in (−π, π]."""
    d = wrap(a - b)
    return d - TWO_PI if d > math.pi else d


def compose_target(t_j: float, o_ij: float, m_ji: float) -> float:
    """§III-B-5a, corrected: ∠T_i = ∠T_j + ∠O_ij − ∠M_ji + π (mod 2π).

    j sees i at ∠M_ji in j's frame; i sees j at ∠O_ij in i's frame. The two bearings are opposite directions
    of the same segment, so j's frame is turned from i's by ρ = ∠O_ij − ∠M_ji + π, and any direction of j's
    frame (here ∠T_j) is ∠T_j + ρ in i's. The printed ∠M_ji − ∠O_ij + ∠T_j has the sign of ρ reversed and
    no π; the authors' Buzz code computes the form used here.
    """
    return wrap(t_j + o_ij - m_ji + math.pi)


def rotation(o_ij: float, m_ji: float) -> float:
    """The angle that turns a direction of j's frame into i's: ∠O_ij − ∠M_ji + π."""
    return wrap(o_ij - m_ji + math.pi)


def angle_ok(a) -> bool:
    """An angle on the wire: a finite real number in [0, 2π)."""
    return isinstance(a, (int, float)) and not isinstance(a, bool) and math.isfinite(a) and 0.0 <= a < TWO_PI


# --------------------------------------------------------------------------------------------- Lennard-Jones
def lj_repulsion(d_cm: float, delta: float, epsilon: float = 1e6) -> float:
    """Eq. 2 as read here: F(d) = (ε/d)·((δ/d)⁴ − (δ/d)²), positive = repulsive, zero at d = δ.

    The exponents 4 and 2 are §IV's; this is the magnitude of the authors' Buzz ``lj_magnitude`` with its sign
    turned so that positive pushes away.
    """
    r = delta / d_cm
    return (epsilon / d_cm) * (r**4 - r**2)


def clip(v: Sequence[float], vmax: float) -> tuple[float, float]:
    """``v`` scaled down to length ``vmax`` when longer (direction kept)."""
    n = math.hypot(v[0], v[1])
    if n > vmax and n > 0:
        return v[0] * vmax / n, v[1] * vmax / n
    return float(v[0]), float(v[1])


def lj_velocity(neighbours: Sequence[tuple[float, float]], delta: float, vmax: float,
                epsilon: float = 1e6) -> tuple[float, float]:
    """The Lennard-Jones velocity of a robot from its neighbours' (distance m, bearing) in its own frame.

    Fixed normalisation, the same in every experiment: the mean over the neighbours of F(d)·(away from j),
    read as cm/s (the unit of Buzz's ``goto``) and so divided by 100 into m/s, then clipped to ``vmax``
    with its direction kept (the wheels' cap). With ε = 10⁶ the slope at δ = 240 cm is 2ε/δ² ≈ 35 (cm/s)/cm:
    a robot 0.5 cm off its minimum already asks for the full 15 cm/s, so the clip is what shapes the motion.
    """
    if not neighbours:
        return 0.0, 0.0
    sx = sy = 0.0
    for d, b in neighbours:
        f = lj_repulsion(max(d, 1e-3) * 100.0, delta, epsilon)
        sx -= f * math.cos(b)
        sy -= f * math.sin(b)
    n = len(neighbours)
    return clip((sx / n / 100.0, sy / n / 100.0), vmax)


# --------------------------------------------------------------------------------------------------- flocking
def flocking_velocity(neighbours: Sequence[tuple[float, float, tuple[float, float]]], vmax: float, *,
                      e: float = 0.3, f: float = 1.0, g: float = 1.5, q: float = 0.6) -> tuple[float, float]:
    """Eq. 3 as read here: v_i = mean_j [ e·x_ij + f·v_j − g·𝟙(d_ij < q)·(q − d_ij)·x̂_ij ], clipped to vmax.

    ``neighbours``: (distance, bearing, v_j) with v_j already turned into this robot's frame. x_ij is j's
    position relative to i (there is no common frame for absolute ones); the separation is a spring that
    pushes i away from j inside q (the printed d_ij·x_ij grows with distance and could not separate).
    Coefficients e (1/s), f, g (1/s) and q (m) are unstated in the paper: the values chosen here.
    """
    if not neighbours:
        return 0.0, 0.0
    sx = sy = 0.0
    for d, b, (vx, vy) in neighbours:
        cx, cy = math.cos(b), math.sin(b)
        sx += e * d * cx + f * vx
        sy += e * d * cy + f * vy
        if d < q:
            sx -= g * (q - d) * cx
            sy -= g * (q - d) * cy
    n = len(neighbours)
    return clip((sx / n, sy / n), vmax)


# ------------------------------------------------------------------------------------------------------- SECS
def spiral_velocity(o_ij: float, d_ij: float, offset: float, radius: float, vmax: float, *,
                    far: float, near: float = 0.25) -> tuple[float, float]:
    """The alignment manoeuvre (§III-B-5b): circle the informer j towards the arm, at a randomised radius.

    ``o_ij``: bearing of j in i's frame; ``offset`` = ∠M_ji − ∠T_j (where j sees i, less the arm's direction
    in j's frame). Beyond ``far`` the robot approaches j, within ``near`` it backs off (the Buzz code's
    thresholds); otherwise it moves tangentially, counter-clockwise round j when the offset is negative
    (so that ∠M_ji grows towards ∠T_j), with a radial term that keeps it at least ``radius``
    from j (a robot pushed farther out stays there, as the Buzz code's purely tangential turn does).
    """
    if d_ij > far:
        return vmax * math.cos(o_ij), vmax * math.sin(o_ij)
    if d_ij < near:
        return -vmax * math.cos(o_ij), -vmax * math.sin(o_ij)
    tangent = o_ij - math.pi / 2 if offset < 0 else o_ij + math.pi / 2
    radial = min(0.0, (d_ij - radius) / radius)  # < 0: inside its radius, move away from j (never pulled in)
    vx = math.cos(tangent) + radial * math.cos(o_ij)
    vy = math.sin(tangent) + radial * math.sin(o_ij)
    n = math.hypot(vx, vy)
    return vmax * vx / n, vmax * vy / n


def arm_probabilities(distances: Sequence[float]) -> list[float]:
    """Probability that a backbone robot joins each task's arm: proportional to the task's distance.

    The distance is from the swarm centre (the master): a farther task needs a longer arm, and an arm's reach
    grows with its robots (Table I).
    """
    total = float(sum(distances))
    if not distances:
        return []
    if total <= 0:
        return [1.0 / len(distances)] * len(distances)
    return [d / total for d in distances]


def draw_arm(probabilities: Sequence[float], u: float) -> int:
    """The arm whose cumulative probability first exceeds ``u`` ∈ [0, 1)."""
    acc = 0.0
    for k, p in enumerate(probabilities):
        acc += p
        if u < acc:
            return k
    return len(probabilities) - 1


def pick_informer(sees_master: bool, candidates: Sequence[tuple[int, float]], own: float) -> int | None:
    """Whom to align with: -1 (the master) when in sight, else a neighbour of the same arm.

    Among the (id, distance to the centre) candidates nearer the centre than this robot, the farthest from it
    (the Buzz code's gradient rule); None when there is none.
    """
    if sees_master:
        return -1
    best, best_d = None, -1.0
    for rid, d in sorted(candidates):
        if d < own and d > best_d:
            best, best_d = rid, d
    return best


def bmu_next(stage: str, slot: int, elapsed: float, *, last: bool, duration: float, waited: float | None,
             gathered: bool, settle_max: float) -> tuple[str, int]:
    """The BMU's next (stage, slot) after one tick (seed 003 §III-C: flock → erupt → rendez-vous, per slot).

    ``stage`` is "flocking" (to the slot's deployment point), "secs" (its prominences erupt) or "rendezvous";
    ``elapsed`` the seconds spent in it, ``waited`` the seconds since the master reached the deployment point
    (None while it is not there), ``gathered`` whether every robot of the swarm is within the master's range
    (the "closed formation"). Flocking ends at the point once the swarm is gathered (or after ``settle_max`` s
    there); the eruption after the slot's ``duration``; the rendez-vous once the swarm is gathered again (or
    after ``settle_max`` s), then the next slot's flocking. The last rendez-vous never ends.
    """
    if stage == "flocking":
        if waited is not None and (gathered or waited >= settle_max):
            return "secs", slot
    elif stage == "secs":
        if elapsed >= duration:
            return "rendezvous", slot
    elif stage == "rendezvous":
        if not last and (gathered or elapsed >= settle_max):
            return "flocking", slot + 1
    else:
        raise ValueError(f"unknown stage {stage!r}")
    return stage, slot


def gather_pulls(neighbours: dict[int, tuple[float, float]], parent: int | None,
                 delta_rv: float) -> list[tuple[float, float]]:
    """The (distance, bearing) pairs a robot feels during a rendez-vous (§III-B-4 with δ_rv, as read here).

    Its parent (the neighbour through which it is nearest the master along the swarm) and the robots closer
    than δ_rv, which only repel. The printed rule (Lennard-Jones of every neighbour) breaks stretched arms: far
    from δ the attraction falls as d⁻³, so a robot of an arm follows its nearer neighbour and the link to
    the farther one stretches past the range. Moving towards the parent cannot lengthen a link to a child:
    the child closes in at full speed while the parent moves at most as fast.
    """
    out = [nb for j, nb in sorted(neighbours.items()) if nb[0] * 100.0 < delta_rv and j != parent]
    if parent is not None and parent in neighbours:
        out.insert(0, neighbours[parent])
    return out


# ------------------------------------------------------------------- opt-in variants (all OFF by default)
def still_aligned(offset: float, tol: float, was: bool, release: float = 2.0) -> bool:
    """The alignment test of §III-B-5b ("when a robot finally aligns ... if a robot loses its alignment").

    Aligned when |offset| < ``tol``; a robot already aligned loses it only beyond ``release``·``tol``
    (hysteresis). ``release`` = 2 is the controller's default; the Buzz code uses one threshold both ways
    (``release`` = 1). The paper states neither.
    """
    return abs(offset) < tol * (release if was else 1.0)


def unicycle_step(heading: float, v: Sequence[float], turn_rate: float, dt: float) -> tuple[float, tuple[float, float]]:
    """A differential-drive body (§IV-A: ARGoS foot-bots) following a commanded velocity ``v``.

    The body turns its ``heading`` towards v's direction by at most ``turn_rate``·``dt`` rad this tick, then
    drives straight ahead at |v|·max(0, cos(remaining error)): it cannot move sideways, and moves only once
    roughly facing v. Returns (new heading, the velocity actually driven). A zero ``v`` keeps the heading.
    """
    speed = math.hypot(v[0], v[1])
    if speed == 0.0:
        return heading, (0.0, 0.0)
    err = diff(math.atan2(v[1], v[0]), heading)
    step = max(-turn_rate * dt, min(turn_rate * dt, err))
    h = wrap(heading + step)
    ahead = speed * max(0.0, math.cos(err - step))
    return h, (ahead * math.cos(h), ahead * math.sin(h))


def walk_back(aligned: bool, was: bool, walking: bool, sees_master: bool) -> bool:
    """Whether an unaligned robot walks back to the master (§III-B-5b, "its control goes back").

    A robot that loses its alignment out of the master's sight (``was`` and not ``aligned``), or is already
    walking back, walks back towards the master along the swarm (to its parent) until it sees the master;
    there it spirals round the master again and may re-enter the arm through the master's cone. Without it
    (the default) it spirals round its informer wherever it is.
    """
    if aligned or sees_master:
        return False
    return walking or was


def in_strip(offset: float, distance: float, half_width: float) -> bool:
    """An alignment cone of constant width (§III-B-5b's "aligns with the prominence", read as a strip).

    With a fixed angular tolerance the cone is 2·``distance``·tan(tol) wide: a few cm next to the informer,
    so a neighbour's Lennard-Jones push moves a robot out of it. Here a robot also counts as aligned when it
    is ahead of its informer (|offset| < π/2) and within ``half_width`` m of the informer's arm line.
    """
    return abs(offset) < math.pi / 2 and abs(distance * math.sin(offset)) <= half_width


def hold_velocity(dist: float, reach: float, band: float, parent: tuple[float, float] | None,
                  v_lj: Sequence[float], vmax: float) -> tuple[float, float]:
    """An aligned robot of an arm whose task lies ``reach`` m from the master (opt-in ``hold_tasks``, §III-C).

    §III-C has the eruption last the task's duration: the prominence must hold the task, but SECS
    (§III-B-5) only pushes robots along a direction, so the arm's tip passes the task and goes on. Here the
    master also floods each task's distance, and a robot compares it with its own distance to the master
    along the swarm (``dist``): short of ``reach`` − ``band`` it follows Lennard-Jones (``v_lj``) as before;
    within ``band`` of it, it stops (holds the task); beyond ``reach`` + ``band`` it walks back towards its
    ``parent`` (distance, bearing) at the overshoot's speed, capped at ``vmax``.
    """
    if dist < reach - band:
        return v_lj[0], v_lj[1]
    if dist <= reach + band or parent is None:
        return 0.0, 0.0
    d, b = parent
    return clip(((dist - reach) * math.cos(b), (dist - reach) * math.sin(b)), vmax) if d > 0 else (0.0, 0.0)
