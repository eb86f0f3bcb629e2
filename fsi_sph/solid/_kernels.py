"""Numba particle loops of the TLSPH solid (gather-only: iteration ``i`` writes row ``i``).

Pair arrays are indexed like the CSR neighbour list ``nbr_j`` of the reference
configuration: pair ``k`` in row ``i`` joins particle ``i`` and ``j = nbr_j[k]``.
Shapes: positions ``(n, 2)``, tensors ``(n, 2, 2)``, pair vectors ``(npairs, 2)``.
"""

import math

import numpy as np
from numba import njit, prange

from fsi_sph.solid.materials import energy_density, pk1
from fsi_sph.sph import operators
from fsi_sph.sph.kernels import kernel_dw, kernel_w, pair_offset

DET_MIN = 1e-6  # |det M| below this (relative to a full support) -> no correction


@njit(cache=True, parallel=True)
def reference_gradients(x0, vol, nbr_start, nbr_j, h, kind, out_gw, out_w, out_L):
    """Kernel values and gradients in the reference configuration, and Oger's correction.

    ``out_gw[k] = grad_i W(X_i - X_j)``, ``out_w[k] = W_ij``, and [F 13-14]
    ``out_L[i] = (M_i^-1)^T`` with ``M_i = sum_j V_j (X_j - X_i) (x) grad W_ij``
    (:func:`fsi_sph.sph.operators.correction_matrices`), identity where
    ``|det M| < DET_MIN``.
    """
    for i in prange(x0.shape[0]):
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j, d0, d1, r = pair_offset(x0, x0, nbr_j, i, k)
            dw = kernel_dw(kind, r, h)
            out_gw[k, 0] = dw * d0 / r
            out_gw[k, 1] = dw * d1 / r
            out_w[k] = kernel_w(kind, r, h)
    operators.correction_matrices(x0, vol, nbr_start, nbr_j, h, kind, DET_MIN, out_L)


@njit(cache=True, parallel=True)
def corrected_gradients(nbr_start, nbr_j, gw, L, out_gi, out_gj):
    """Per pair ``out_gi[k] = L_i gw_k`` and ``out_gj[k] = L_j gw_k`` [F 13]."""
    for i in prange(nbr_start.shape[0] - 1):
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            out_gi[k, 0] = L[i, 0, 0] * gw[k, 0] + L[i, 0, 1] * gw[k, 1]
            out_gi[k, 1] = L[i, 1, 0] * gw[k, 0] + L[i, 1, 1] * gw[k, 1]
            out_gj[k, 0] = L[j, 0, 0] * gw[k, 0] + L[j, 0, 1] * gw[k, 1]
            out_gj[k, 1] = L[j, 1, 0] * gw[k, 0] + L[j, 1, 1] * gw[k, 1]


@njit(cache=True, parallel=True)
def deformation_stress(x, vol, nbr_start, nbr_j, gi, model, lam, mu, out_F, out_P):
    """Deformation gradient [F 36] ``F_i = sum_j V_j (x_j - x_i) (x) L_i grad W_ij`` and
    first Piola-Kirchhoff stress ``P_i = P(F_i)`` [F 37-40]."""
    for i in prange(x.shape[0]):
        f00 = 0.0
        f01 = 0.0
        f10 = 0.0
        f11 = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            u0 = (x[j, 0] - x[i, 0]) * vol[j]
            u1 = (x[j, 1] - x[i, 1]) * vol[j]
            f00 += u0 * gi[k, 0]
            f01 += u0 * gi[k, 1]
            f10 += u1 * gi[k, 0]
            f11 += u1 * gi[k, 1]
        out_F[i, 0, 0] = f00
        out_F[i, 0, 1] = f01
        out_F[i, 1, 0] = f10
        out_F[i, 1, 1] = f11
        p00, p01, p10, p11 = pk1(model, lam, mu, f00, f01, f10, f11)
        out_P[i, 0, 0] = p00
        out_P[i, 0, 1] = p01
        out_P[i, 1, 0] = p10
        out_P[i, 1, 1] = p11


