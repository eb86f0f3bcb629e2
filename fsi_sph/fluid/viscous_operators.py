"""The viscous operators of the intermediate velocity (module docstring of
:mod:`fsi_sph.fluid.viscous`): the Morris pair coefficients [F 11-12] and their local
normalisation, the implicit step's sparse matrix with no-slip mirror walls, and the
transposed stress term of the ``stress`` operator by nested corrected gradients [F 7,
F 13-14]. Numba loops are gather-only."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit, prange

from fsi_sph.fluid import _kernels as K
from fsi_sph.sph.kernels import kernel_dw, kernel_w, pair_offset_sq


@njit(cache=True)
def pair_coefficients(x, vol, nu, nbr_start, nbr_j, nf, h, kind, eta2, out_c):
    """Morris coefficient ``c_ij = -V_j (nu_i + nu_j) r dW/dr / (r^2 + eta^2)`` of every pair
    of the fluid rows' CSR list (``out_c`` aligned with ``nbr_j``)."""
    for i in range(nf):
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j, d0, d1, r2, r = pair_offset_sq(x, x, nbr_j, i, k)
            if r < 1e-12 * h:
                out_c[k] = 0.0
                continue
            out_c[k] = -vol[j] * (nu[i] + nu[j]) * r * kernel_dw(kind, r, h) / (r2 + eta2)


@njit(cache=True)
def local_lap_scales(x, vol, nbr_start, nbr_j, nf, h, kind, eta2, divr, divr_full, lap_scale,
                     out):
    """Per-particle normalisation ``4 / sum_j c_ij r_ij^2`` of the Morris operator [F 11-12]
    (``c_ij`` without the viscosity) on the particles' own arrangement; ``lap_scale`` (the
    square lattice's) where the support is truncated (``divr < divr_full``)."""
    for i in range(nf):
        if divr[i] < divr_full:
            out[i] = lap_scale
            continue
        m = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j, d0, d1, r2, r = pair_offset_sq(x, x, nbr_j, i, k)
            if r < 1e-12 * h:
                continue
            m -= 2.0 * vol[j] * r * kernel_dw(kind, r, h) * r2 / (r2 + eta2)
        out[i] = 4.0 / m


@njit(cache=True)
def pair_gradient_weights(x, vol, L, nbr_start, nbr_j, nf, h, kind, out_g):
    """``out_g[k] = V_j L_i grad W_ij`` of every pair ``k = (i, j)`` of the fluid rows' CSR
    list: the weights of the corrected consistent gradient [F 7, F 13-14],
    ``grad phi_i = sum_j out_g[k] (phi_j - phi_i)``."""
    for i in range(nf):
        for k in range(nbr_start[i], nbr_start[i + 1]):
            out_g[k, 0], out_g[k, 1] = K.corrected_pair_gradient(x, vol, L, i, nbr_j[k], h,
                                                                 kind)


@njit(cache=True, parallel=True)
def transpose_stress_divergence(x, vol, tau, fstart, fj, col_of, Lf, nf, h, kind, out):
    """Divergence of the transposed viscous stress, the part of ``div(2 eta D)`` that the
    Morris form ``div(eta grad u)`` leaves out (module docstring):
    ``out_i[k] = sum_l d/dx_l tau[k, l]`` with ``tau_i[k, l] = nu_i d u_l / d x_k`` given per
    fluid particle, by the corrected consistent divergence over the fluid neighbours
    (``fstart, fj``: fluid-only CSR lists, periodic images folded onto their original by
    ``col_of``; ``Lf`` the correction matrices of those lists) [F 7, F 13-14]. Gather only."""
    for i in prange(nf):
        a0 = 0.0
        a1 = 0.0
        for k in range(fstart[i], fstart[i + 1]):
            j = fj[k]
            c = col_of[j]
            g0, g1 = K.corrected_pair_gradient(x, vol, Lf, i, j, h, kind)
            a0 += (tau[c, 0, 0] - tau[i, 0, 0]) * g0 + (tau[c, 0, 1] - tau[i, 0, 1]) * g1
            a1 += (tau[c, 1, 0] - tau[i, 1, 0]) * g0 + (tau[c, 1, 1] - tau[i, 1, 1]) * g1
        out[i, 0] = a0
        out[i, 1] = a1


def fluid_lists(nbr_start, nbr_j, col_of):
    """The fluid-only part of a fluid rows' CSR list (sources with ``col_of >= 0``: fluid
    particles and their periodic images), :func:`_kernels.fluid_sublists` on every row."""
    nf = len(nbr_start) - 1
    start = np.empty(nf + 1, dtype=np.int64)
    j = K.fluid_sublists(nbr_start, nbr_j, col_of, np.ones(nf, dtype=np.bool_), start)
    return start, j


