"""The per-step table of a run's output (``/steps``): its columns and one row per step."""

from __future__ import annotations


class StepTable:
    """Columns and rows of the per-step table of a scene with the fluid ``fluid`` and the
    coupling ``coupling`` (either may be None)."""

    def __init__(self, fluid, coupling):
        self.fluid = fluid
        self.coupling = coupling
        # viscosity law / implicit step: every dt limit [F 48]
        self.dt_limits = fluid is not None and fluid.viscous is not None
        # open boundaries: the fluid's count and the mass that entered and left per step
        self.open = fluid is not None and fluid.open is not None
        # the fluid's particle count (a fluid split over ranks counts every rank's)
        self.fluid_count = (lambda: fluid.nf) if fluid is not None else None

    @property
    def columns(self):
        cols = ("t", "dt", "n_sub")
        if self.fluid is not None:
            cols += ("ppe_iterations", "ppe_residual", "ppe_assemble_s", "ppe_setup_s",
                     "ppe_solve_s", "ppe_rebuilt")
        if self.dt_limits:
            cols += ("dt_advective", "dt_viscous_explicit", "dt_force", "nu_max",
                     "viscous_iterations", "viscous_residual", "viscous_fallback")
        if self.coupling is not None:
            cols += ("power_on_structures", "power_on_fluid")
        if self.open:
            cols += ("fluid_particles", "mass_in", "mass_out")
        return cols

    def row(self, t, dt, n_sub):
        """The row of the step that ended at ``t`` (``n_sub``: sub-steps per body)."""
        row = [t, dt, max(n_sub.values(), default=0)]
        if self.fluid is not None:
            st = self.fluid.last_stats
            row += [st.iterations, st.residual, st.assemble_time, st.setup_time,
                    st.solve_time, float(st.rebuilt)]
        if self.dt_limits:
            lim, vs = self.fluid.dt_limits, self.fluid.viscous.stats
            row += [lim["advective"], lim["viscous"], lim["force"], lim["nu_max"],
                    vs.iterations, vs.residual, float(vs.fallback)]
        if self.coupling is not None:
            row += [self.coupling.power_structure, self.coupling.power_fluid]
        if self.open:
            row += [self.fluid_count(), *self.fluid.mass_flux()]
        return row
