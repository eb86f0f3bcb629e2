"""The viscous part of the intermediate velocity [F 16], explicit or implicit.

Explicit (the default, :func:`fsi_sph.fluid._kernels.predict_velocity`)::

    u*_i = u_i + dt (sum_j c_ij (u_j - u_i) + g),
    c_ij = -V_j (nu_i + nu_j) r_ij dW/dr / (r_ij^2 + eta^2)   (Morris [F 11-12], c_ij >= 0)

is stable only for ``dt <= 0.125 h^2 / nu_max`` [F 48], which the large apparent viscosity of
the mu(I) law (PHYSICS.md §7) makes prohibitive. Implicit (backward Euler) with the same
Morris operator and the same neighbours, then the body force::

    u**_i - dt sum_j c_ij (u**_j - u**_i) = u_i,      u*_i = u**_i + dt g

(the body force outside the solve, so that a fluid at rest gets exactly ``u* = dt g``, like
the explicit form, which the projection removes against the walls' ``u*_w = dt g``; with
``g`` inside the solve and walls at rest the no-slip walls would drag the gravity increment
and a layer at rest would not stay at rest).

For the non-Newtonian laws the walls are no-slip mirrors (:func:`wall_mirror`, Adami et
al. 2012) and the body force is inside the solve::

    u*_i - dt sum_j c_ij (u*_j - u*_i) = u_i + dt g,   u*_w = 2 ubar_w - <u*>_w

with ``<u*>_w`` the Shepard average of the fluid around wall particle ``w`` and ``ubar_w``
the wall's predicted intermediate velocity, the boundary condition of ``u*`` in a projection
method (Kim & Moin 1985; Brown, Cortez & Minion 2001): ``ubar_w = u_w + dt grad p^n / rho``,
``u_w`` the wall's own velocity and ``grad p^n / rho`` the fluid's pressure acceleration of
the previous step (the correction step's operator) Shepard-averaged at the wall. Where the
fluid is at rest that is ``dt g`` on every wall, bed and side walls alike, and the fluid gets
exactly ``u* = dt g``, which the projection removes; on an inclined bed under a flowing
layer it is ``dt g_n`` normal to the bed (the layer's pressure is hydrostatic in depth), so
the bed does not slide at ``dt g_t``. (Before: ``u_w + dt ((g - a_w) . n_w) n_w``, the
normal part of gravity only. Along a vertical side wall that mirrored ``u_w = 0`` and the
no-slip wall dragged the gravity increment of the fluid beside it every step; the
projection then pushed that fluid up the wall: a mu(I) wedge at 15 deg, below its repose
angle, crept with the material rising along the wall at 0.014 m/s, and the pressure beside
the wall fell to ~0.6 of hydrostatic. docs/mui_notes_2026-11-30.md.)

Incremental projection (``fluid.projection = "incremental"``, Goda 1979; isph.py): the
lagged pressure acceleration joins the body force on the right-hand side of the solve,
``u*_i - dt sum_j c_ij (u*_j - u*_i) = u_i + dt (g - grad p^n_i / rho)``, so the frictional
viscosity resists the pressure push in the same step, and the walls are mirrored about their
own velocity, ``ubar_w = u_w``: the wall's intermediate velocity is ``u_w + dt grad phi /
rho`` (Kim & Moin 1985), the projection taking back only the increment ``phi``, which the
walls' extrapolated pressure rows keep free of the hydrostatic part (a fixed wall's row for
``phi`` has no g term; a fluid at rest has ``phi = 0`` and ``u* = 0`` beside the walls). The
target ``u_w + dt grad p^n / rho`` of the standard form would be wrong here: the fluid's
``u*`` no longer holds the hydrostatic ``dt g`` that it matched. The PPE's divergence sees
the same ``u*_w = u_w`` (isph.py, ``solve_pressure``).

The ``stress`` operator (``viscous_operator = "stress"``) adds the divergence of the
transposed stress, so that the viscous term is ``div(2 eta D) / rho`` and not the Morris
``div(eta grad u) / rho``; for an incompressible flow they differ by ``div(eta (grad u)^T)
= (grad u)^T . grad eta``, i.e. wherever ``eta`` varies (in pure extension the Morris
stress is ``eta eps``, half of ``2 eta eps``). It is computed by nested corrected gradients
[F 7, F 13-14]: ``tau_i = nu_i (grad u)_i^T`` over all neighbours (walls mirrored), then
its corrected divergence over the fluid neighbours (:func:`transpose_stress_divergence`,
gather only). Implicitly the term couples the two velocity components and reaches two
neighbour rings: one sparse system for ``[u_x; u_y]``, ``(blockdiag(A, A) - dt B) U = b``
(:func:`transpose_operator`), solved by a sparse LU. (A pairwise form ``sum c_ij ((u_j -
u_i) . e) e``, which is exact for a divergence-free field with varying ``eta`` in the
continuum, was rejected: on a square lattice its shear and extension responses are 0.79 and
1.55 of the exact ones.)

For the Morris part the implicit step is a sparse system ``A u* = b`` for each velocity
component, ``A = I + dt (D - C)``,
``D_ii = sum_j c_ij`` over all neighbours, ``C_ij = c_ij`` over fluid neighbours. Boundary
(wall) neighbours carry their known velocity ``u_w`` (no slip): ``b_i += dt sum_w c_iw u_w``.
Periodic images of fluid particles (``col_of[j] >= 0`` for ``j >= nf``) are folded onto the
column of their original. With equal volumes ``c_ij = c_ji``, so ``A`` is symmetric and
strictly diagonally dominant with a positive diagonal: symmetric positive definite. It is
solved by conjugate gradients preconditioned by a pyamg smoothed-aggregation hierarchy (one
hierarchy for both components), warm-started from ``u^n``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import pyamg
import scipy.sparse as sp
from numba import njit, prange

from fsi_sph.fluid import _kernels as K
from fsi_sph.fluid import amg
from fsi_sph.fluid.isph import DIVR_FULL
from fsi_sph.sph.kernels import kernel_dw, kernel_w


@dataclass
class ViscousStats:
    """One implicit viscous solve: CG iterations (sum over both components), largest final
    relative residual, wall time (s)."""

    iterations: int = 0
    residual: float = 0.0
    time: float = 0.0
    fallback: bool = False  # the stress operator's solve was replaced by the Morris one


@njit(cache=True)
def pair_coefficients(x, vol, nu, nbr_start, nbr_j, nf, h, kind, eta2, out_c):
    """Morris coefficient ``c_ij = -V_j (nu_i + nu_j) r dW/dr / (r^2 + eta^2)`` of every pair
    of the fluid rows' CSR list (``out_c`` aligned with ``nbr_j``)."""
    for i in range(nf):
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            d0 = x[i, 0] - x[j, 0]
            d1 = x[i, 1] - x[j, 1]
            r2 = d0 * d0 + d1 * d1
            r = math.sqrt(r2)
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
            j = nbr_j[k]
            d0 = x[i, 0] - x[j, 0]
            d1 = x[i, 1] - x[j, 1]
            r2 = d0 * d0 + d1 * d1
            r = math.sqrt(r2)
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


