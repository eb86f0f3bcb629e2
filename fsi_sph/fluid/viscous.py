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
the wall fell to ~0.6 of hydrostatic. docs/numerics/granular.md, "Walls of the viscous term".)

Incremental projection (``fluid.projection = "incremental"``, Goda 1979; increments.py): the
lagged pressure acceleration joins the body force on the right-hand side of the solve,
``u*_i - dt sum_j c_ij (u*_j - u*_i) = u_i + dt (g - grad p^n_i / rho)``, so the frictional
viscosity resists the pressure push in the same step, and the walls are mirrored about their
own velocity, ``ubar_w = u_w``: the wall's intermediate velocity is ``u_w + dt grad phi /
rho`` (Kim & Moin 1985), the projection taking back only the increment ``phi``, which the
walls' extrapolated pressure rows keep free of the hydrostatic part (a fixed wall's row for
``phi`` has no g term; a fluid at rest has ``phi = 0`` and ``u* = 0`` beside the walls). The
target ``u_w + dt grad p^n / rho`` of the standard form would be wrong here: the fluid's
``u*`` no longer holds the hydrostatic ``dt g`` that it matched. The PPE's divergence sees
the same ``u*_w = u_w`` (pressure_solve.py, ``PressureSolve.solve``).

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

import numpy as np
import scipy.sparse as sp

from fsi_sph.fluid import _kernels as K
from fsi_sph.fluid.lattice import DIVR_FULL
from fsi_sph.fluid.viscous_operators import (
    assemble,
    fluid_lists,
    kernel_w_array,
    local_lap_scales,
    transpose_operator,
    transpose_stress_divergence,
    wall_target,
)
from fsi_sph.fluid.viscous_solvers import MorrisPreconditioner, ViscousStats, solve_implicit


