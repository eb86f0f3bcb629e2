"""The Drucker-Prager cone's plane-strain match to Mohr-Coulomb (``dp_parameters``) and the
factor of safety of an infinite cohesionless slope that the cone itself implies.

An infinite slope at angle beta carries on planes parallel to its surface
``tau/(-sigma_n) = tan(beta)`` at every depth; the stress along the slope ``sigma_s`` is free
(statically indeterminate) and in plane strain at plastic flow the out-of-plane stress
follows from ``eps_zz^p = 0``: ``s_zz = -2 alpha_psi sqrt(J2)``. The slope can stand when
some ``sigma_s`` keeps ``f = alpha I1 + sqrt(J2) - k_c <= 0``; with strength reduction
(``tan(phi)/F``) the factor of safety is the F at which the largest admissible
``tau/(-sigma_n)`` equals tan(beta). For Mohr-Coulomb that is ``tan(phi)/tan(beta)``.
Everything below is found numerically from the cone (root finding over the stress), not from
the closed forms of ``dp_parameters``.
"""

import math

import pytest
from scipy.optimize import brentq, minimize_scalar

from fsi_sph.soil._kernels import dp_parameters, invariants


def _f_at_flow(sig_s, tau, alpha, kc, a_psi):
    """Yield function of the in-plane state (sigma_s, sigma_n = -1, tau) with sigma_zz at
    its plane-strain flow value (s_zz = -2 a_psi sqrt(J2), solved numerically)."""
    sn = -1.0

    def flow(szz):
        i1, sj2 = invariants(sig_s, sn, tau, szz)
        return (szz - i1 / 3.0) + 2.0 * a_psi * sj2

    lo, hi = -50.0, 50.0
    szz = brentq(flow, lo, hi, xtol=1e-14)
    i1, sj2 = invariants(sig_s, sn, tau, szz)
    return alpha * i1 + sj2 - kc


def max_slope_ratio(phi, psi):
    """Largest tau/(-sigma_n) on a plane that the cone admits at plastic flow (c = 0)."""
    alpha, kc, a_psi = dp_parameters(phi, 0.0, psi)

    def best_f(tau):  # f minimised over the free stress along the slope
        r = minimize_scalar(lambda s: _f_at_flow(s, tau, alpha, kc, a_psi),
                            bounds=(-30.0, 0.0), method="bounded",
                            options=dict(xatol=1e-12))
        return r.fun

    return brentq(best_f, 1e-6, 20.0, xtol=1e-13)


def infinite_slope_fos(phi, psi, beta):
    """Strength-reduction factor of safety of the infinite slope, from the cone alone."""
    tp = math.tan(phi)
    return brentq(lambda F: max_slope_ratio(math.atan(tp / F), min(psi, math.atan(tp / F)))
                  - math.tan(beta), 0.05, 5.0, xtol=1e-12)


@pytest.mark.parametrize("phi_deg,psi_deg", [(20.0, 0.0), (45.0, 0.0), (60.0, 0.0),
                                             (30.0, 10.0), (40.0, 40.0)])
def test_cone_mobilises_phi_in_plane_strain(phi_deg, psi_deg):
    """At flow the cone admits on a plane exactly tau/(-sigma_n) = tan(phi), whatever psi."""
    phi, psi = math.radians(phi_deg), math.radians(psi_deg)
    assert max_slope_ratio(phi, psi) == pytest.approx(math.tan(phi), rel=1e-6)


@pytest.mark.parametrize("beta_deg", [45.0, 30.0])
def test_infinite_slope_fos_is_tan_phi_over_tan_beta(beta_deg):
    """Slope 1 of [S 5-5] (phi = 20 deg, psi = 0, c = 0): F = tan(phi)/tan(beta); at 45 deg
    0.364. The earlier fit [S 4-40] used with psi = 0 gave 0.297 at 45 deg (-18 %)."""
    phi, beta = math.radians(20.0), math.radians(beta_deg)
    assert infinite_slope_fos(phi, 0.0, beta) == pytest.approx(
        math.tan(phi) / math.tan(beta), rel=1e-6)


def test_associated_fit_is_S_4_40():
    """psi = phi: the fit of [S 4-40, 4-41]."""
    for phi_deg in (10.0, 20.0, 35.0):
        phi = math.radians(phi_deg)
        t = math.tan(phi)
        alpha, kc, a_psi = dp_parameters(phi, 1e4, phi)
        assert alpha == pytest.approx(t / math.sqrt(9 + 12 * t * t), rel=1e-12)
        assert kc == pytest.approx(3e4 / math.sqrt(9 + 12 * t * t), rel=1e-12)
        assert a_psi == pytest.approx(alpha, rel=1e-12)


def test_psi_zero_fit():
    """psi = 0: alpha = sin(phi)/3, k_c = c cos(phi), alpha_psi = 0."""
    phi = math.radians(20.0)
    alpha, kc, a_psi = dp_parameters(phi, 1.1e4, 0.0)
    assert alpha == pytest.approx(math.sin(phi) / 3.0, rel=1e-12)
    assert kc == pytest.approx(1.1e4 * math.cos(phi), rel=1e-12)
    assert a_psi == 0.0


def test_cohesive_plane_strain_strength():
    """phi = 0 (Tresca in plane strain): the cone admits a shear stress c on any plane."""
    alpha, kc, a_psi = dp_parameters(0.0, 2e4, 0.0)
    assert alpha == 0.0
    assert kc == pytest.approx(2e4, rel=1e-12)