@njit(cache=True)
def _viscous_pk1(F, i, q):
    """PK1 of the isotropic viscous pressure q: -q J F^-T [F 43]."""
    f00 = F[i, 0, 0]
    f01 = F[i, 0, 1]
    f10 = F[i, 1, 0]
    f11 = F[i, 1, 1]
    # J F^-T = cofactor matrix of F
    return -q * f11, q * f10, q * f01, -q * f00


@njit(cache=True, parallel=True)
def accelerations(x, v, x0, vol, F, P, nbr_start, nbr_j, gi, gj, w, rho0, c0, h,
                  av_alpha, av_beta, hg_coeff, youngs, out_a):
    """Internal acceleration of every particle (body force and clamps are added by the caller).

    Stress [F 44], written pairwise so that action equals reaction:
    ``rho0 dv_i/dt = sum_j V_j (P_i L_i + P_j L_j) grad W_ij``.
    Artificial viscosity [F 41-43]: for approaching pairs
    ``phi = h (v_ij . x_ij)/(|x_ij|^2 + 0.01 h^2)``, viscous pressure
    ``q = rhobar (-alpha c phi + beta phi^2)`` (Monaghan's ``Pi_ij rhobar^2``), mapped to
    PK1 as ``-q J F^-T`` on each side and halved between them.
    Hourglass control (Ganzenmueller 2015): ``eps_i = F_i X_ij - x_ij``,
    ``delta_i = eps_i . e_ij``, force on i ``-(alpha_HG E / 2) V_i V_j W_ij / |X_ij|^2
    (delta_i + delta_j) e_ij`` with ``e_ij = x_ij/|x_ij|``, ``x_ij = x_j - x_i``.
    """
    for i in prange(x.shape[0]):
        a0 = 0.0
        a1 = 0.0
        rho_i = rho0 / (F[i, 0, 0] * F[i, 1, 1] - F[i, 0, 1] * F[i, 1, 0])
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            # --- stress [F 44]
            s0 = (P[i, 0, 0] * gi[k, 0] + P[i, 0, 1] * gi[k, 1]
                  + P[j, 0, 0] * gj[k, 0] + P[j, 0, 1] * gj[k, 1])
            s1 = (P[i, 1, 0] * gi[k, 0] + P[i, 1, 1] * gi[k, 1]
                  + P[j, 1, 0] * gj[k, 0] + P[j, 1, 1] * gj[k, 1])
            d0 = x[j, 0] - x[i, 0]
            d1 = x[j, 1] - x[i, 1]
            r2 = d0 * d0 + d1 * d1
            # --- artificial viscosity [F 41-43]
            if av_alpha > 0.0 or av_beta > 0.0:
                vdotx = (v[i, 0] - v[j, 0]) * (x[i, 0] - x[j, 0]) + (v[i, 1] - v[j, 1]) * (
                    x[i, 1] - x[j, 1])
                if vdotx < 0.0:
                    phi = h * vdotx / (r2 + 0.01 * h * h)
                    rho_j = rho0 / (F[j, 0, 0] * F[j, 1, 1] - F[j, 0, 1] * F[j, 1, 0])
                    q = 0.5 * (rho_i + rho_j) * (-av_alpha * c0 * phi + av_beta * phi * phi)
                    qi00, qi01, qi10, qi11 = _viscous_pk1(F, i, 0.5 * q)
                    qj00, qj01, qj10, qj11 = _viscous_pk1(F, j, 0.5 * q)
                    s0 += (qi00 * gi[k, 0] + qi01 * gi[k, 1] + qj00 * gj[k, 0] + qj01 * gj[k, 1])
                    s1 += (qi10 * gi[k, 0] + qi11 * gi[k, 1] + qj10 * gj[k, 0] + qj11 * gj[k, 1])
            a0 += vol[j] * s0
            a1 += vol[j] * s1
            # --- hourglass control (Ganzenmueller 2015)
            if hg_coeff > 0.0:
                X0 = x0[j, 0] - x0[i, 0]
                X1 = x0[j, 1] - x0[i, 1]
                r = math.sqrt(r2)
                e0 = d0 / r
                e1 = d1 / r
                di = ((F[i, 0, 0] * X0 + F[i, 0, 1] * X1 - d0) * e0
                      + (F[i, 1, 0] * X0 + F[i, 1, 1] * X1 - d1) * e1)
                dj = ((F[j, 0, 0] * X0 + F[j, 0, 1] * X1 - d0) * e0
                      + (F[j, 1, 0] * X0 + F[j, 1, 1] * X1 - d1) * e1)
                fh = -0.5 * hg_coeff * youngs * vol[j] * w[k] / (X0 * X0 + X1 * X1) * (di + dj)
                a0 += fh * e0
                a1 += fh * e1
        out_a[i, 0] = a0 / rho0
        out_a[i, 1] = a1 / rho0


