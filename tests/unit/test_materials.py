"""Elastic laws F -> P [F 37-40]: zero stress at rest, Hooke limit, objectivity, P = dW/dF."""

import numpy as np
import pytest

from fsi_sph.solid.materials import MODELS, energy_density, lame, pk1, wave_speed

E, NU = 2.0e6, 0.3
LAM, MU = lame(E, NU)


def P_of(model, F):
    return np.array(pk1(MODELS[model], LAM, MU, F[0, 0], F[0, 1], F[1, 0], F[1, 1])).reshape(2, 2)


def rot(a):
    return np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])


def test_lame_and_wave_speed():
    lam, mu = lame(1.0, 0.25)
    assert np.isclose(lam, 0.4) and np.isclose(mu, 0.4)
    assert np.isclose(wave_speed(1.0, 0.25, 1.0), np.sqrt(1.2))


@pytest.mark.parametrize("model", sorted(MODELS))
def test_zero_stress_at_rest_and_under_rotation(model):
    assert np.allclose(P_of(model, np.eye(2)), 0.0, atol=1e-9)
    assert np.allclose(P_of(model, rot(0.7)), 0.0, atol=1e-6 * MU)


@pytest.mark.parametrize("model", sorted(MODELS))
def test_small_strain_is_hooke(model):
    """Plane strain: sigma = lam tr(eps) I + 2 mu eps for |eps| << 1."""
    eps = 1e-6 * np.array([[1.0, 0.4], [0.4, -0.7]])
    P = P_of(model, np.eye(2) + eps)
    want = LAM * np.trace(eps) * np.eye(2) + 2 * MU * eps
    np.testing.assert_allclose(P, want, rtol=1e-4, atol=1e-9 * MU)


@pytest.mark.parametrize("model", sorted(MODELS))
def test_objective(model, rng):
    """P(R F) = R P(F)."""
    F = np.eye(2) + 0.2 * rng.standard_normal((2, 2))
    R = rot(1.1)
    np.testing.assert_allclose(P_of(model, R @ F), R @ P_of(model, F), rtol=1e-10,
                               atol=1e-10 * MU)


@pytest.mark.parametrize("model", ["stvk", "neo_hookean"])
def test_pk1_is_energy_derivative(model, rng):
    """P = dW/dF (hyperelastic laws), by central differences."""
    F = np.eye(2) + 0.15 * rng.standard_normal((2, 2))
    h = 1e-6
    fd = np.zeros((2, 2))
    for a in range(2):
        for b in range(2):
            Fp, Fm = F.copy(), F.copy()
            Fp[a, b] += h
            Fm[a, b] -= h
            wp = energy_density(MODELS[model], LAM, MU, *Fp.ravel())
            wm = energy_density(MODELS[model], LAM, MU, *Fm.ravel())
            fd[a, b] = (wp - wm) / (2 * h)
    np.testing.assert_allclose(P_of(model, F), fd, rtol=1e-6, atol=1e-6 * MU)


def test_hooke_almansi_is_hooke_on_almansi_strain():
    """The source's law [F 37-40]: sigma = lam tr(e) I + 2 mu e, e = F^-T E F^-1,
    P = J sigma F^-T."""
    F = np.array([[1.1, 0.2], [-0.05, 0.9]])
    Ei = 0.5 * (F.T @ F - np.eye(2))
    Fi = np.linalg.inv(F)
    e = Fi.T @ Ei @ Fi
    sig = LAM * np.trace(e) * np.eye(2) + 2 * MU * e
    want = np.linalg.det(F) * sig @ Fi.T
    np.testing.assert_allclose(P_of("hooke_almansi", F), want, rtol=1e-12)


@pytest.mark.parametrize("model", sorted(MODELS))
@pytest.mark.parametrize("plane", ["strain", "stress"])
def test_uniaxial_stress_modulus(model, plane):
    """Uniaxial stress (sigma_yy = 0) at small strain: the 2D law's axial modulus is
    E / (1 - nu^2) in plane strain (eps_zz = 0) and E in plane stress (sigma_zz = 0).
    eps_yy is found from sigma_yy = 0 (linear in eps_yy at small strain)."""
    lam, mu = lame(E, NU, plane)
    exx = 1e-6

    def p_of(eyy):
        F = np.diag([1.0 + exx, 1.0 + eyy])
        return np.array(pk1(MODELS[model], lam, mu, *F.ravel())).reshape(2, 2)

    s0, s1 = p_of(0.0)[1, 1], p_of(-1e-6)[1, 1]
    eyy = 1e-6 * s0 / (s1 - s0)  # root of sigma_yy(eps_yy), linear between the two
    modulus = p_of(eyy)[0, 0] / exx
    want = E / (1 - NU**2) if plane == "strain" else E
    assert np.isclose(modulus, want, rtol=1e-4)
    # lateral contraction: nu/(1 - nu) in plane strain, nu in plane stress
    assert np.isclose(-eyy / exx, NU / (1 - NU) if plane == "strain" else NU, rtol=1e-4)


def test_plane_stress_wave_speed_and_bad_plane():
    lam, mu = lame(1.0, 0.25, "stress")
    assert np.isclose(lam, 0.25 / (1 - 0.25**2)) and np.isclose(mu, 0.4)
    assert np.isclose(wave_speed(1.0, 0.25, 1.0, "stress"), np.sqrt(1 / (1 - 0.25**2)))
    with pytest.raises(ValueError, match="allowed"):
        lame(1.0, 0.25, "shell")
