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
the wall velocity: normal to the wall (``n_w``) the wall's predicted velocity of the PPE,
``u_w + dt ((g - a_w) . n_w) n_w``, so that a fluid at rest under a gravity normal to the
wall again gets exactly ``u* = dt g``; along the wall its own velocity ``u_w``. (Mirroring
about the whole ``u_w + dt g`` makes a bed under a tilted gravity slide at ``dt g_t``,
which, times the wall coupling rate ``sum_w c_iw ~ 1/dt`` of a mu(I) material, was a bed
force of twice gravity on the first row of the Bagnold case.)
is a sparse system ``A u* = b`` for each velocity component, ``A = I + dt (D - C)``,
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
from numba import njit

from fsi_sph.fluid import _kernels as K
from fsi_sph.sph.kernels import kernel_dw, kernel_w


@dataclass
class ViscousStats:
    """One implicit viscous solve: CG iterations (sum over both components), largest final
    relative residual, wall time (s)."""

    iterations: int = 0
    residual: float = 0.0
    time: float = 0.0


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
    ml = pyamg.smoothed_aggregation_solver(A, symmetry="symmetric" if sym else "nonsymmetric",
                                           max_coarse=50)
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
    col_of = np.full(len(fluid.x_all), -1, dtype=np.int64)
    col_of[:nf] = np.arange(nf)
    if fluid.periodic is not None:
        rows, src = fluid.periodic.fluid_images()
        col_of[rows] = src
    mirror = None
    wall_rows = col_of[nf:] < 0  # boundary rows of known velocity (not periodic images)
    if law.kind != "newtonian" and wall_rows.any():
        mirror = wall_mirror(fluid, col_of)
        S, target = mirror
        u_w = target - S @ b["v"]
        fluid.v_all[nf:][wall_rows] = u_w[wall_rows]  # strain rate and explicit operator
    if law.needs_gradients:
        fluid._gradients()
        law.update(fluid.grad_v, b["p"], b["nu"])
    else:
        b["nu"][:] = law.nu0
    fluid.nu_all[:nf] = b["nu"]
    if fluid.periodic is not None:
        fluid.periodic.sync(fluid)  # the images' viscosity
    if fluid.n_walls and law.kind != "newtonian":
        wall_viscosity(fluid)
    fluid.v_old[:] = b["v"]
    g = fluid.gravity
    # The Morris operator with the lattice normalisation of the PPE (docs/fluid.md): on a
    # regular lattice its second moment is 3.92 instead of 4 (h = 1.2 dx), i.e. the viscous
    # stress 2 % low. For a Newtonian fluid that is a 2 % viscosity error; for the mu(I) law
    # the flow makes up for it with a 2 % larger friction coefficient, and near mu_s that is
    # a ~20 % larger inertial number (dI/I ~ 9 dmu/mu on the Bagnold case). Scaling nu
    # (the operator is linear in it) keeps the plain Newtonian path as it was.
    nu_op = fluid.nu_all * fluid.lap_scale if law.kind != "newtonian" else fluid.nu_all
    if fluid.cfg.viscous_step == "implicit":
        if mirror is not None:
            # the walls are mirrored about their predicted velocity: normal to the wall
            # u_w + dt (g - a_w) . n n, the u*_w of the PPE (module docstring); along the
            # wall their own velocity (no slip)
            S, target = mirror
            n = fluid.wall_n
            gn = np.einsum("ij,ij->i", fluid.g_b, n)[:, None] * n
            no_normal = ~n.any(axis=1)
            gn[no_normal] = fluid.g_b[no_normal]
            target = wall_target(S, fluid.v_b + dt * gn)
            mirror = (S, target)
            A, b_wall = assemble(fluid.x_all, fluid.vol_all, nu_op, fluid.v_all,
                                 fluid.ff_start, fluid.ff_j, nf, fluid.h, fluid.kernel,
                                 fluid.eta2, dt, col_of, mirror)
            u, fluid.viscous_stats = solve(A, fluid.v_old + dt * g + b_wall, fluid.v_old,
                                           fluid.cfg.viscous_rtol)
            fluid.v_star[:] = u
        else:
            A, b_wall = assemble(fluid.x_all, fluid.vol_all, fluid.nu_all, fluid.v_all,
                                 fluid.ff_start, fluid.ff_j, nf, fluid.h, fluid.kernel,
                                 fluid.eta2, dt, col_of)
            # walls at their own velocity: the body force is added after the solve (a
            # split step), so that a fluid at rest gets exactly u* = dt g, which the
            # projection removes against the walls' u*_w = dt g of the PPE
            u, fluid.viscous_stats = solve(A, fluid.v_old + b_wall, fluid.v_old,
                                           fluid.cfg.viscous_rtol)
            fluid.v_star[:] = u + dt * g
    else:
        K.predict_velocity(fluid.x_all, fluid.v_all, fluid.vol_all, nu_op,
                           fluid.ff_start, fluid.ff_j, nf, fluid.h, fluid.kernel, fluid.eta2,
                           g[0], g[1], dt, fluid.v_star)
    fluid.v_all[nf:] = fluid.v_b  # what the projection sees: the walls' own velocity


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
