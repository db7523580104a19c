"""Leader-follower pure rules (protocols/leader_follower/rules.py), Eqs. 9–24 of Sano et al."""

from __future__ import annotations

import math

import pytest

from protocols.leader_follower import rules
from protocols.leader_follower.suite import TABLE1, TABLE2

P = rules.Params(rho=5.0, rho1=4.65, rho2=0.55, rho3=0.20, size=0.20, U=0.9)  # Table 1, follower 1


def test_order_holds_for_both_tables_and_names_the_broken_key():
    for rho, r1, r2, r3, size, _ in TABLE1 + TABLE2:
        assert rules.order_problem(rho, r1, r2, r3, size) is None
    assert "rho3" in rules.order_problem(5.0, 4.65, 0.55, 0.10, 0.20)
    assert "rho2" in rules.order_problem(5.0, 4.65, 0.15, 0.20, 0.20)
    assert "rho1" in rules.order_problem(5.0, 0.50, 0.55, 0.20, 0.20)
    assert "rho1" in rules.order_problem(4.0, 4.65, 0.55, 0.20, 0.20)


def test_band_radii_eq17():
    assert rules.rho_e_minus(P, 0.0) == pytest.approx(0.55)
    assert rules.rho_e_minus(P, 0.9) == pytest.approx(0.20)  # U′ = U: ρ^{e−} = ρ‴
    assert rules.rho_c(P, 0.9) == pytest.approx(4.65 + 0.35 / 2)
    assert rules.rho_e_plus(P, 0.9) == pytest.approx(5.0)  # U′ = U: ρ^{e+} = ρ


def test_radial_eqs_11_14_15_and_clip():
    assert rules.radial(P, 0.55) == 0.0
    assert rules.radial(P, 0.375) == pytest.approx(-0.45)  # halfway to ρ‴: −U/2, away from the target
    assert rules.radial(P, 2.0) == 0.0  # between ρ″ and ρ′
    assert rules.radial(P, 4.825) == pytest.approx(0.45)
    assert rules.radial(P, 5.0) == pytest.approx(0.9)
    assert rules.radial(P, 9.0) == pytest.approx(0.9)  # clipped to U
    assert rules.radial(P, 0.0) == pytest.approx(-0.9)


@pytest.mark.parametrize("r,case", [(0.4, "a"), (0.55, "a"), (1.0, "b"), (2.6, "b"), (3.0, "c"),
                                    (4.65, "d"), (4.8, "d"), (4.9, "e")])
def test_cases(r, case):
    assert rules.case_of(P, r, 0.9) == case


def test_tracking_inputs_b_c_d_e():
    Up = 0.6
    mid = (0.55 + 4.65) / 2
    ur, ut, up = rules.tracking(P, mid, 1.0, Up)
    assert ur == 0.0 and up == Up and ut == pytest.approx(Up)  # (b)/(c) peak σU′ at the middle
    ur, ut, _ = rules.tracking(P, 1.0, -0.5, Up)
    assert ut == pytest.approx(2 * -0.5 * Up / 4.1 * 0.45)  # (b)
    ur, ut, _ = rules.tracking(P, 4.0, 0.5, Up)
    assert ut == pytest.approx(2 * 0.5 * Up / 4.1 * 0.65)  # (c)
    ur, ut, _ = rules.tracking(P, 4.7, 0.5, Up)  # (d): ρ^c = 4.65 + 0.6/1.8·0.35
    assert ur == pytest.approx(0.9 * 0.05 / 0.35) and ut == pytest.approx(0.5 * ur)
    ur, ut, up = rules.tracking(P, 4.85, 0.5, Up)  # (e)
    assert ut == pytest.approx(0.5 * (up - ur)) and up == Up


def test_tracking_updates_U_prime_first_eq16():
    ur, _, up = rules.tracking(P, 4.99, 1.0, 0.1)
    assert up == pytest.approx(abs(ur))


@pytest.mark.parametrize("r", [0.05, 0.3, 0.55, 1.0, 2.6, 4.0, 4.7, 4.8, 4.95, 5.0, 6.0])
@pytest.mark.parametrize("sigma", [-1.0, -0.3, 0.0, 0.7, 1.0])
def test_speed_never_exceeds_U_lemma_42(r, sigma):
    for Up in (0.0, 0.2, 0.9):
        ur, ut, _ = rules.tracking(P, r, sigma, Up)
        assert math.hypot(ur, ut) <= P.U + 1e-12


def test_compose_eq9():
    ux, uy = rules.compose((0.0, 2.0), 1.0, 0.5)  # e_r = +y, e_θ = −x
    assert (ux, uy) == pytest.approx((-0.5, 1.0))
    assert rules.compose((0.0, 0.0), 1.0, 1.0) == (0.0, 0.0)


def test_switch_period_and_blend_eq18():
    h = min(5.0 - 4.65, 0.55 - 0.20)
    assert rules.switch_period(P) == pytest.approx(h / (2.253 * 0.9))
    assert rules.blend((1.0, 0.0), (0.0, 1.0), 0.25) == pytest.approx((0.75, 0.25))
    assert rules.blend((1.0, 0.0), (0.0, 1.0), 2.0) == pytest.approx((0.0, 1.0))
    assert 2 * math.pi * (1 - math.exp(-1 / rules.ZETA)) / rules.ZETA <= 1


def test_side_eq21():
    assert rules.side((1.0, 0.0), (1.0, -1.0)) == 1  # clockwise of the target: S^r
    assert rules.side((1.0, 0.0), (1.0, 1.0)) == -1
    assert rules.side((1.0, 0.0), (2.0, 0.0)) == 0


def test_theta_des_eqs_22_to_24():
    q = math.pi / 4
    assert rules.theta_next(0.0, 0, 1) == pytest.approx(q)
    assert rules.theta_next(0.0, 0, -1) == pytest.approx(-q)
    assert rules.theta_next(q, 1, 1) == pytest.approx(q)  # (π/4 + π/4)/2
    assert rules.theta_next(q, 1, -1) == pytest.approx(-q / 2)
    assert rules.theta_next(-q / 2, 2, 1) == pytest.approx(q / 4)
    assert rules.theta_next(-q / 2, 2, -1) == pytest.approx((-q - q / 2) / 2)
    th, n = 0.0, 0
    for e in (1, -1, -1, 1, 1, -1, 1):
        th, n = rules.theta_next(th, n, e), n + 1
        assert abs(math.tan(th)) <= 1.0 and th != 0.0


def test_sigma_step_eq20():
    assert rules.sigma_step(0.0, 1.0, -1.0, 1.0, 0.01) == pytest.approx(0.01)
    assert rules.sigma_step(0.0, -1.0, -1.0, 1.0, 0.01) == pytest.approx(-0.01)
    assert rules.sigma_step(0.995, 1.0, -1.0, 1.0, 0.01) == pytest.approx(1.0)  # not past σ^des
    assert rules.sigma_step(0.3, 0.3, -1.0, 1.0, 0.01) == 0.3
    assert rules.sigma_step(1.0, 5.0, -1.0, 1.0, 1.0) == 1.0


def test_crossing_target_determination():
    assert rules.crossed(4.60, 4.70, P)  # out through ∂S′
    assert rules.crossed(0.60, 0.50, P)  # in through ∂S″
    assert not rules.crossed(2.0, 2.1, P)
    assert not rules.crossed(4.7, 4.7, P)
