"""Slow dense numpy oracles (O(N^2), all pairs) for the numba particle loops.

Each function mirrors one loop in ``fsi_sph/*/_kernels.py`` but is written from the
equation, over a dense pair matrix, with no neighbour list.
"""

import numpy as np


def cubic_w(r, h):
    """Cubic B-spline [F 5], vectorised."""
    q = r / h
    a = 15.0 / (7.0 * np.pi * h * h)
    return a * np.where(q < 1, 2 / 3 - q**2 + 0.5 * q**3, np.where(q < 2, (2 - q) ** 3 / 6, 0.0))


def cubic_dw(r, h):
    q = r / h
    a = 15.0 / (7.0 * np.pi * h * h)
    return a / h * np.where(q < 1, -2 * q + 1.5 * q**2, np.where(q < 2, -0.5 * (2 - q) ** 2, 0.0))


def pairs(x0, h):
    """Dense pair data in the reference configuration: d[i, j] = X_i - X_j, r, mask (j != i,
    r < 2h), grad_i W_ij [npts, npts, 2]."""
    d = x0[:, None, :] - x0[None, :, :]
    r = np.linalg.norm(d, axis=2)
    mask = (r < 2 * h) & ~np.eye(len(x0), dtype=bool)
    rs = np.where(mask, r, 1.0)
    g = np.where(mask[..., None], cubic_dw(rs, h)[..., None] * d / rs[..., None], 0.0)
    w = np.where(mask, cubic_w(rs, h), 0.0)
    return d, mask, g, w


def correction(x0, vol, h):
    """L_i = (M_i^-1)^T, M_i = sum_j V_j (X_j - X_i) (x) grad W_ij [F 13-14]."""
    d, mask, g, _ = pairs(x0, h)
    M = -np.einsum("j,ija,ijb->iab", vol, d, g)
    return np.transpose(np.linalg.inv(M), (0, 2, 1))


def deformation_gradient(x, x0, vol, h):
    """F_i = sum_j V_j (x_j - x_i) (x) L_i grad W_ij [F 36]."""
    _, _, g, _ = pairs(x0, h)
    L = correction(x0, vol, h)
    gc = np.einsum("iab,ijb->ija", L, g)
    dx = x[None, :, :] - x[:, None, :]
    return np.einsum("j,ija,ijb->iab", vol, dx, gc)


def stvk_pk1(F, lam, mu):
    """P = F S, S = lam tr(E) I + 2 mu E, E = (F^T F - I)/2."""
    E = 0.5 * (np.einsum("nki,nkj->nij", F, F) - np.eye(2))
    S = lam * np.trace(E, axis1=1, axis2=2)[:, None, None] * np.eye(2) + 2 * mu * E
    return F @ S


def stress_accelerations(x, x0, vol, P, rho0, h):
    """rho0 a_i = sum_j V_j (P_i L_i + P_j L_j) grad W_ij [F 44] (no viscosity, no HG)."""
    _, _, g, _ = pairs(x0, h)
    L = correction(x0, vol, h)
    PL = P @ L
    s = np.einsum("iab,ijb->ija", PL, g) + np.einsum("jab,ijb->ija", PL, g)
    return np.einsum("j,ija->ia", vol, s) / rho0


def hourglass_accelerations(x, x0, vol, F, rho0, h, coeff, E):
    """Ganzenmueller (2015) penalty: force on i -(c E / 2) V_i V_j W_ij / |X_ij|^2
    (delta_i + delta_j) e_ij, delta = (F X_ij - x_ij) . e_ij, X_ij = X_j - X_i."""
    d0, mask, _, w = pairs(x0, h)
    X = -d0  # X_j - X_i
    xx = x[None, :, :] - x[:, None, :]
    rx = np.linalg.norm(xx, axis=2)
    e = np.where(mask[..., None], xx / np.where(mask, rx, 1.0)[..., None], 0.0)
    err_i = np.einsum("iab,ijb->ija", F, X) - xx
    err_j = np.einsum("jab,ijb->ija", F, X) - xx
    di = np.einsum("ija,ija->ij", err_i, e)
    dj = np.einsum("ija,ija->ij", err_j, e)
    X2 = np.where(mask, np.einsum("ija,ija->ij", X, X), 1.0)
    f = -0.5 * coeff * E * vol[None, :] * w / X2 * (di + dj)
    return np.einsum("ij,ija->ia", np.where(mask, f, 0.0), e) / rho0


def viscous_accelerations(x, v, F, vol, x0, rho0, c0, h, alpha, beta):
    """Artificial viscosity [F 41-43]: q = rhobar (-alpha c phi + beta phi^2) for approaching
    pairs, phi = h v_ij.x_ij / (|x_ij|^2 + 0.01 h^2), PK1 -q/2 J F^-T on each side."""
    _, mask, g, _ = pairs(x0, h)
    L = correction(x0, vol, h)
    xij = x[:, None, :] - x[None, :, :]
    vij = v[:, None, :] - v[None, :, :]
    vdx = np.einsum("ija,ija->ij", vij, xij)
    r2 = np.einsum("ija,ija->ij", xij, xij)
    phi = h * vdx / (r2 + 0.01 * h * h)
    J = np.linalg.det(F)
    rho = rho0 / J
    q = 0.5 * (rho[:, None] + rho[None, :]) * (-alpha * c0 * phi + beta * phi**2)
    q = np.where(mask & (vdx < 0), q, 0.0)
    cof = J[:, None, None] * np.transpose(np.linalg.inv(F), (0, 2, 1))  # J F^-T
    Li_g = np.einsum("iab,ijb->ija", L, g)
    Lj_g = np.einsum("jab,ijb->ija", L, g)
    s = (-0.5 * q)[..., None] * (np.einsum("iab,ijb->ija", cof, Li_g)
                                  + np.einsum("jab,ijb->ija", cof, Lj_g))
    return np.einsum("j,ija->ia", vol, s) / rho0