def wall_mirror(fluid, col_of):
    """No-slip velocity of the boundary particles for the viscous term (Adami et al. 2012):
    ``u_w = 2 v_w - sum_f W_wf u_f / sum_f W_wf`` over the fluid neighbours ``f`` of ``w``
    (``v_w`` the wall's own velocity), so that the velocity extrapolated through the wall
    vanishes at the wall and not a few wall layers deeper; ``u_w = v_w`` without fluid
    neighbours. Returns ``(S, target)``: ``u_w = target_w - S_w u`` with ``S`` (boundary
    rows x fluid unknowns, periodic images folded by ``col_of``)."""
    nf, nb = fluid.nf, len(fluid.x_all) - fluid.nf
    start, j = fluid.wf_start, fluid.wf_j
    rows = np.repeat(np.arange(nb), np.diff(start))
    d = fluid.x_all[nf + rows] - fluid.x_all[j]
    w = kernel_w_array(np.hypot(d[:, 0], d[:, 1]), fluid.h, fluid.kernel)
    sw = np.bincount(rows, weights=w, minlength=nb)
    has = sw > 0.0
    wt = w / np.where(sw > 0.0, sw, 1.0)[rows]
    S = sp.csr_array((wt, (rows, col_of[j])), shape=(nb, nf))
    S.sum_duplicates()
    return S, wall_target(S, fluid.v_b, has)


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


