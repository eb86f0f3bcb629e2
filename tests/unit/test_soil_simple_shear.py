"""Steady simple shear of the Drucker-Prager soil at a material point (stress_update: Jaumann
rate [S 4-42 to 4-57] and return mapping [S 4-36 to 4-41]) against the analytic critical
state of non-associated flow with psi = 0.

With psi = 0 the plastic strain rate is deviatoric and parallel to s; in simple shear
(no stretching, plane strain) it ends when the in-plane and out-of-plane normal deviators
vanish, sigma_xx = sigma_yy = sigma_zz = -p, and the stress sits on the cone with
sqrt(J2) = |tau| = 3 alpha p. The shear on the shearing plane is then tau/sigma_n = 3 alpha
= sin phi with the plane-strain fit at flow for psi = 0, alpha = sin(phi)/3: the friction
that a slip band of this soil mobilises in steady simple shear is atan(sin phi) = 18.7 deg for
phi = 19.8 deg, below phi (Davis 1968: tan phi* = sin phi cos psi/(1 - sin phi sin psi)).
(With the fit [S 4-40] used at psi = 0 it was atan(3 alpha) = 18.4 deg.) That is part of why
the cohesionless soil runs out further than a material with friction phi on its slip
surfaces.
"""

import math

import numpy as np
import pytest

from fsi_sph.soil._kernels import dp_parameters, stress_update

E, NU = 5.84e6, 0.3
G = E / (2 * (1 + NU))
K = E / (3 * (1 - 2 * NU))


@pytest.mark.parametrize("phi", [19.8, 30.0])
def test_simple_shear_critical_state(phi):
    alpha, kc, apsi = dp_parameters(math.radians(phi), 0.0, 0.0)
    p0 = 2.0e3
    sigma = np.array([[[-0.43 * p0, 0.0], [0.0, -p0]]])  # an at-rest (K0) start
    szz = np.array([-0.43 * p0])
    eps = np.zeros(1)
    gdot, dt = 1.0, 1e-5
    L = np.array([[[0.0, gdot], [0.0, 0.0]]])  # v_x = gdot y
    for _ in range(40000):  # shear strain 0.4
        stress_update(1, L, sigma, szz, eps, dt, G, K, alpha, kc, apsi)
    sxx, syy, sxy = sigma[0, 0, 0], sigma[0, 1, 1], sigma[0, 0, 1]
    p = -(sxx + syy + szz[0]) / 3.0
    # normal stresses equal to O(tau/G), shear ratio 3 alpha
    np.testing.assert_allclose([sxx, syy, szz[0]], -p, rtol=1e-3)
    assert abs(sxy) / -syy == pytest.approx(3.0 * alpha, rel=1e-3)
    # Davis (1968) for psi = 0: tan phi* = sin phi
    assert abs(sxy) / -syy == pytest.approx(math.sin(math.radians(phi)), rel=1e-3)