def transpose_operator(x, vol, nu, L, nbr_start, nbr_j, nf, h, kind, col_of, v, mirror=None):
    """Matrix form of :func:`transpose_stress_divergence` with ``tau_i[k, l] = nu_i d u_l /
    d x_k`` from the corrected gradient [F 7, F 13-14] over all neighbours (``L`` their
    correction matrices; boundary velocities ``v[j]`` known, or the no-slip mirror
    ``target - S u``): ``div tau = B U + e`` with ``U = [u_x; u_y]`` (2 nf) and ``B`` the
    2 x 2 block operator ``B_kl = Dv_l diag(nu) G_k`` (``G_k``: d/dx_k of a fluid field,
    ``Dv_l``: the outer corrected divergence over fluid neighbours). Returns ``(B, e)``,
    ``B`` a :class:`TransposeTerm` (its products by the factors; ``B.tocsr()`` the matrix)."""
    nb = len(x) - nf
    g = np.empty((len(nbr_j), 2))
    pair_gradient_weights(x, vol, L, nbr_start, nbr_j, nf, h, kind, g)
    rows = np.repeat(np.arange(nf), np.diff(nbr_start))
    cols = col_of[nbr_j]
    inner = cols >= 0
    wall = ~inner
    fstart, fj = fluid_lists(nbr_start, nbr_j, col_of)
    Lf = np.empty((nf, 2, 2))
    K.correction_matrices(x, vol, fstart, fj, h, kind, Lf)
    gf = np.empty((len(fj), 2))
    pair_gradient_weights(x, vol, Lf, fstart, fj, nf, h, kind, gf)
    frows = np.repeat(np.arange(nf), np.diff(fstart))
    ar = np.arange(nf)
    G, Dv, const = [], [], []
    for k in range(2):
        Gk = sp.csr_array((np.concatenate([g[inner, k], -np.bincount(rows, g[:, k], nf)]),
                           (np.concatenate([rows[inner], ar]),
                            np.concatenate([cols[inner], ar]))), shape=(nf, nf))
        Gb = sp.csr_array((g[wall, k], (rows[wall], nbr_j[wall] - nf)), shape=(nf, nb))
        if mirror is not None:
            S, target = mirror
            Gk = Gk - Gb @ S
            const.append(Gb @ target)
        else:
            const.append(Gb @ v[nf:])
        G.append(sp.csr_array(Gk))
        Dv.append(sp.csr_array((np.concatenate([gf[:, k], -np.bincount(frows, gf[:, k], nf)]),
                                (np.concatenate([frows, ar]),
                                 np.concatenate([col_of[fj], ar]))), shape=(nf, nf)))
    e = np.column_stack([sum(Dv[l] @ (nu * const[k][:, l]) for l in range(2))
                         for k in range(2)])
    return TransposeTerm(G, Dv, nu), e


class TransposeTerm:
    """``B = [[B_00, B_01], [B_10, B_11]]``, ``B_kl = Dv_l diag(nu) G_k`` (a two-ring
    stencil, about 120 entries per row), kept as its factors: ``B @ U`` costs about what
    the assembled matrix's product costs, and the sparse products that assemble it (85 ms
    per step at 3 250 particles, a third of the mu(I) step) are saved. ``tocsr()`` builds
    the matrix (for the direct solve and the tests)."""

    def __init__(self, G, Dv, nu):
        self.G, self.Dv, self.nu = G, Dv, nu
        self.n = len(nu)
        self.shape = (2 * self.n, 2 * self.n)

    def __matmul__(self, U):
        n = self.n
        u = (U[:n], U[n:])
        out = np.empty(2 * n)
        for k in range(2):
            out[k * n:(k + 1) * n] = sum(self.Dv[l] @ (self.nu * (self.G[k] @ u[l]))
                                         for l in range(2))
        return out

    def tocsr(self):
        N = sp.diags_array(self.nu)
        return sp.block_array([[self.Dv[l] @ N @ self.G[k] for l in range(2)]
                               for k in range(2)], format="csr")


def assemble(x, vol, nu, v, nbr_start, nbr_j, nf, h, kind, eta2, dt, col_of, mirror=None):
    """``A`` (nf x nf, CSR) and the boundary part of the right-hand side,
    ``dt sum_w c_iw u_w`` (nf, 2), of the implicit viscous step (module docstring).

    ``x, vol, nu, v``: stacked (fluid, then boundary) arrays; ``col_of[j]``: unknown of
    source ``j`` (``j`` itself for fluid, the original for a periodic image, -1 for a
    boundary particle of known velocity ``v[j]``).

    ``mirror = (S, target)`` (from :func:`wall_mirror`): the boundary velocities are the
    no-slip mirror ``u_w = target_w - S_w u`` of the unknown fluid velocities (rows of ``S``
    and ``target`` by boundary row ``j - nf``); ``A`` gains ``dt C_w S`` and is no longer
    symmetric, and the right-hand side part is ``dt C_w target``."""
    c = np.empty(len(nbr_j))
    pair_coefficients(x, vol, nu, nbr_start, nbr_j, nf, h, kind, eta2, c)
    rows = np.repeat(np.arange(nf), np.diff(nbr_start))
    cols = col_of[nbr_j]
    diag = 1.0 + dt * np.bincount(rows, weights=c, minlength=nf)
    inner = cols >= 0
    A = sp.csr_array((np.concatenate([diag, -dt * c[inner]]),
                      (np.concatenate([np.arange(nf), rows[inner]]),
                       np.concatenate([np.arange(nf), cols[inner]]))), shape=(nf, nf))
    A.sum_duplicates()
    wall = ~inner
    b_wall = np.zeros((nf, 2))
    if mirror is None:
        for k in range(2):
            b_wall[:, k] = dt * np.bincount(rows[wall], weights=c[wall] * v[nbr_j[wall], k],
                                            minlength=nf)
        return A, b_wall
    S, target = mirror
    Cw = sp.csr_array((c[wall], (rows[wall], nbr_j[wall] - nf)), shape=(nf, S.shape[0]))
    A = sp.csr_array(A + dt * (Cw @ S))
    b_wall = dt * (Cw @ target)
    return A, b_wall


def wall_target(S, v_wall, has=None):
    """``target_w = 2 v_w`` where wall ``w`` has fluid neighbours, else ``v_w``."""
    if has is None:
        has = np.diff(S.indptr) > 0
    return np.where(has[:, None], 2.0, 1.0) * v_wall


def kernel_w_array(r, h, kind):
    out = np.empty(len(r))
    _kernel_w_loop(r, h, kind, out)
    return out


@njit(cache=True)
def _kernel_w_loop(r, h, kind, out):
    for k in range(len(r)):
        out[k] = kernel_w(kind, r[k], h)
