"""Drucker-Prager return mapping [S 4-36 to 4-41] (scalar helper, tension positive)."""

import math

import numpy as np
import pytest

from fsi_sph.soil._kernels import dp_parameters, invariants, return_map

E, NU = 10.0e6, 0.3
G = E / (2 * (1 + NU))
K = E / (3 * (1 - 2 * NU))


def f_yield(s, alpha, kc):
    i1, sj2 = invariants(*s)
    return alpha * i1 + sj2 - kc


def random_states(rng, n, scale=1e5):
    """Random plane-strain stresses (sxx, syy, sxy, szz), mostly compressive."""
    out = rng.normal(size=(n, 4)) * scale
    out[:, [0, 1, 3]] -= rng.uniform(0, 2, size=(n, 1)) * scale
    return out


def test_plane_strain_fit_values():
    """psi = 0: alpha = sin(phi)/3, k_c = c cos(phi) (the plane-strain match at flow,
    tests/unit/test_soil_dp_fit.py; [S 4-40, 4-41] is its psi = phi case)."""
    alpha, kc, apsi = dp_parameters(math.radians(30.0), 1e4, 0.0)
    assert alpha == pytest.approx(math.sin(math.radians(30.0)) / 3.0, rel=1e-14)
    assert kc == pytest.approx(1e4 * math.cos(math.radians(30.0)), rel=1e-14)
    assert apsi == 0.0


@pytest.mark.parametrize("phi,c,psi", [(20.0, 0.0, 0.0), (30.0, 1e4, 0.0), (35.0, 5e3, 10.0),
                                       (0.0, 2e4, 0.0)])
def test_returned_stress_on_or_inside_surface(phi, c, psi):
    alpha, kc, apsi = dp_parameters(math.radians(phi), c, math.radians(psi))
    rng = np.random.default_rng(1)
    for s in random_states(rng, 500):
        out = return_map(*s, alpha, kc, apsi, G, K)
        f_new = f_yield(out[:4], alpha, kc)
        assert f_new <= 1e-9 * max(1.0, abs(s).max())
        beyond_apex = alpha > 0 and sum(s[[0, 1, 3]]) > kc / alpha
        if f_yield(s, alpha, kc) > 1e-9 * abs(s).max() or beyond_apex:
            # plastic: on the surface (or at the apex), positive plastic strain
            assert abs(f_new) <= 1e-8 * abs(s).max()
            assert out[4] >= 0.0


def test_elastic_state_untouched():
    alpha, kc, apsi = dp_parameters(math.radians(30.0), 1e4, 0.0)
    rng = np.random.default_rng(2)
    n_el = 0
    for s in random_states(rng, 500, scale=2e4):
        if f_yield(s, alpha, kc) < 0 and sum(s[[0, 1, 3]]) < kc / alpha:
            out = return_map(*s, alpha, kc, apsi, G, K)
            assert out[:4] == tuple(s)
            assert out[4] == 0.0
            n_el += 1
    assert n_el > 50


def test_psi_zero_keeps_mean_stress_and_scales_deviator():
    """Non-associated flow with psi = 0: no plastic volume change, s scaled radially."""
    alpha, kc, apsi = dp_parameters(math.radians(25.0), 2e3, 0.0)
    s = np.array([-1e5, -3e5, 8e4, -1.5e5])
    out = np.array(return_map(*s, alpha, kc, apsi, G, K)[:4])
    assert out[[0, 1, 3]].sum() == pytest.approx(s[[0, 1, 3]].sum(), rel=1e-13)
    m0, m1 = s[[0, 1, 3]].mean(), out[[0, 1, 3]].mean()
    d0 = s - np.array([m0, m0, 0, m0])
    d1 = out - np.array([m1, m1, 0, m1])
    ratio = d1 / d0
    assert np.allclose(ratio, ratio[0], rtol=1e-12) and 0 < ratio[0] < 1


def test_dilatancy_changes_mean_stress():
    """With psi > 0 the plastic strain dilates (tr d_eps_p = 3 alpha_psi dlam > 0), so the
    constrained return makes I1 more compressive by 9 K alpha_psi dlam,
    dlam = f/(G + 9 K alpha alpha_psi)."""
    alpha, kc, apsi = dp_parameters(math.radians(30.0), 0.0, math.radians(15.0))
    s = np.array([-1e5, -3e5, 8e4, -1.5e5])
    f0 = f_yield(s, alpha, kc)
    dlam = f0 / (G + 9 * K * alpha * apsi)
    out = return_map(*s, alpha, kc, apsi, G, K)
    i1_new = out[0] + out[1] + out[3]
    assert i1_new == pytest.approx(s[[0, 1, 3]].sum() - 9 * K * apsi * dlam, rel=1e-12)
    assert abs(f_yield(out[:4], alpha, kc)) < 1e-9 * abs(s).max()


@pytest.mark.parametrize("c", [0.0, 1e4])
@pytest.mark.parametrize("psi", [0.0, 15.0, 30.0])
def test_tension_apex(c, psi):
    """A hydrostatic tension beyond the apex goes to the apex I1 = k_c/alpha with s = 0
    (tension cracking: I1 moved back to the apex, then the deviator scaled by
    (k_c - alpha I1)/sqrt(J2) = 0, PHYSICS §6 / [S 4-36]); for c = 0 that is the stress-free
    state, whatever the dilatancy: a particle pulled apart must not come out compressed."""
    alpha, kc, apsi = dp_parameters(math.radians(30.0), c, math.radians(psi))
    s = (5e4, 4e4, 1e4, 4.5e4)
    out = return_map(*s, alpha, kc, apsi, G, K)
    i1, sj2 = invariants(*out[:4])
    assert i1 == pytest.approx(kc / alpha, abs=1e-8 * 5e4)
    assert sj2 == pytest.approx(0.0, abs=1e-8 * 5e4)
    if c == 0.0:
        assert np.allclose(out[:4], 0.0, atol=1e-9)


def test_plastic_strain_increment():
    """eps_p increment = sqrt(2/3) |s_trial - s_new|/(2G)."""
    alpha, kc, apsi = dp_parameters(math.radians(20.0), 0.0, 0.0)
    s = np.array([-1e5, -4e5, 5e4, -2e5])
    out = return_map(*s, alpha, kc, apsi, G, K)
    ds = np.array(out[:4]) - s
    norm = math.sqrt(ds[0] ** 2 + ds[1] ** 2 + ds[3] ** 2 + 2 * ds[2] ** 2)
    assert out[4] == pytest.approx(math.sqrt(2 / 3) * norm / (2 * G), rel=1e-12)
