"""The pressure Poisson equation of the projection [F 17, F 20-21]: assembly over the
particle set, the free surface's target, the density relaxation's source, the tension
cut-off, the solve (standard, or the increment of the incremental projection,
:mod:`fsi_sph.fluid.increments`) and the pressure state a restart needs."""

from __future__ import annotations

import numpy as np

from fsi_sph.fluid import _kernels as K
from fsi_sph.fluid.increments import PressureIncrements
from fsi_sph.fluid.lattice import DIVR_FULL
from fsi_sph.fluid.ppe import PPEStats, PressureSolver, assemble


class PressureSolve:
    """The PPE of a particle set ``ps`` (row roles ``rows``, boundary rows ``boundary``,
    pressure gradient ``gradient``)."""

    def __init__(self, ps, rows, boundary, gradient):
        self.ps = ps
        self.rows = rows
        self.boundary = boundary
        self.gradient = gradient
        cfg = ps.cfg
        self.incremental = cfg.projection == "incremental"
        if self.incremental and ps.ns:
            raise ValueError("fluid.projection = \"incremental\" with coupled structures is "
                             "not supported")
        self.incremental_step = False  # this step's projection is the incremental one
        self.p_surface = np.zeros(ps.nf)  # the surface rows' target (surface_pressure)
        self.ppe = PressureSolver(cfg.ppe)
        self.last_stats = PPEStats()
        self.div = np.zeros(ps.nf)
        self.increments = PressureIncrements(ps, rows, gradient, self.ppe)

    def resize(self):
        """A new fluid particle count (open boundaries): the per-row arrays follow."""
        self.p_surface = np.zeros(self.ps.nf)
        self.div = np.zeros(self.ps.nf)

    def begin_step(self, dt):
        """The pressure's part of the start of a step (before the predictor): ``p^0`` before
        the first incremental step, this step's projection, and with the incremental one
        the carried ``p^n`` and the walls' re-extrapolated ``p^n``."""
        ps = self.ps
        if self.incremental and not ps.p_known:
            self.initial_pressure(dt)
        self.incremental_step = self.incremental
        self.boundary.new_step()  # new positions and p^n: the mirror walls' force anew
        if self.incremental_step:
            self.increments.carry()
            self.boundary.refresh_wall_pressure()

    def initial_pressure(self, dt):
        """``p^0`` of the incremental projection: the standard PPE's pressure for
        ``u* = u^0 + dt g`` (no viscous term), the pressure that holds the body force against
        the walls and the incompressibility of the initial state; hydrostatic in a fluid at
        rest. (``p^0 = 0`` would give a first step whose increment builds up the whole
        hydrostatic pressure against walls that enter with ``u*_w = u_w``.)"""
        ps = self.ps
        self.incremental_step = False
        ps.v_star[:] = ps.body["v"] + dt * ps.gravity
        self.solve(dt)

    def solve(self, dt):
        """Assemble and solve the PPE [F 17, F 20-21]; fluid and wall pressures; PPEStats.
        Incremental projection: the PPE for the increment ``phi`` [Goda 1979]
        (:meth:`PressureIncrements.solve`)."""
        ps = self.ps
        import time

        b = ps.body
        t0 = time.perf_counter()
        # Walls enter div u* with the predicted velocity u*_w = u_w + dt (g - a_w) of a static
        # wall (u_w = a_w = 0), the velocity that Adami's extrapolation (the g term of the
        # wall rows) takes back to u_w in the correction. With u*_w = u_w instead, the wall
        # flux would be counted twice, once through div u* and once through the extrapolated
        # wall pressure, and a tank at rest would not stay at rest.
        # A moving boundary (structure particle) likewise enters with u_b + dt (g - a_b)
        # when its acceleration a_b is known (explicit), with u_b + dt g when the solve takes
        # it implicitly (BoundaryRows.set_structures).
        # Incremental projection [Goda 1979]: the walls' p^n already holds the g term
        # (BoundaryRows.refresh_wall_pressure), so the increment's wall rows carry none: the
        # walls enter with their own velocity, which is also the no-slip mirror target of the
        # viscous step (viscous.py), so both see the same u*_w.
        g_star = ps.g_b if self.boundary.g_star is None else self.boundary.g_star
        vb_star = ps.v_b.copy() if self.incremental_step else ps.v_b + dt * g_star
        if ps.periodic is not None:
            ps.periodic.boundary_star(ps, vb_star)
        ps.velocity_divergence(ps.v_star, vb_star, self.div)
        source = -ps.rho / dt * self.div
        relax = self.relaxation_source(dt)
        if relax is not None and not self.incremental_step:
            source += relax
        ps.correction_matrices()
        # rows whose kernel support is truncated (free surface, near it, or beside the end
        # of a wall) get the consistent (corrected) Laplacian and pressure gradient
        # (FluidSection.laplacian = "consistent": every row)
        if ps.cfg.laplacian == "consistent":
            self.consistent = np.ones(ps.nf, dtype=np.bool_)
        else:
            self.consistent = (b["class"] != K.INTERIOR) | (b["divr"] < DIVR_FULL)
        alpha = b["alpha"]
        if self.incremental_step:  # drops: free-surface rows (PressureIncrements.carry)
            alpha = np.where(self.increments.drops, 0.0, alpha)
        A, rhs = assemble(ps.x_all, ps.vol_all, alpha, source, ps.L, self.consistent,
                          ps.ff_start, ps.ff_j,
                          ps.wf_start, ps.wf_j, ps.nf, ps.nw, ps.h, ps.kernel,
                          ps.eta2, ps.lap_scale, ps.diag_ref, ps.rho,
                          self.boundary.wall_body_force(), ps.implicit,
                          self.rows.interface_weights() if ps.ns else None)
        if ps.cfg.surface_offset > 0.0:
            self.offset_surface_rows(A, rhs, alpha)
        if ps.open is not None:  # the outflow buffers: p = p_out
            ps.open.hold_pressure(A, rhs, ps.nf + ps.n_fixed, ps.diag_ref)
        if self.incremental_step:
            p, stats = self.increments.solve(A, rhs, source, alpha, relax, t0,
                                             self.p_surface)
        else:
            if ps.periodic is not None:
                A, rhs = ps.periodic.constrain(A, rhs, ps.diag_ref)
            t1 = time.perf_counter()
            low_rank = self.boundary.rigid_terms() if self.boundary.rigid is not None else None
            p, stats = self.ppe.solve(A, rhs, ps.p_all, ps.nf, low_rank)
            stats.assemble_time = t1 - t0
            if self.incremental:  # the initial pressure p^0 (initial_pressure)
                self.increments.phi_all = np.zeros(len(p))
        if ps.cfg.tension_cutoff:
            p = self.cut_tension(p)
        ps.p_known = True
        ps.p_all[:] = p
        b["p"][:] = p[:ps.nf]
        if ps.walls is not None:
            ps.walls.body["p"][:] = p[ps.nf:ps.nf + ps.n_fixed]
        self.last_stats = stats
        self.A, self.rhs = A, rhs
        return stats

    def surface_pressure(self):
        """Pressure of the free-surface rows when the free surface lies ``delta =
        fluid.surface_offset * dx`` outside their particles (a surface particle stands for
        the area around it, so a flat surface is half a spacing above the top row's
        centres): ``p = 0`` at the surface, linearly extrapolated to the particle along the
        outward normal ``n`` with the last pressure's gradient (at the current positions),
        ``p_s = delta min(max(0, -n . grad p^n), rho max(0, -g . n))`` -- ``delta rho g
        cos(theta)`` in a layer at rest, 0 in free fall, never a tension, and never more
        than the hydrostatic head of the half spacing: a one-sided gradient at the toe of a
        granular collapse, extrapolated as it was, kicked a toe particle into the floor at
        1.85 m/s (twice the free-fall speed from the column's top; a = 0.5, full
        resolution). Zero where a row has no normal (interior class), for drops and for
        rows without neighbours. It changes only the target of the Dirichlet part of the
        [F 20-21] rows; the offset itself has no equation in PHYSICS.md."""
        ps = self.ps
        b = ps.body
        if self.incremental_step:
            grad = self.gradient.lagged * ps.rho
        else:
            grad = np.empty((ps.nf, 2))
            self.gradient.apply(ps.p_all, grad)
        dpdn = np.einsum("ij,ij->i", b["normal"], grad)
        head = ps.rho * np.maximum(-(b["normal"] @ ps.gravity), 0.0)
        p_s = ps.cfg.surface_offset * ps.dx * np.clip(-dpdn, 0.0, head)
        p_s[np.diff(ps.ff_start) == 0] = 0.0
        if self.incremental_step:
            p_s[self.increments.drops] = 0.0
        return p_s

    def offset_surface_rows(self, A, rhs, alpha):
        """Move the free-surface rows' target from ``p = 0`` to :meth:`surface_pressure`:
        a row ``D_i p_i - alpha_i sum_j a_ij p_j = alpha_i source_i`` (:func:`ppe.assemble`,
        [F 20-21]) gets ``+ (1 - alpha_i) D_i p_s,i`` on its right-hand side (pure Dirichlet
        rows: ``p_i = p_s,i``). In place; the incremental projection's right-hand side
        (:func:`ppe.increment_rhs`) inherits it."""
        ps = self.ps
        nf = ps.nf
        blend = np.where(np.diff(ps.ff_start) == 0, 0.0, np.clip(alpha, 0.0, 1.0))
        self.p_surface = self.surface_pressure()
        rhs[:nf] += (1.0 - blend) * A.diagonal()[:nf] * self.p_surface

    def cut_tension(self, p):
        """``max(p, 0)`` for a cohesionless material (``fluid.tension_cutoff``): the fluid,
        the fixed walls (whose pressure is extrapolated from the fluid's) and the periodic
        images; with the incremental projection the increment that :meth:`correct` applies
        becomes ``max(p^n + phi, 0) - p^n``. Where the cut-off acts, ``u^{n+1}`` keeps the
        divergence of ``u*``: the material opens instead of pulling (no tension between
        grains)."""
        ps = self.ps
        rows = np.ones(len(p), dtype=bool)  # [fluid | walls | structures or images]
        rows[ps.nf + ps.n_walls:ps.nf + ps.nw] = False  # structures: their own stress
        cut = np.where(rows, np.maximum(p, 0.0), p)
        if self.incremental_step:
            self.increments.phi_all += cut - p
        return cut

    def relaxation_source(self, dt):
        """The density-error term of the PPE source, or None without density relaxation.

        Density-error term of the stabilised ISPH source (Asai et al. 2012): lap p = rho
        div u* / dt + relax rho (sigma0 - sigma) / (sigma0 dt^2), applied where sigma >
        sigma0 in the interior, so that particles that have drifted together (a
        divergence-free projection does not see it) are pushed apart, and with
        ``density_relaxation_sign = "both"`` (the default) also where sigma < sigma0 on a
        full support, so that the water does not dilate.

        Rows with a coupled structure in their support are left out (both signs): the
        structure's particles are not on the fluid's lattice, so the kernel sum there
        measures the interface's gap or overlap, not the fluid's volume; relaxing it pumped
        water under a heaving floating box (fastest fluid particle over 1 s 0.22 m/s, 0.046
        without relaxation, 0.074 with these rows left out;
        tests/consistency/test_floating_box.py). Not in PHYSICS.md."""
        ps = self.ps
        b = ps.body
        relax = ps.cfg.density_relaxation
        if relax <= 0.0:
            return None
        excess = (b["sigma"] - ps.sigma0) / ps.sigma0
        if ps.cfg.density_relaxation_sign == "compression":
            excess = np.maximum(excess, 0.0)
        else:  # "both": an expansion (sigma < sigma0) pulls back too, where the kernel
            # support is full (a truncated support also has sigma < sigma0); under a
            # sustained shear the shifting otherwise lets a layer slowly dilate (issue 6)
            excess[(excess < 0.0) & self.rows.truncated_for_relaxation()] = 0.0
        excess[b["class"] != K.INTERIOR] = 0.0
        if ps.ns:
            excess[self.rows.structure_rows(ps.nf + ps.nw - ps.ns)] = 0.0
        return relax * ps.rho / (dt * dt) * excess

    def extra_state(self):
        """State outside the fluid body's arrays that the next step needs (restart): the
        stacked fluid, wall and structure pressures, the warm start of the next solve, and
        whether a pressure is known yet (the incremental projection's p^n, the mirror walls'
        lagged gradient)."""
        ps = self.ps
        state = {"p_all": ps.p_all.copy(), "p_known": np.array(ps.p_known)}
        if self.incremental:
            state["phi_all"] = self.increments.phi_all.copy()
        return state

    def load_extra_state(self, state):
        ps = self.ps
        p = state["p_all"]
        if len(p) == len(ps.p_all):
            ps.p_all[:] = p
        else:  # periodic images come and go: fluid and walls are what carries over, the
            # images' rows are filled from their originals at the next neighbour update
            n = ps.nf + ps.n_walls
            ps.p_all[:n] = p[:n]
        if "phi_all" in state:  # (the increment's warm start is resized when needed)
            self.increments.phi_all = np.array(state["phi_all"])
        if "p_known" in state:
            ps.p_known = bool(state["p_known"])
        if ps.walls is not None:
            ps.walls.body["p"][:] = ps.p_all[ps.nf:ps.nf + ps.n_fixed]

    def at_snapshot(self):
        """Called when a snapshot is written: rebuild the AMG hierarchy at the next solve."""
        self.ppe.reset()
