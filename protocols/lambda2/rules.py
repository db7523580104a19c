"""Pure update rules of the three λ2 estimators (Panerati et al., seed 003, Sec. II-B). Robot side, no I/O.

Notation: x_i is robot i's entry of the iterated vector, N_i the neighbours whose values it uses this
iteration, (Lx)_i = |N_i|·x_i − Σ_{j∈N_i} x_j the robot's entry of the Laplacian product (the paper's
x_k^{i+1} = L_kk·x_k^i − Σ_{j|L_kj=−1} x_j^i). Every function takes plain floats and lists so that the
unit tests can compare it with the matrix form on small graphs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

METHODS = ("pi1", "pi2", "wave")
DROPS = ("drop", "reuse")


# ------------------------------------------------------------------ shared
def laplacian_row(x_i: float, values: Sequence[float]) -> float:
    """(Lx)_i = d_i·x_i − Σ_j x_j over the neighbour values used (d_i = how many)."""
    return len(values) * x_i - math.fsum(values)


def ratio_estimate(x_i: float, lx_i: float) -> float | None:
    """λ̂_i = (Lx)_i / x_i: exact for every robot once x is an eigenvector (authors' code); None at x_i = 0."""
    if x_i == 0.0 or not math.isfinite(x_i):
        return None
    est = lx_i / x_i
    return est if math.isfinite(est) else None


def step_size(dmax: int) -> float:
    """γ = 1/(2·d_max): λ_max ≤ 2·d_max, so I − γL has its spectrum in [0, 1] (a safe power iteration)."""
    return 1.0 / (2.0 * max(dmax, 1))


# ------------------------------------------------------------------ PI1 (Bertrand & Moonen [11])
def pi1_phase(r: int, flood: int) -> str:
    """Return what PI1 does at position r of its period: "L", "GN" or "G".

    "L" (r = 0): x ← Lx, which removes the constant vector's component (rounding error makes it grow by
    1/(1 − γλ2) per G step); "GN" (r = flood + 1): a G step, then the division by the beacon's norm, which
    the beacon computed at r = 1 and flooded since; "G": x ← (I − γL)x.
    """
    if r == 0:
        return "L"
    if r == flood + 1:
        return "GN"
    return "G"


def pi1_period(estimate: float | None, gamma: float, flood: int, default: int, gain: float = 10.0,
               longest: int = 5000) -> int:
    """Length of the next PI1 period, chosen by the beacon from its own estimate λ̂_b: ceil(gain/(γ·λ̂_b)).

    Between two L steps the constant component grows by about exp(γ·λ2·P) and the L step amplifies a mode
    λ_m against λ2 by λ_m/λ2 while the G steps damp it by exp(−γ(λ_m − λ2)·P): γ·λ2·P = 10 keeps the first
    below 10⁵ (from 10⁻¹⁶) and makes the second shrink for every λ_m > λ2. Clipped to [flood + 3, longest];
    ``default`` without a usable estimate.
    """
    if estimate is None or not math.isfinite(estimate) or estimate <= 0.0:
        return max(default, flood + 3)
    return int(min(max(math.ceil(gain / (gamma * estimate)), flood + 3), longest))


def pi1_step(x_i: float, lx_i: float, phase: str, gamma: float) -> float:
    """One PI1 update: Lx in the "L" phase, x − γ·Lx otherwise (normalisation is a separate division)."""
    return lx_i if phase == "L" else x_i - gamma * lx_i


def beacon_norm(x_b: float, values: Sequence[float]) -> float:
    """The beacon's norm estimate: the RMS of x over its closed neighbourhood (all it can see)."""
    vals = [x_b, *values]
    return math.sqrt(math.fsum(v * v for v in vals) / len(vals))


# ------------------------------------------------------------------ PI2 (Di Lorenzo & Barbarossa [14])
# The paper (§II-B) says only that [14] uses "average consensus" for the normalisation that a power iteration
# needs. The authors' Octave code iterates B = I − γL − 11ᵀ/K (γ = 0.8/K) once per round, then runs an
# average consensus (weights 0.8/(K − 1)) until max − min < 0.01 and divides by the true 2-norm: the mean in
# B and the norm are computed with global knowledge, the consensus only takes the time. A robot has neither,
# so here the mean comes from a fixed number C of average-consensus steps and the scale from C steps of
# max-consensus in the same frames. An unfinished average consensus removes only part of each mode, so the
# deflation is a filter 1 − (1 − ελ_m)^C on mode m; with one power step per round it can favour λ3 over λ2
# (``pi2_gain``). P power steps per round (``power``) make the power iteration's own ratio
# ((1 − γλ3)/(1 − γλ2))^P beat the filter's.
def pi2_phase(k: int, power: int, consensus: int) -> int:
    """Position r of iteration k ≥ 1 in a PI2 round of ``power`` + ``consensus`` iterations.

    r < power: a power step x ← x − γLx; r ≥ power: a consensus step (the mean and the max of the round's w).
    """
    return (k - 1) % (power + consensus)


def consensus_step(a_i: float, values: Sequence[float], eps: float) -> float:
    """Average consensus a ← (I − εL)a: a_i + ε·Σ_j (a_j − a_i) (the same eigenvectors as L)."""
    return a_i - eps * laplacian_row(a_i, values)


def consensus_eps(dmax: int) -> float:
    """ε = 1/(d_max + 1): the max-degree weights, I − εL doubly stochastic with a non-negative diagonal."""
    return 1.0 / (max(dmax, 1) + 1.0)


def max_step(m_i: float, values: Sequence[float]) -> float:
    """Max-consensus m ← max(m_i, m_j): exact at every robot after as many steps as the graph's diameter."""
    return max([m_i, *values])


def pi2_normalise(w_i: float, mean: float, top: float) -> float:
    """x_i ← (w_i − a_i)/m: deflation by the consensus mean a_i, division by the max-consensus m of |w|.

    Any scale common to all robots keeps the direction, and the estimate (Lx)_i/x_i does not depend on it;
    m only keeps the numbers near 1. m = 0 (w = 0 everywhere): centred, not divided.
    """
    centred = w_i - mean
    return centred / top if top > 0.0 and math.isfinite(top) else centred


def pi2_gain(eigenvalues: Sequence[float], gamma: float, power: int, eps: float, consensus: int) -> list[float]:
    """Per-round gain of each Laplacian mode under PI2 (lossless): |1 − γλ|^P · |1 − (1 − ελ)^C|.

    The mode of largest gain (λ = 0 has gain 0: it is removed exactly, the consensus keeps the sum) is the
    fixed point of the round; it is the Fiedler vector only if λ2's gain is the largest. The max-consensus
    scale multiplies every mode alike and is left out.
    """
    return [abs(1.0 - gamma * lam) ** power * abs(1.0 - (1.0 - eps * lam) ** consensus) for lam in eigenvalues]


# ------------------------------------------------------------------ Wave (Sahai et al. [17])
def wave_step(s1: float, s2: float, lx1: float, k2: float) -> float:
    """s_i(t) = 2·s_i(t−1) − s_i(t−2) − k²·(L s(t−1))_i (the degree term the printed update omits)."""
    return 2.0 * s1 - s2 - k2 * lx1


def wave_k2(dmax: int) -> float:
    """k² = 1/d_max: half the local stability bound k² < 2/d_max (which implies k²·λ_max < 4)."""
    return 1.0 / max(dmax, 1)


def lowest_peak(signal: Sequence[float], rel: float = 0.01, pad: int = 4) -> float | None:
    """ω of the lowest non-zero spectral peak of ``signal`` (rad per iteration), or None.

    The least-squares line is removed (the λ = 0 mode is a constant, its drift under loss a slope), a
    Blackman window applied (side lobes below −58 dB), the FFT (numpy.fft.rfft)
    zero-padded to ≥ ``pad``·n points; the first local maximum of |X| above ``rel`` × the largest, beyond the
    window's main lobe, is refined by a parabola through the log-magnitudes of it and its two neighbours.
    """
    s = np.asarray(signal, dtype=float)
    n = len(s)
    if n < 8 or not np.all(np.isfinite(s)):
        return None
    t = np.arange(n)
    s = (s - np.polyval(np.polyfit(t, s, 1), t)) * np.blackman(n)
    m = 1 << max(int(math.ceil(math.log2(pad * n))), 4)
    mag = np.abs(np.fft.rfft(s, m))
    lobe = int(math.ceil(3 * m / n))  # Blackman main lobe half-width, in padded bins
    if len(mag) <= lobe + 2:
        return None
    top = mag[lobe:].max()
    if top <= 0.0:
        return None
    for b in range(max(lobe, 1), len(mag) - 1):
        if mag[b] >= rel * top and mag[b] >= mag[b - 1] and mag[b] > mag[b + 1]:
            la, lb, lc = np.log(mag[b - 1:b + 2] + 1e-300)
            den = la - 2 * lb + lc
            off = 0.5 * (la - lc) / den if den < 0 else 0.0
            return 2.0 * math.pi * (b + off) / m
    return None


def wave_estimate(signal: Sequence[float], k2: float) -> float | None:
    """λ̂ = 2(1 − cos ω)/k² from the lowest non-zero peak ω of the robot's own signal."""
    w = lowest_peak(signal)
    return None if w is None else 2.0 * (1.0 - math.cos(w)) / k2


# ------------------------------------------------------------------ error (the paper's e)
def error_percent(estimate: float | None, truth: float) -> float:
    """Return e = |λ̂2 − λ2| / (10⁻²·λ2), in percent; inf without an estimate."""
    if estimate is None or truth <= 0.0:
        return math.inf
    return abs(estimate - truth) / (1e-2 * truth)
