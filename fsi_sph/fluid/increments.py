"""The incremental projection's own state and solves [Goda 1979]: the carried pressure
``p^n`` and its drops, the increment ``phi`` (the next solve's warm start) and the density
relaxation's pressure ``q`` (module docstring of :mod:`fsi_sph.fluid.isph`)."""

from __future__ import annotations

import numpy as np

from fsi_sph.fluid.ppe import increment_rhs


class PressureIncrements:
    """The increments of a particle set ``ps`` (row roles ``rows``, pressure gradient
    ``gradient``), solved with the pressure solver ``ppe``."""

    def __init__(self, ps, rows, gradient, ppe):
        self.ps = ps
        self.rows = rows
        self.gradient = gradient
        self.ppe = ppe
        n = len(ps.x_all)
        # the last pressure increment phi (incremental projection): the next solve's warm start
        self.phi_all = np.zeros(n)
        self.relax_all = np.zeros(n)  # and the density relaxation's pressure q (the same)
        self.drops = np.zeros(ps.nf, dtype=bool)

    def carry(self):
        """The ``p^n`` that the incremental projection carries into the step, and its drops:
        fluid particles with fewer fluid neighbours than a quarter of a full support's
        (:func:`lattice_offsets`; a corner of a block has 7 of 20) carry ``p^n = 0`` and
        are free-surface rows of the PPE (``self.drops``, :meth:`solve_pressure`). With an
        interior row, a drop of 3 particles landing on the floor ahead of the collapse
        front had a nearly singular row (its wall neighbours' pressures are extrapolated
        from its own): its pressure, carried from step to step, grew 0.7 -> 12 -> 112 kPa
        in three steps (hydrostatic at the bottom of the column: 1.6 kPa) and threw it off
        at 20 m/s; not carried, the increment alone still reached 22 -> 111 kPa. Set in
        ``body["p"]``: the viscosity law sees it too."""
        ps = self.ps
        b = ps.body
        self.drops = 4 * self.rows.fluid_neighbour_counts() < ps.n_full
        b["p"][self.drops] = 0.0

    def solve(self, A, rhs, source, alpha, relax, t0, p_surface):
        """The incremental projection's solves [Goda 1979] (the matrix ``A``, the divergence
        right-hand side ``rhs`` and its ``source`` from :meth:`solve_pressure`): the
        increment ``phi`` (:func:`ppe.increment_rhs`: ``p^{n+1} = 0`` at the free surface,
        the wall rows' condition on ``p^{n+1}``; with ``incremental_damping = beta`` the
        right-hand side is blended with the standard one, :meth:`standard_rhs`,
        so that ``p^{n+1} = (1 - beta) (p^n + phi) + beta p_standard``) and, with density
        relaxation, its pressure ``q`` (source
        only, ``q = 0`` at the free surface and no wall term), which :meth:`correct` turns
        into a displacement. ``p^{n+1} = p^n + phi`` keeps ``q`` out: a pressure that only
        moves particles apart is not a pressure of the flow. Accumulated in ``p`` its
        particle-scale part, which the gradient hardly sees and the next increments
        therefore never take back, grew without bound (collapse at dt 2e-4 s: +-60 times
        the hydrostatic pressure). Returns ``(p^{n+1}, PPEStats)``."""
        ps = self.ps
        import time

        nf = ps.nf
        dirichlet = (alpha <= 0.0) | (np.diff(ps.ff_start) == 0)
        rhs_phi = increment_rhs(A, rhs, ps.p_all, alpha, dirichlet, nf)
        beta = ps.cfg.incremental_damping
        if beta > 0.0:
            rhs_phi *= 1.0 - beta
            rhs_phi += beta * self.standard_rhs(A, rhs, source, alpha, dirichlet,
                                                p_surface)
        if ps.periodic is not None:
            A, rhs_phi = ps.periodic.constrain(A, rhs_phi, ps.diag_ref)
        t1 = time.perf_counter()
        n = len(rhs_phi)
        if len(self.phi_all) != n:  # periodic images come and go: warm start resized
            self.phi_all = np.zeros(n)
        self.phi_all, stats = self.ppe.solve(A, rhs_phi, self.phi_all, nf)
        self.relax_all = np.zeros(n)
        if relax is not None:
            rhs_q = np.zeros(n)
            rhs_q[:nf] = np.where(dirichlet, 0.0, alpha * relax)
            self.relax_all, stats_q = self.ppe.solve(A, rhs_q, np.zeros(n), nf)
            for k in ("iterations", "setup_time", "solve_time", "vcycles", "matvecs"):
                setattr(stats, k, getattr(stats, k) + getattr(stats_q, k))
            stats.residual = max(stats.residual, stats_q.residual)
            stats.rebuilt = stats.rebuilt or stats_q.rebuilt
        stats.assemble_time = t1 - t0
        return ps.p_all + self.phi_all, stats

    def standard_rhs(self, A, rhs, source, alpha, dirichlet, p_surface):
        """Right-hand side of ``A (p_s - p^n) = b_s - A p^n`` for the non-incremental
        pressure ``p_s``: the standard PPE (walls with ``u*_w = u_w + dt g`` and their g
        term) of the velocity ``u* + dt grad p^n / rho`` (the "pressure form" of the
        incremental scheme, Bell, Colella & Glaz 1989). Its source is ``source - rho div(grad
        p^n / rho)`` with the walls at ``g`` in the divergence. Alone (beta = 1) it converges
        slowly where the viscous step is stiff (a column at rest from 0.54 of hydrostatic:
        0.92 after 300 steps), but it has no memory: mixed in at ``beta = 0.1`` it takes
        away the particle-scale pressure noise the incremental form accumulates (the
        collapse's pressure spread, the run-out's dt dependence: a = 0.5 sand r 0.64 / 0.51
        at the advective dt / 2e-4 s without it, 0.57 / 0.58 with it, no relaxation)."""
        ps = self.ps
        nf = ps.nf
        vb = ps.g_b.copy()
        if ps.periodic is not None:
            rows, src = ps.periodic.fluid_images()
            vb[rows - nf] = self.gradient.lagged[src]
        div_g = ps.velocity_divergence(self.gradient.lagged, vb, np.empty(nf))
        b_s = rhs.copy()  # the wall rows of the standard PPE
        b_s[:nf] = np.where(dirichlet, 0.0, alpha * (source - ps.rho * div_g))
        if ps.cfg.surface_offset > 0.0:  # the surface rows' target
            # (PressureSolve.offset_surface_rows)
            b_s[:nf] += ((1.0 - np.where(dirichlet, 0.0, alpha)) * A.diagonal()[:nf]
                         * p_surface)
        return b_s - A @ ps.p_all