def solve(A, rhs, x0, rtol):
    """Solve ``A u = rhs`` column by column (CG + smoothed-aggregation AMG); returns
    ``(u, ViscousStats)``."""
    t0 = time.perf_counter()
    n = A.shape[0]
    out = np.empty_like(rhs)
    stats = ViscousStats()
    if n == 0:
        return out, stats
    A = sp.csr_matrix(A)
    A.indices = A.indices.astype(np.int32)
    A.indptr = A.indptr.astype(np.int32)
    sym = abs(A - A.T).max() <= 1e-12 * abs(A).max()
    accel = "cg" if sym else "bicgstab"
    ml = amg.seeded_build(pyamg.smoothed_aggregation_solver, A,
                          symmetry="symmetric" if sym else "nonsymmetric", max_coarse=50)
    for k in range(rhs.shape[1]):
        b = np.ascontiguousarray(rhs[:, k])
        res = []
        u = ml.solve(b, x0=np.ascontiguousarray(x0[:, k]), tol=rtol, accel=accel, maxiter=200,
                     residuals=res)
        nb = np.linalg.norm(b)
        rel = float(np.linalg.norm(b - A @ u) / nb) if nb > 0 else 0.0
        if not rel <= 10.0 * rtol:  # not converged: a direct solve, so the step stays right
            from scipy.sparse.linalg import spsolve

            u = spsolve(A.tocsc(), b)
            rel = float(np.linalg.norm(b - A @ u) / nb) if nb > 0 else 0.0
        out[:, k] = u
        stats.iterations += max(len(res) - 1, 0)
        stats.residual = max(stats.residual, rel)
    stats.time = time.perf_counter() - t0
    return out, stats


