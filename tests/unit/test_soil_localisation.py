"""Where the Drucker-Prager soil can form a shear band: a localisation (acoustic tensor)
analysis of the tangent that the implemented stress update actually has.

Rudnicki & Rice (1975, J. Mech. Phys. Solids 23:371) and Rice (1976): a band with normal N
can form when ``det(N . C^ep . N) <= 0`` (loss of ellipticity; in dynamics, of
hyperbolicity). For non-associated flow (psi < phi) this happens already at zero hardening,
i.e. in the elastic-perfectly plastic soil of [S 4-36 to 4-41], and only for a range of
orientations; Vermeer (1990, Geotechnique 40:223) places observed and computed bands between
Roscoe's 45 + psi/2 and Coulomb's 45 + phi/2. The tangent here is taken from
``stress_update`` by finite differences (no formula assumed), at the plane-strain critical
state of the column's soil (phi = 19.8 deg, c = 0: in-plane Mohr circle at asin(3 alpha),
s_zz = 0, sigma_v the major stress, as in the active wedge behind the released face).

What it shows for the column collapse (validation/column_collapse.py): with psi = 0 a band
can form at 45.0 to 53.3 deg from the horizontal (the most critical orientation ~49 deg), so
the onset line the SPH soil draws at 45.0 deg is one the model admits (its Roscoe edge),
and Coulomb's 54.9 deg is not among them: in that stress state (the Rankine active state, a
vertical major stress) no discretisation of this model can put a band there. At first yield
from an elastic state (s_zz the smallest deviator) no orientation localises yet; the state
reaches the critical one as s_zz flows to 0. With psi = phi no orientation loses
ellipticity at zero hardening.
"""

import math

import numpy as np
import pytest

from fsi_sph.soil._kernels import dp_parameters, stress_update

E, NU = 5.84e6, 0.3
G = E / (2 * (1 + NU))
K = E / (3 * (1 - 2 * NU))
PHI = 19.8


def critical_state(alpha, p0=1.0e3):
    """Plane-strain critical state on the cone: sigma_yy = -p0 (major), in-plane circle at
    sin(phi_m) = 3 alpha, s_zz = 0 (tension positive)."""
    sm = 3.0 * alpha
    sxx = -p0 * (1.0 - sm) / (1.0 + sm)
    return sxx, -p0, 0.0, 0.5 * (sxx - p0)


def response(state, deps, params):
    """Stress increment (xx, yy, xy) of one stress_update with strain increment deps
    (exx, eyy, gamma_xy/2), no rotation (dt = 1, L symmetric)."""
    sxx, syy, sxy, szz = state
    L = np.array([[[deps[0], deps[2]], [deps[2], deps[1]]]])
    sigma = np.array([[[sxx, sxy], [sxy, syy]]])
    sz = np.array([szz])
    eps = np.zeros(1)
    stress_update(1, L, sigma, sz, eps, 1.0, G, K, *params)
    return np.array([sigma[0, 0, 0] - sxx, sigma[0, 1, 1] - syy, sigma[0, 0, 1] - sxy]), eps[0]


def tangent(psi_deg):
    """In-plane tangent D (3x3, Voigt with tensorial shear strain) of the plastic-loading
    branch of stress_update, by finite differences inside the loading cone."""
    params = dp_parameters(math.radians(PHI), 0.0, math.radians(psi_deg))
    st = critical_state(params[0])
    eta = 1e-9
    load = np.array([1.0, -1.0, 0.0]) * 1e-6  # lateral extension, vertical compression
    base, ep = response(st, load, params)
    assert ep > 0.0  # plastic loading
    D = np.zeros((3, 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = eta
        D[:, k] = (response(st, load + e, params)[0] - base) / eta
    return D, st


def det_acoustic(D, theta_deg):
    """det(N . C . N) for the band plane at theta from the horizontal (N its normal)."""
    th = math.radians(theta_deg + 90.0)
    n0, n1 = math.cos(th), math.sin(th)
    # C_ijkl from D (stress (xx, yy, xy) per strain (xx, yy, exy)), minor symmetries
    idx = {(0, 0): 0, (1, 1): 1, (0, 1): 2, (1, 0): 2}
    C = np.zeros((2, 2, 2, 2))
    for i in range(2):
        for j in range(2):
            for k in range(2):
                for m in range(2):
                    f = 1.0 if k == m else 0.5  # e_xy carries half of each of kl = xy, yx
                    C[i, j, k, m] = D[idx[i, j], idx[k, m]] * f
    N = np.array([n0, n1])
    return np.linalg.det(np.einsum("j,ijkl,l->ik", N, C, N))


def test_elastic_tangent_is_recovered_in_unloading():
    params = dp_parameters(math.radians(PHI), 0.0, 0.0)
    st = critical_state(params[0])
    ds, ep = response(st, np.array([-1e-7, 1e-7, 0.0]), params)  # unloading: elastic
    lam = K - 2.0 * G / 3.0
    assert ep == 0.0
    np.testing.assert_allclose(ds, [-2 * G * 1e-7, 2 * G * 1e-7, 0.0], rtol=1e-6,
                               atol=1e-9 * lam)


@pytest.mark.parametrize("psi", [0.0, PHI])
def test_band_orientations_of_the_column_soil(psi):
    D, _ = tangent(psi)
    angles = np.arange(30.0, 80.0, 0.1)
    dets = np.array([det_acoustic(D, a) for a in angles])
    if psi == 0.0:
        band = angles[dets < 0.0]
        assert len(band) > 0  # loses ellipticity at zero hardening (Rudnicki & Rice)
        assert band.min() == pytest.approx(45.0, abs=0.3)  # Roscoe, 45 + psi/2
        assert band.max() == pytest.approx(53.3, abs=0.3)
        assert band.max() < 45.0 + PHI / 2.0  # Coulomb's angle is not admitted
        assert angles[np.argmin(dets)] == pytest.approx(49.1, abs=0.5)
    else:
        assert dets.min() > 0.0  # associated: no band at zero hardening