@njit(cache=True, parallel=True)
def kick(v, a, g, f_ext, m, damping, dt, free):
    """Half or full velocity update ``v += dt (a + g + f_ext/m - xi v)`` on free particles
    [F 44-45]; clamped particles keep v = 0."""
    for i in prange(v.shape[0]):
        if free[i]:
            for d in range(2):
                v[i, d] += dt * (a[i, d] + g[d] + f_ext[i, d] / m[i] - damping * v[i, d])
        else:
            v[i, 0] = 0.0
            v[i, 1] = 0.0


@njit(cache=True, parallel=True)
def drift(x, v, dt):
    """Position update ``x += dt v``."""
    for i in prange(x.shape[0]):
        x[i, 0] += dt * v[i, 0]
        x[i, 1] += dt * v[i, 1]


@njit(cache=True)
def substeps(n, dt, x, v, x0, vol, m, F, P, a, f_ext, free, g, damping, nbr_start, nbr_j, gi,
             gj, w, model, lam, mu, rho0, c0, h, av_alpha, av_beta, hg_coeff, youngs):
    """``n`` velocity-Verlet sub-steps of ``dt`` (kick dt/2, drift, stress, forces, kick dt/2;
    :meth:`ElasticBody.substep`, [F 44-45]) in one call: the same loops in the same order,
    without a return to Python between them (a structure takes tens to hundreds of sub-steps
    per fluid step)."""
    half = 0.5 * dt
    for _ in range(n):
        kick(v, a, g, f_ext, m, damping, half, free)
        drift(x, v, dt)
        deformation_stress(x, vol, nbr_start, nbr_j, gi, model, lam, mu, F, P)
        accelerations(x, v, x0, vol, F, P, nbr_start, nbr_j, gi, gj, w, rho0, c0, h, av_alpha,
                      av_beta, hg_coeff, youngs, a)
        kick(v, a, g, f_ext, m, damping, half, free)


@njit(cache=True)
def strain_energy(F, vol, model, lam, mu):
    """Total stored energy sum_i V_i W(F_i) (serial, fixed summation order)."""
    e = 0.0
    for i in range(F.shape[0]):
        e += vol[i] * energy_density(model, lam, mu, F[i, 0, 0], F[i, 0, 1], F[i, 1, 0],
                                     F[i, 1, 1])
    return e


def cauchy_stress(F, P):
    """sigma = P F^T / J for every particle (numpy; used for output only)."""
    J = np.linalg.det(F)
    return np.einsum("nij,nkj->nik", P, F) / J[:, None, None]


# ---------------------------------------------------------------------------------------------
# Energy-conserving hourglass control (PHYSICS.md §4, "hourglass control"): the exact gradient
# of the penalty energy
#   Phi = (c/4) sum_a sum_b wt_ab |eps_ab|^2,  eps_ab = F_a X_ab - x_ab,
#   wt_ab = V_a V_b W_ab / |X_ab|^2,  X_ab = X_b - X_a,  x_ab = x_b - x_a,  c = alpha_HG E.
# Phi vanishes for any affine motion (F_a X_ab = x_ab), so only non-affine (hourglass) modes
# pay, like Ganzenmueller's (2015) penalty; unlike it, the force -dPhi/dx conserves energy.
# With F_a = sum_m V_m (x_m - x_a) (x) gi_am and G_a = sum_m V_m gi_am, the force on k is
#   f_k = -(c/2) sum_{a in N(k)} [ V_k H_a gi_ak + wt_ka eps_ka (1 - G_k . X_ka) - wt_ka eps_ak ]
# with H_a = sum_b wt_ab eps_ab (x) X_ab, and gi_ak = -gj of the pair (k, a).