def predict(fluid, dt):
    """[F 16] for a fluid with a non-Newtonian law or the implicit viscous step: the
    viscosity from the law (velocity gradient and pressure of step n), then the
    intermediate velocity ``fluid.v_star``."""
    b = fluid.body
    nf = fluid.nf
    fluid._sync()
    law = fluid.viscosity_law
    g = fluid.gravity
    # body force of the solve: g, or g - grad p^n / rho with the incremental projection
    force = g - fluid.lagged_pressure_acceleration() if fluid.incremental_step else g
    col_of = fluid.fluid_of  # the unknown of each stacked row (-1: known boundary velocity)
    mirror = None
    wall_rows = col_of[nf:] < 0  # boundary rows of known velocity (not periodic images)
    if law.kind != "newtonian" and wall_rows.any():
        mirror = wall_mirror(fluid, col_of)
        S, target = mirror
        u_w = target - S @ b["v"]
        fluid.v_all[nf:][wall_rows] = u_w[wall_rows]  # strain rate and explicit operator
    stress = fluid.cfg.viscous_operator == "stress"
    if law.needs_gradients or stress:
        fluid._gradients()  # (L and grad u with the mirrored wall velocities)
    if law.needs_gradients:
        law.update(fluid.grad_v, b["p"], b["nu"])
    else:
        b["nu"][:] = law.nu0
    fluid.nu_all[:nf] = b["nu"]
    if fluid.periodic is not None:
        fluid.periodic.sync(fluid)  # the images' viscosity
    if fluid.n_walls and law.kind != "newtonian":
        wall_viscosity(fluid)
    fluid.v_old[:] = b["v"]
    nu_op = morris_viscosity(fluid) if law.kind != "newtonian" else fluid.nu_all
    if fluid.cfg.viscous_step == "implicit":
        if mirror is not None:
            # the walls are mirrored about their predicted intermediate velocity, the
            # boundary condition of u* in a projection method (Kim & Moin 1985; Brown,
            # Cortez & Minion 2001): u*_w = u_w + dt grad p^n / rho, with grad p^n / rho
            # the fluid's lagged pressure acceleration averaged at the wall (module
            # docstring). Along a side wall of a column at rest that is dt g, the gravity
            # increment the fluid beside it gets, so the no-slip wall does not drag it.
            S, target = mirror
            # (Tried and dropped: the PPE's (g - a_w) . n normal to the wall with the lagged
            # pressure acceleration only along it, with or without a bound on the latter:
            # the a = 2 collapse blew up at 0.49 s when its front reached the end wall, the
            # a = 8 column threw a particle 3.7 m high over the end wall.)
            # Incremental projection: the walls' own velocity (module docstring).
            v_target = (fluid.v_b if fluid.incremental_step else
                        fluid.v_b + dt * wall_pressure_acceleration(fluid, col_of))
            mirror = (S, wall_target(S, v_target))
            A, b_wall = assemble(fluid.x_all, fluid.vol_all, nu_op, fluid.v_all,
                                 fluid.ff_start, fluid.ff_j, nf, fluid.h, fluid.kernel,
                                 fluid.eta2, dt, col_of, mirror)
            u, fluid.viscous_stats = _solve_step(fluid, A, fluid.v_old + dt * force + b_wall,
                                                 dt, col_of, mirror, stress)
            fluid.v_star[:] = u
        else:
            A, b_wall = assemble(fluid.x_all, fluid.vol_all, fluid.nu_all, fluid.v_all,
                                 fluid.ff_start, fluid.ff_j, nf, fluid.h, fluid.kernel,
                                 fluid.eta2, dt, col_of)
            # walls at their own velocity: the body force is added after the solve (a
            # split step), so that a fluid at rest gets exactly u* = dt g, which the
            # projection removes against the walls' u*_w = dt g of the PPE. Incremental:
            # g - grad p^n / rho inside the solve (~0 at rest, walls' u*_w = u_w).
            inside = dt * force if fluid.incremental_step else 0.0
            u, fluid.viscous_stats = _solve_step(fluid, A, fluid.v_old + inside + b_wall, dt,
                                                 col_of, None, stress)
            fluid.v_star[:] = u if fluid.incremental_step else u + dt * g
    else:
        K.predict_velocity(fluid.x_all, fluid.v_all, fluid.vol_all, nu_op,
                           fluid.ff_start, fluid.ff_j, nf, fluid.h, fluid.kernel, fluid.eta2,
                           g[0], g[1], dt, fluid.v_star)
        if fluid.incremental_step:  # [Goda 1979]: - dt grad p^n / rho
            fluid.v_star += dt * (force - g)
        if stress:  # the transposed part of div(2 eta D), explicit like the rest
            fluid.v_star += dt * explicit_transpose_term(fluid, col_of)
    fluid.v_all[nf:] = fluid.v_b  # what the projection sees: the walls' own velocity


def morris_viscosity(fluid):
    """``nu_i s_i`` for the Morris operator of a non-Newtonian law, ``s_i`` the particle's own
    normalisation ``4 / sum_j c_ij r_ij^2`` (:func:`local_lap_scales`).

    The operator's second moment depends on the particle arrangement: the square lattice's
    is 3.92 instead of 4 (h = 1.2 dx; the PPE's ``lap_scale`` corrects that), and in a
    sheared layer, whose rows slide over each other, it is another 0.2-2.3 % above the
    lattice's (mean 1 %, measured on the Bagnold layer). For a Newtonian fluid that is a
    1 % viscosity error; for the mu(I) law near mu_s, where dI/I ~ 21 dmu, the flow makes up
    for a 1 % stronger operator with a ~20 % smaller inertial number: the Bagnold layer ran
    10-18 % slow with the lattice constant (docs/fluid.md). The pair coefficient
    ``(nu_i s_i + nu_j s_j)`` stays symmetric (momentum is conserved); particles with a
    truncated support (free surface) and boundary particles keep the lattice constant, so
    that the pairwise flux near a free surface is the interior one."""
    nf = fluid.nf
    sc = np.full(len(fluid.x_all), fluid.lap_scale)
    local_lap_scales(fluid.x_all, fluid.vol_all, fluid.ff_start, fluid.ff_j, nf, fluid.h,
                     fluid.kernel, fluid.eta2, fluid.body["divr"], DIVR_FULL, fluid.lap_scale,
                     sc)
    if fluid.periodic is not None:
        rows, src = fluid.periodic.fluid_images()
        sc[rows] = sc[src]
    return fluid.nu_all * sc


