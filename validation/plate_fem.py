"""Reference first-mode period of a clamped 2D plate in plane-strain elasticity, by finite
elements (bilinear quads, 2x2 Gauss, consistent mass; scipy shift-invert eigensolver).

Thin-plate (Euler-Bernoulli) theory, which gives the oscillating plate's analytic reference
T c0/L = 72.39 [F 49-50], neglects shear deformation and rotary inertia; for L/t = 10 these
lengthen the period by a fraction of a percent. This module computes the 2D-continuum period
that a converged SPH solution should approach, so the validation can report both.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla


def _q1_matrices(a, b, lam, mu, rho):
    """Stiffness (8x8) and consistent mass (8x8) of an a x b bilinear quad, plane strain.
    Node order (0,0), (a,0), (a,b), (0,b); dofs (u0, v0, u1, v1, ...)."""
    D = np.array([[lam + 2 * mu, lam, 0.0], [lam, lam + 2 * mu, 0.0], [0.0, 0.0, mu]])
    xi_n = np.array([-1.0, 1.0, 1.0, -1.0])
    eta_n = np.array([-1.0, -1.0, 1.0, 1.0])
    g = 1.0 / math.sqrt(3.0)
    Ke = np.zeros((8, 8))
    Me = np.zeros((8, 8))
    for xi in (-g, g):
        for eta in (-g, g):
            N = 0.25 * (1 + xi * xi_n) * (1 + eta * eta_n)
            dNx = 0.25 * xi_n * (1 + eta * eta_n) * 2.0 / a
            dNy = 0.25 * eta_n * (1 + xi * xi_n) * 2.0 / b
            B = np.zeros((3, 8))
            B[0, 0::2] = dNx
            B[1, 1::2] = dNy
            B[2, 0::2] = dNy
            B[2, 1::2] = dNx
            w = a * b / 4.0
            Ke += w * B.T @ D @ B
            Nm = np.zeros((2, 8))
            Nm[0, 0::2] = N
            Nm[1, 1::2] = N
            Me += w * rho * Nm.T @ Nm
    return Ke, Me


def first_period(length, thickness, E, nu, rho, nx, ny):
    """First natural period (s) of a plate clamped at x = 0 (all dofs of that edge fixed)."""
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    a, b = length / nx, thickness / ny
    Ke, Me = _q1_matrices(a, b, lam, mu, rho)
    node = np.arange((nx + 1) * (ny + 1)).reshape(nx + 1, ny + 1)
    ex, ey = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    ex, ey = ex.ravel(), ey.ravel()
    conn = np.stack([node[ex, ey], node[ex + 1, ey], node[ex + 1, ey + 1], node[ex, ey + 1]], 1)
    dofs = np.repeat(2 * conn, 2, axis=1) + np.tile([0, 1], 4)
    rows = np.repeat(dofs, 8, axis=1).ravel()
    cols = np.tile(dofs, (1, 8)).ravel()
    ndof = 2 * (nx + 1) * (ny + 1)
    K = sp.csr_matrix((np.tile(Ke.ravel(), len(conn)), (rows, cols)), shape=(ndof, ndof))
    M = sp.csr_matrix((np.tile(Me.ravel(), len(conn)), (rows, cols)), shape=(ndof, ndof))
    free = np.ones(ndof, dtype=bool)
    free[np.concatenate([2 * node[0], 2 * node[0] + 1])] = False
    K, M = K[free][:, free], M[free][:, free]
    w2 = spla.eigsh(K.tocsc(), k=1, M=M.tocsc(), sigma=0.0, which="LM",
                    return_eigenvectors=False)[0]
    return 2 * math.pi / math.sqrt(w2)


def converged_period(length, thickness, E, nu, rho, ny_list=(8, 16, 32)):
    """Periods on three meshes of square elements and their Richardson extrapolation
    (second order); returns (extrapolated, [periods], observed order)."""
    Ts = [first_period(length, thickness, E, nu, rho, round(ny * length / thickness), ny)
          for ny in ny_list]
    order = math.log2(abs(Ts[0] - Ts[1]) / abs(Ts[1] - Ts[2]))
    T = Ts[2] + (Ts[2] - Ts[1]) / (2**order - 1)
    return T, Ts, order


def euler_bernoulli_period(length, thickness, E, nu, rho, kl=1.875):
    """Thin-plate (plane strain) first period: w^2 = E' t^2 k^4 / (12 rho), E' = E/(1-nu^2)."""
    k = kl / length
    w2 = E / (1 - nu**2) * thickness**2 * k**4 / (12 * rho)
    return 2 * math.pi / math.sqrt(w2)