@njit(cache=True, parallel=True)
def hourglass_moments(x, x0, vol, F, nbr_start, nbr_j, w, out_H):
    """``H_a = sum_b wt_ab eps_ab (x) X_ab`` for every particle (see the block comment)."""
    for a in prange(x.shape[0]):
        h00 = 0.0
        h01 = 0.0
        h10 = 0.0
        h11 = 0.0
        for k in range(nbr_start[a], nbr_start[a + 1]):
            b = nbr_j[k]
            X0 = x0[b, 0] - x0[a, 0]
            X1 = x0[b, 1] - x0[a, 1]
            wt = vol[a] * vol[b] * w[k] / (X0 * X0 + X1 * X1)
            e0 = F[a, 0, 0] * X0 + F[a, 0, 1] * X1 - (x[b, 0] - x[a, 0])
            e1 = F[a, 1, 0] * X0 + F[a, 1, 1] * X1 - (x[b, 1] - x[a, 1])
            h00 += wt * e0 * X0
            h01 += wt * e0 * X1
            h10 += wt * e1 * X0
            h11 += wt * e1 * X1
        out_H[a, 0, 0] = h00
        out_H[a, 0, 1] = h01
        out_H[a, 1, 0] = h10
        out_H[a, 1, 1] = h11


@njit(cache=True, parallel=True)
def hourglass_conservative(x, x0, vol, m, F, H, G, nbr_start, nbr_j, gj, w, c, out_a):
    """Add the energy-conserving hourglass acceleration ``f_k / m_k`` to ``out_a``."""
    for k in prange(x.shape[0]):
        f0 = 0.0
        f1 = 0.0
        for p in range(nbr_start[k], nbr_start[k + 1]):
            a = nbr_j[p]
            X0 = x0[a, 0] - x0[k, 0]  # X_ka
            X1 = x0[a, 1] - x0[k, 1]
            d0 = x[a, 0] - x[k, 0]  # x_ka
            d1 = x[a, 1] - x[k, 1]
            wt = vol[k] * vol[a] * w[p] / (X0 * X0 + X1 * X1)
            # V_k H_a gi_ak with gi_ak = -gj[p]
            f0 -= vol[k] * (H[a, 0, 0] * gj[p, 0] + H[a, 0, 1] * gj[p, 1])
            f1 -= vol[k] * (H[a, 1, 0] * gj[p, 0] + H[a, 1, 1] * gj[p, 1])
            # wt eps_ka (1 - G_k . X_ka)
            s = 1.0 - (G[k, 0] * X0 + G[k, 1] * X1)
            f0 += wt * (F[k, 0, 0] * X0 + F[k, 0, 1] * X1 - d0) * s
            f1 += wt * (F[k, 1, 0] * X0 + F[k, 1, 1] * X1 - d1) * s
            # - wt eps_ak, eps_ak = F_a X_ak - x_ak = -(F_a X_ka - x_ka)
            f0 += wt * (F[a, 0, 0] * X0 + F[a, 0, 1] * X1 - d0)
            f1 += wt * (F[a, 1, 0] * X0 + F[a, 1, 1] * X1 - d1)
        out_a[k, 0] -= 0.5 * c * f0 / m[k]
        out_a[k, 1] -= 0.5 * c * f1 / m[k]


@njit(cache=True)
def hourglass_energy(x, x0, vol, F, nbr_start, nbr_j, w, c):
    """The penalty energy Phi (J per metre of depth; serial, fixed summation order)."""
    e = 0.0
    for a in range(x.shape[0]):
        for k in range(nbr_start[a], nbr_start[a + 1]):
            b = nbr_j[k]
            X0 = x0[b, 0] - x0[a, 0]
            X1 = x0[b, 1] - x0[a, 1]
            wt = vol[a] * vol[b] * w[k] / (X0 * X0 + X1 * X1)
            e0 = F[a, 0, 0] * X0 + F[a, 0, 1] * X1 - (x[b, 0] - x[a, 0])
            e1 = F[a, 1, 0] * X0 + F[a, 1, 1] * X1 - (x[b, 1] - x[a, 1])
            e += wt * (e0 * e0 + e1 * e1)
    return 0.25 * c * e