def _solve_step(fluid, A, rhs, dt, col_of, mirror, stress):
    """The implicit viscous solve: per component with the Morris matrix ``A``; with the
    ``stress`` operator one coupled system for ``U = [u_x; u_y]``,
    ``(blockdiag(A, A) - dt B) U = rhs + dt e`` (:func:`transpose_operator`)."""
    if not stress:
        return solve(A, rhs, fluid.v_old, fluid.cfg.viscous_rtol)
    nf = fluid.nf
    B, e = transpose_operator(fluid.x_all, fluid.vol_all, fluid.nu_all[:nf], fluid.L,
                              fluid.ff_start, fluid.ff_j, nf, fluid.h, fluid.kernel, col_of,
                              fluid.v_all, mirror)
    b = rhs + dt * e
    x0 = fluid.v_old.T.reshape(-1)
    if fluid.morris_pre is None:
        fluid.morris_pre = MorrisPreconditioner()
    u, stats = solve_coupled(A, CoupledMatrix(A, B, dt), b.T.reshape(-1), x0,
                             fluid.cfg.viscous_rtol, fluid.morris_pre)
    u = u.reshape(2, nf).T
    if amplifies(u, b):
        u, stats = solve(A, rhs, fluid.v_old, fluid.cfg.viscous_rtol)
        stats.fallback = True
    return u, stats


class CoupledMatrix:
    """``blockdiag(A, A) - dt B`` of the stress operator's step as products (``A`` the Morris
    matrix, ``B`` the transposed term, :class:`TransposeTerm` or a sparse matrix);
    ``tocsr()`` assembles it (direct solve)."""

    def __init__(self, A, B, dt):
        self.A, self.B, self.dt = A, B, dt
        self.n = A.shape[0]
        self.shape = (2 * self.n, 2 * self.n)
        self.dtype = np.dtype(np.float64)

    def __matmul__(self, U):
        n = self.n
        return np.concatenate([self.A @ U[:n], self.A @ U[n:]]) - self.dt * (self.B @ U)

    def tocsr(self):
        return sp.csr_array(sp.block_diag([self.A, self.A], format="csr")
                            - self.dt * self.B.tocsr())


#: the stress operator's solution may exceed the bound of the Morris one by this factor
AMPLIFICATION_LIMIT = 2.0


def amplifies(u, rhs):
    """True if the implicit stress-operator step ``u`` (nf, 2) has a component larger than
    ``AMPLIFICATION_LIMIT`` times the largest of the right-hand side ``rhs`` (nf, 2).

    The Morris matrix ``A = I + dt (D - C)`` is an M-matrix whose row sums are at least 1,
    so its solution obeys ``max_i |u_i,k| <= max_i |rhs_i,k|`` per component: viscosity
    only takes velocity away. The nested corrected gradients of the transposed term ``B``
    carry no such guarantee: on a lopsided support (a few particles left on the floor, the
    correction matrices up to ``1 / DET_MIN``) ``blockdiag(A, A) - dt B`` can be nearly
    singular, and at ``dt nu / dx^2 ~ 4-50`` its solution was 8 m/s for a right-hand side of
    0.03 m/s (a = 8 collapse, deposit at rest: a particle thrown at 45 m/s; session notes
    2026-12-01). Such a step is not a viscous step."""
    for k in range(2):
        bound = float(np.max(np.abs(rhs[:, k]))) if len(rhs) else 0.0
        if float(np.max(np.abs(u[:, k]), initial=0.0)) > AMPLIFICATION_LIMIT * bound + 1e-12:
            return True
    return False


