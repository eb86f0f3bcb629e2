"""Objectivity of the Jaumann stress update [S 4-42 to 4-57]: a rigid rotation must turn the
stress with the material and leave its invariants unchanged."""

import math

import numpy as np

from fsi_sph.neighbors import find_neighbors
from fsi_sph.soil import _kernels as K
from fsi_sph.sph.kernels import CUBIC_SPLINE

E, NU = 10.0e6, 0.3
G = E / (2 * (1 + NU))
BULK = E / (3 * (1 - 2 * NU))
SIG0 = np.array([[-3e4, 1.2e4], [1.2e4, -1e4]])
SZZ0 = -1.5e4


def rotate(n_steps, omega=2.0, theta=0.6, use_sph=False):
    """Rotate a set of particles rigidly by ``theta`` in ``n_steps`` stress updates; returns the
    stresses (n, 2, 2), szz, the SPH velocity gradient of the last step and the rotation."""
    dx = 0.1
    ix, iy = np.meshgrid(np.arange(8), np.arange(8), indexing="ij")
    x = np.column_stack([(ix.ravel() + 0.5) * dx, (iy.ravel() + 0.5) * dx])
    n = len(x)
    W = np.array([[0.0, -omega], [omega, 0.0]])
    v = x @ W.T
    dt = theta / omega / n_steps
    if use_sph:
        h = 1.2 * dx
        start, nbr = find_neighbors(x, x, 2 * h, exclude_self=True)
        L = np.zeros((n, 2, 2))
        K.velocity_gradient(n, x, v, v, np.full(n, 2000.0), np.full(n, 2000.0 * dx * dx), start,
                            nbr, h, CUBIC_SPLINE, L, np.zeros(n))
    else:
        L = np.broadcast_to(W, (n, 2, 2)).copy()
    sigma = np.broadcast_to(SIG0, (n, 2, 2)).copy()
    szz = np.full(n, SZZ0)
    eps_p = np.zeros(n)
    alpha, kc, apsi = K.dp_parameters(math.radians(30.0), 1e6, 0.0)  # stays elastic
    for _ in range(n_steps):
        K.stress_update(n, L, sigma, szz, eps_p, dt, G, BULK, alpha, kc, apsi)
    c, s = math.cos(theta), math.sin(theta)
    R = np.array([[c, -s], [s, c]])
    return sigma, szz, eps_p, R


def invariants(sig, szz):
    i1 = sig[:, 0, 0] + sig[:, 1, 1] + szz
    det2 = sig[:, 0, 0] * sig[:, 1, 1] - sig[:, 0, 1] ** 2
    return i1, det2


def test_rigid_rotation_keeps_invariants_and_rotates_stress():
    i1_0 = np.trace(SIG0) + SZZ0
    det_0 = np.linalg.det(SIG0)
    errs, derrs = [], []
    for n_steps in (200, 400):
        sig, szz, eps_p, R = rotate(n_steps)
        i1, det2 = invariants(sig, szz)
        np.testing.assert_allclose(i1, i1_0, rtol=1e-13)  # trace: exact
        np.testing.assert_allclose(szz, SZZ0, rtol=1e-13)
        assert np.all(eps_p == 0.0)
        derrs.append(np.max(np.abs(det2 / det_0 - 1)))
        errs.append(np.abs(sig[0] - R @ SIG0 @ R.T).max() / np.abs(SIG0).max())
    # explicit first-order update: errors O(dt), halving with dt
    assert derrs[0] < 2e-2 and errs[0] < 2e-2
    assert 1.8 < derrs[0] / derrs[1] < 2.2
    assert 1.8 < errs[0] / errs[1] < 2.2


def test_rigid_rotation_through_sph_velocity_gradient():
    """The corrected SPH velocity gradient of a rigid rotation has no strain rate, so the
    stress of every particle (surface ones included) is rotated, not deformed."""
    sig, szz, _, R = rotate(400, use_sph=True)
    i1, det2 = invariants(sig, szz)
    np.testing.assert_allclose(i1, np.trace(SIG0) + SZZ0, rtol=1e-9)
    sig_ref, szz_ref, _, _ = rotate(400)  # the exact-L update: SPH must reproduce it
    np.testing.assert_allclose(sig, sig_ref, rtol=1e-8, atol=1e-8 * np.abs(SIG0).max())
    assert np.max(np.abs(det2 / np.linalg.det(SIG0) - 1)) < 1e-2
    assert np.abs(sig - R @ SIG0 @ R.T).max() / np.abs(SIG0).max() < 1e-2