class ViscousStep:
    """The intermediate velocity of a fluid with a viscosity law (``fluid.material.
    viscosity``), the implicit step or the stress operator, over a particle set ``ps`` (row
    roles ``rows``, pressure gradient ``gradient``, pressure solve ``pressure``)."""

    def __init__(self, ps, rows, gradient, pressure, law):
        self.ps = ps
        self.rows = rows
        self.gradient = gradient
        self.pressure = pressure
        self.law = law  # the viscosity law (rheology.py)
        self.stats = ViscousStats()
        self.morris_pre = None  # the implicit stress step's AMG hierarchy (solve_step)
        self.implicit_solve = solve_implicit  # (replaced on several ranks)

    def at_snapshot(self):
        """A restart point: the kept AMG hierarchy is built anew at the next solve."""
        self.morris_pre = None

    def predict(self, dt):
        """[F 16] for a fluid with a non-Newtonian law or the implicit viscous step: the
        viscosity from the law (velocity gradient and pressure of step n), then the
        intermediate velocity ``ps.v_star``."""
        ps = self.ps
        b = ps.body
        nf = ps.nf
        ps.sync()
        law = self.law
        g = ps.gravity
        # body force of the solve: g, or g - grad p^n / rho with the incremental projection
        force = g - self.gradient.lagged_acceleration() if self.pressure.incremental_step else g
        col_of = self.rows.fluid_of  # the unknown of each stacked row (-1: known boundary velocity)
        mirror = None
        wall_rows = col_of[nf:] < 0  # boundary rows of known velocity (not periodic images)
        if law.kind != "newtonian" and wall_rows.any():
            mirror = self.wall_mirror(col_of)
            S, target = mirror
            u_w = target - S @ b["v"]
            ps.v_all[nf:][wall_rows] = u_w[wall_rows]  # strain rate and explicit operator
        stress = ps.cfg.viscous_operator == "stress"
        if law.needs_gradients or stress:
            ps.gradients()  # (L and grad u with the mirrored wall velocities)
        if law.needs_gradients:
            law.update(ps.grad_v, b["p"], b["nu"])
        else:
            b["nu"][:] = law.nu0
        ps.nu_all[:nf] = b["nu"]
        if ps.periodic is not None:
            ps.periodic.sync(ps)  # the images' viscosity
        if ps.n_walls and law.kind != "newtonian":
            self.wall_viscosity()
        ps.v_old[:] = b["v"]
        nu_op = self.morris_viscosity() if law.kind != "newtonian" else ps.nu_all
        if ps.cfg.viscous_step == "implicit":
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
                v_target = (ps.v_b if self.pressure.incremental_step else
                            ps.v_b + dt * self.wall_pressure_acceleration(col_of))
                mirror = (S, wall_target(S, v_target))
                A, b_wall = assemble(ps.x_all, ps.vol_all, nu_op, ps.v_all,
                                     ps.ff_start, ps.ff_j, nf, ps.h, ps.kernel,
                                     ps.eta2, dt, col_of, mirror)
                u, self.stats = self.solve_step(A, ps.v_old + dt * force + b_wall,
                                                dt, col_of, mirror, stress)
                ps.v_star[:] = u
            else:
                A, b_wall = assemble(ps.x_all, ps.vol_all, ps.nu_all, ps.v_all,
                                     ps.ff_start, ps.ff_j, nf, ps.h, ps.kernel,
                                     ps.eta2, dt, col_of)
                # walls at their own velocity: the body force is added after the solve (a
                # split step), so that a fluid at rest gets exactly u* = dt g, which the
                # projection removes against the walls' u*_w = dt g of the PPE. Incremental:
                # g - grad p^n / rho inside the solve (~0 at rest, walls' u*_w = u_w).
                inside = dt * force if self.pressure.incremental_step else 0.0
                u, self.stats = self.solve_step(A, ps.v_old + inside + b_wall, dt,
                                                col_of, None, stress)
                ps.v_star[:] = u if self.pressure.incremental_step else u + dt * g
        else:
            K.predict_velocity(ps.x_all, ps.v_all, ps.vol_all, nu_op,
                               ps.ff_start, ps.ff_j, nf, ps.h, ps.kernel, ps.eta2,
                               g[0], g[1], dt, ps.v_star)
            if self.pressure.incremental_step:  # [Goda 1979]: - dt grad p^n / rho
                ps.v_star += dt * (force - g)
            if stress:  # the transposed part of div(2 eta D), explicit like the rest
                ps.v_star += dt * self.explicit_transpose_term(col_of)
        ps.v_all[nf:] = ps.v_b  # what the projection sees: the walls' own velocity

    def morris_viscosity(self):
        """``nu_i s_i`` for the Morris operator of a non-Newtonian law, ``s_i`` the particle's own
        normalisation ``4 / sum_j c_ij r_ij^2`` (:func:`local_lap_scales`).

        The operator's second moment depends on the particle arrangement: the square lattice's
        is 3.92 instead of 4 (h = 1.2 dx; the PPE's ``lap_scale`` corrects that), and in a
        sheared layer, whose rows slide over each other, it is another 0.2-2.3 % above the
        lattice's (mean 1 %, measured on the Bagnold layer). For a Newtonian fluid that is a
        1 % viscosity error; for the mu(I) law near mu_s, where dI/I ~ 21 dmu, the flow makes up
        for a 1 % stronger operator with a ~20 % smaller inertial number: the Bagnold layer ran
        10-18 % slow with the lattice constant (docs/ps.md). The pair coefficient
        ``(nu_i s_i + nu_j s_j)`` stays symmetric (momentum is conserved); particles with a
        truncated support (free surface) and boundary particles keep the lattice constant, so
        that the pairwise flux near a free surface is the interior one."""
        ps = self.ps
        nf = ps.nf
        sc = np.full(len(ps.x_all), ps.lap_scale)
        local_lap_scales(ps.x_all, ps.vol_all, ps.ff_start, ps.ff_j, nf, ps.h,
                         ps.kernel, ps.eta2, ps.body["divr"], DIVR_FULL, ps.lap_scale,
                         sc)
        if ps.periodic is not None:
            rows, src = ps.periodic.fluid_images()
            sc[rows] = sc[src]
        return ps.nu_all * sc

    def solve_step(self, A, rhs, dt, col_of, mirror, stress):
        """The implicit viscous solve: per component with the Morris matrix ``A``; with the
        ``stress`` operator one coupled system for ``U = [u_x; u_y]``,
        ``(blockdiag(A, A) - dt B) U = rhs + dt e`` (:func:`transpose_operator`), solved by
        ``self.implicit_solve`` (:func:`solve_implicit`; on several ranks gathered to rank
        0: fsi_sph/parallel/ranks.py)."""
        ps = self.ps
        coupled = None
        if stress:
            nf = ps.nf
            B, e = transpose_operator(ps.x_all, ps.vol_all, ps.nu_all[:nf], ps.L,
                                      ps.ff_start, ps.ff_j, nf, ps.h, ps.kernel, col_of,
                                      ps.v_all, mirror)
            coupled = (B, rhs + dt * e, dt)
            if self.morris_pre is None:
                self.morris_pre = MorrisPreconditioner()
        return self.implicit_solve(A, rhs, ps.v_old, ps.cfg.viscous_rtol, coupled,
                                   self.morris_pre)

    def wall_mirror(self, col_of):
        """No-slip velocity of the boundary particles for the viscous term (Adami et al. 2012):
        ``u_w = 2 v_w - sum_f W_wf u_f / sum_f W_wf`` over the fluid neighbours ``f`` of ``w``
        (``v_w`` the wall's own velocity), so that the velocity extrapolated through the wall
        vanishes at the wall and not a few wall layers deeper; ``u_w = v_w`` without fluid
        neighbours. Returns ``(S, target)``: ``u_w = target_w - S_w u`` with ``S`` (boundary
        rows x fluid unknowns, periodic images folded by ``col_of``)."""
        ps = self.ps
        nf, nb = ps.nf, len(ps.x_all) - ps.nf
        start, j = ps.wf_start, ps.wf_j
        rows = np.repeat(np.arange(nb), np.diff(start))
        d = ps.x_all[nf + rows] - ps.x_all[j]
        w = kernel_w_array(np.hypot(d[:, 0], d[:, 1]), ps.h, ps.kernel)
        sw = np.bincount(rows, weights=w, minlength=nb)
        has = sw > 0.0
        wt = w / np.where(sw > 0.0, sw, 1.0)[rows]
        S = sp.csr_array((wt, (rows, col_of[j])), shape=(nb, nf))
        S.sum_duplicates()
        return S, wall_target(S, ps.v_b, has)

    def wall_pressure_acceleration(self, col_of):
        """``grad p^n / rho`` at the boundary particles: the Shepard average over each boundary
        particle's fluid neighbours of the fluid's pressure acceleration of the previous step,
        with the operator of the correction step (``ps.correct``: corrected [F 7, F 13] or
        conservative [F 10], walls' pressures included; periodic images carry their
        original's); 0 where a boundary particle has no fluid neighbour."""
        ps = self.ps
        nf = ps.nf
        gp = np.zeros((len(ps.x_all), 2))
        self.gradient.apply(ps.p_all, gp[:nf])
        gp[:nf] /= ps.rho
        fold = col_of >= 0
        gp[fold] = gp[:nf][col_of[fold]]
        xb = ps.x_all[nf:]
        out = np.zeros((len(xb), 2))
        tmp = np.empty(len(xb))
        for k in range(2):
            K.shepard_at(xb, ps.x_all, np.ascontiguousarray(gp[:, k]), ps.wf_start,
                         ps.wf_j, ps.h, ps.kernel, tmp)
            out[:, k] = np.where(np.isfinite(tmp), tmp, 0.0)
        return out

    def explicit_transpose_term(self, col_of):
        """``(1/rho) div(eta (grad u)^T)`` of the fluid rows at ``u^n`` (mirrored walls), gather
        only: ``tau_i = nu_i (grad u_i)^T`` from the corrected gradient, then its corrected
        divergence over the fluid neighbours (:func:`transpose_stress_divergence`)."""
        ps = self.ps
        nf = ps.nf
        tau = ps.nu_all[:nf, None, None] * np.transpose(ps.grad_v, (0, 2, 1))
        fstart, fj = fluid_lists(ps.ff_start, ps.ff_j, col_of)
        Lf = np.empty((nf, 2, 2))
        K.correction_matrices(ps.x_all, ps.vol_all, fstart, fj, ps.h, ps.kernel, Lf)
        out = np.empty((nf, 2))
        transpose_stress_divergence(ps.x_all, ps.vol_all, np.ascontiguousarray(tau), fstart,
                                    fj, col_of, Lf, nf, ps.h, ps.kernel, out)
        return out

    def wall_viscosity(self):
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
        ps = self.ps
        nf, nw = ps.nf, ps.n_walls
        law = self.law
        out = np.empty(nw)
        xw = ps.x_all[nf:nf + nw]
        if law.kind == "mu_i":
            gd = np.zeros(len(ps.x_all))
            gd[:nf] = law.gdot
            if ps.periodic is not None:
                rows, src = ps.periodic.fluid_images()
                gd[rows] = gd[src]
            K.shepard_at(xw, ps.x_all, gd, ps.wf_start, ps.wf_j, ps.h, ps.kernel,
                         out)
            ok = np.isfinite(out)
            out[ok] = law.mu_i_nu(out[ok], ps.p_all[nf:nf + nw][ok])
        else:
            K.shepard_at(xw, ps.x_all, ps.nu_all, ps.wf_start, ps.wf_j, ps.h,
                         ps.kernel, out)
        out[~np.isfinite(out)] = law.nu0
        ps.nu_all[nf:nf + nw] = out
        if ps.periodic is not None:
            ps.periodic.sync(ps)  # and the wall images'