def solve_coupled(A, A2, b, x0, rtol, pre=None):
    """The coupled system ``A2 U = b`` of the stress operator (a sparse matrix or a
    :class:`CoupledMatrix`) by flexible GMRES (:func:`amg.fgmres`), preconditioned by a
    smoothed-aggregation AMG V-cycle of the Morris matrix ``A`` on each velocity component
    (the block diagonal of ``A2``; the transposed part ``dt B`` it leaves out is of the same
    order but couples the components); ``pre`` a :class:`MorrisPreconditioner` that keeps
    the hierarchy across steps (None: a fresh one). A sparse LU (:func:`solve_direct`) if
    GMRES does not reach ``10 rtol`` in 200 iterations. Returns ``(u, ViscousStats)``."""
    t0 = time.perf_counter()
    n = A.shape[0]
    if n == 0:
        return np.zeros(0), ViscousStats()
    pre = MorrisPreconditioner() if pre is None else pre
    vc = pre.prepare(A)

    def apply(r):
        return np.concatenate([vc(r[:n]), vc(r[n:])])

    u, its, rel = amg.fgmres(_Operator(A2), np.ascontiguousarray(b, dtype=np.float64),
                             np.ascontiguousarray(x0, dtype=np.float64), apply, rtol, 200,
                             restart=50)
    pre.record(its)
    if not rel <= 10.0 * rtol:  # not converged: a direct solve, so the step stays right
        return solve_direct(A2 if sp.issparse(A2) else A2.tocsr(), b)
    stats = ViscousStats()
    stats.iterations = its
    stats.residual = rel
    stats.time = time.perf_counter() - t0
    return u, stats


class _Operator:
    """``matvec`` and ``residual`` of a sparse matrix or a :class:`CoupledMatrix` for
    :func:`amg.fgmres`."""

    def __init__(self, M):
        self.M = M
        self.shape = M.shape

    def matvec(self, x, out=None):
        y = self.M @ x
        if out is None:
            return y
        out[:] = y
        return out

    def residual(self, x, b, out):
        np.subtract(b, self.M @ x, out=out)
        return out


class MorrisPreconditioner:
    """The smoothed-aggregation hierarchy of the Morris matrix as a numba V-cycle
    (:class:`amg.VCycle`), kept across steps like the PPE's (:mod:`ppe`): each step its
    finest level is the step's matrix (``refresh_finest``), and the hierarchy is rebuilt
    every ``REBUILD_EVERY`` steps, when the GMRES iterations exceed ``GROWTH`` times those
    right after the last rebuild (plus 2), or when the number of unknowns changes. The
    set-up was 44 ms of a 160 ms mu(I) step at 3 250 particles."""

    REBUILD_EVERY = 10
    GROWTH = 1.5

    def __init__(self):
        self.vc = None
        self.age = 0
        self.base = None
        self.stale = False

    def prepare(self, A):
        """The V-cycle for this step's Morris matrix ``A``."""
        n = A.shape[0]
        if (self.vc is None or self.stale or self.age >= self.REBUILD_EVERY
                or self.vc.A[0].shape[0] != n):
            ml = amg.seeded_build(pyamg.smoothed_aggregation_solver, sp.csr_matrix(A),
                                  symmetry="nonsymmetric", max_coarse=50)
            self.vc = amg.VCycle(ml)
            self.age, self.base, self.stale = 0, None, False
        else:
            self.vc.refresh_finest(A)
            self.age += 1
        return self.vc

    def record(self, iterations):
        """The iterations of this step's solve (decides the next rebuild)."""
        if self.base is None:
            self.base = iterations
        self.stale = iterations > self.GROWTH * self.base + 2


def solve_direct(A, b):
    """Sparse LU (SuperLU) solve of the coupled system. Its nested operator reaches two
    neighbour rings and is not symmetric; there the smoothed-aggregation set-up of the
    AMG-Krylov path costs more per step than a direct factorisation at the sizes of the
    mu(I) cases (2 nf <= ~10^4 unknowns). Returns ``(u, ViscousStats)``."""
    from scipy.sparse.linalg import splu

    t0 = time.perf_counter()
    stats = ViscousStats()
    if A.shape[0] == 0:
        return np.zeros(0), stats
    u = splu(sp.csc_matrix(A)).solve(b)
    nb = np.linalg.norm(b)
    stats.residual = float(np.linalg.norm(b - A @ u) / nb) if nb > 0 else 0.0
    stats.time = time.perf_counter() - t0
    return u, stats


def wall_pressure_acceleration(fluid, col_of):
    """``grad p^n / rho`` at the boundary particles: the Shepard average over each boundary
    particle's fluid neighbours of the fluid's pressure acceleration of the previous step,
    with the operator of the correction step (``fluid.correct``: corrected [F 7, F 13] or
    conservative [F 10], walls' pressures included; periodic images carry their
    original's); 0 where a boundary particle has no fluid neighbour."""
    nf = fluid.nf
    gp = np.zeros((len(fluid.x_all), 2))
    fluid._pressure_gradient(fluid.p_all, gp[:nf])
    gp[:nf] /= fluid.rho
    fold = col_of >= 0
    gp[fold] = gp[:nf][col_of[fold]]
    xb = fluid.x_all[nf:]
    out = np.zeros((len(xb), 2))
    tmp = np.empty(len(xb))
    for k in range(2):
        K.shepard_at(xb, fluid.x_all, np.ascontiguousarray(gp[:, k]), fluid.wf_start,
                     fluid.wf_j, fluid.h, fluid.kernel, tmp)
        out[:, k] = np.where(np.isfinite(tmp), tmp, 0.0)
    return out


def explicit_transpose_term(fluid, col_of):
    """``(1/rho) div(eta (grad u)^T)`` of the fluid rows at ``u^n`` (mirrored walls), gather
    only: ``tau_i = nu_i (grad u_i)^T`` from the corrected gradient, then its corrected
    divergence over the fluid neighbours (:func:`transpose_stress_divergence`)."""
    nf = fluid.nf
    tau = fluid.nu_all[:nf, None, None] * np.transpose(fluid.grad_v, (0, 2, 1))
    fstart, fj = fluid_lists(fluid.ff_start, fluid.ff_j, col_of)
    Lf = np.empty((nf, 2, 2))
    K.correction_matrices(fluid.x_all, fluid.vol_all, fstart, fj, fluid.h, fluid.kernel, Lf)
    out = np.empty((nf, 2))
    transpose_stress_divergence(fluid.x_all, fluid.vol_all, np.ascontiguousarray(tau), fstart,
                                fj, col_of, Lf, nf, fluid.h, fluid.kernel, out)
    return out


def wall_viscosity(fluid):
    """Viscosity of the fixed wall particles, so that a no-slip wall shears the fluid
    beside it with the material's own law, as a mirrored fluid would (Morris et al. 1997
    give boundary particles the fluid's viscosity; with a constant wall value far below
    the apparent viscosity the pair term ``(nu_i + nu_w)`` halves the wall friction of a
    mu(I) material and the layer slips over a no-slip bed).

    mu(I): the law [G 35] at the wall particle, with the Shepard average of the fluid
    neighbours' strain rate and the wall particle's own pressure (Adami's extrapolation
    from the PPE, i.e. the pressure at the bed, below the first fluid row). Other laws:
    the Shepard average of the fluid neighbours' viscosity. A wall particle with no fluid
    neighbour keeps the material's ``nu``."""
    nf, nw = fluid.nf, fluid.n_walls
    law = fluid.viscosity_law
    out = np.empty(nw)
    xw = fluid.x_all[nf:nf + nw]
    if law.kind == "mu_i":
        gd = np.zeros(len(fluid.x_all))
        gd[:nf] = law.gdot
        if fluid.periodic is not None:
            rows, src = fluid.periodic.fluid_images()
            gd[rows] = gd[src]
        K.shepard_at(xw, fluid.x_all, gd, fluid.wf_start, fluid.wf_j, fluid.h, fluid.kernel,
                     out)
        ok = np.isfinite(out)
        out[ok] = law.mu_i_nu(out[ok], fluid.p_all[nf:nf + nw][ok])
    else:
        K.shepard_at(xw, fluid.x_all, fluid.nu_all, fluid.wf_start, fluid.wf_j, fluid.h,
                     fluid.kernel, out)
    out[~np.isfinite(out)] = law.nu0
    fluid.nu_all[nf:nf + nw] = out
    if fluid.periodic is not None:
        fluid.periodic.sync(fluid)  # and the wall images'
