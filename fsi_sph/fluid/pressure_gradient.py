"""The correction step's pressure gradient at the fluid rows: conservative [F 10],
corrected [F 7, F 13] or both (``interface_conservative``), with the walls' floor of
``fluid.wall_suction = false``; and the incremental predictor's lagged ``grad p^n / rho``."""

from __future__ import annotations

import numpy as np

from fsi_sph.fluid import _kernels as K


class PressureGradient:
    """The pressure gradient over a particle set ``ps`` (row roles ``rows``, boundary rows
    ``boundary``)."""

    def __init__(self, ps, rows, boundary):
        self.ps = ps
        self.rows = rows
        self.boundary = boundary
        self.lagged = np.zeros((ps.nf, 2))  # grad p^n / rho of the step

    def lagged_acceleration(self):
        """``grad p^n / rho`` of the fluid rows for the incremental predictor (Goda 1979),
        with the correction step's operator (:meth:`apply`) at the current
        positions: the last solve's ``p`` (Taylor-corrected by the shift), walls included."""
        ps = self.ps
        ps.sync()
        ps.correction_matrices()
        out = np.empty((ps.nf, 2))
        self.apply(ps.p_all, out)
        out /= ps.rho
        self.lagged = out
        return out

    def apply(self, p, out, floor="pressure"):
        """The correction step's gradient of the stacked field ``p`` at the fluid rows
        (``ps.L`` current): conservative [F 10] or corrected [F 7, F 13], over the fluid,
        the walls and the periodic images (the structures are left to the coupling).
        With ``fluid.wall_suction = false`` the fixed walls cannot pull
        (:func:`_kernels.wall_floor`): ``floor`` = "pressure" (a pressure: hydrostatic
        carry), "increment" (an increment of it: none) or None (no floor: the density
        relaxation's displacement pressure). The floor acts on the rows that are not
        interior (free-surface and near-surface class, :meth:`RowRoles.floor_rows`)."""
        ps = self.ps
        jmax = ps.nf + ps.nw - ps.ns
        rg = self.rows.no_rg
        floored = self.rows.no_rows
        if not ps.cfg.wall_suction and floor is not None:
            floored = self.rows.wall_rows
            # the walls' own extrapolation force (BoundaryRows.wall_body_force)
            if floor == "pressure":
                rg = self.rows.floor_rg
                if ps.cfg.wall_pressure == "mirror":
                    rg[ps.nf:ps.nf + ps.n_walls] = (
                        ps.rho * self.boundary.wall_body_force()[:ps.n_walls])
        rows = self.rows.floor_rows() if floored is not self.rows.no_rows else self.rows.no_rows
        return self.with_rows(p, jmax, floored, rows, rg, out)

    def with_rows(self, p, jmax, floored, floor_row, rg, out):
        ps = self.ps
        form = ps.cfg.pressure_gradient
        if form == "conservative":
            K.pressure_gradient(ps.x_all, p, ps.vol_all, ps.ff_start, ps.ff_j, ps.nf,
                                ps.h, ps.kernel, ps.grad_scale, jmax, floored, floor_row,
                                rg, out)
            return out
        K.corrected_pressure_gradient(ps.x_all, p, ps.vol_all, ps.L, ps.ff_start,
                                      ps.ff_j, ps.nf, ps.h, ps.kernel, jmax, floored,
                                      floor_row, rg, out)
        if form == "interface_conservative" and ps.ns:
            # the rows beside a structure take the pair form [F 10], the one that balances the
            # interface force [F 46-47] (under a uniform pressure both vanish there); in a
            # confined flow, whose pressure level is arbitrary and through the pair form's
            # self-term pushed the rows of an irregular support (the flag's root), the
            # difference form over the whole support (docs/numerics/coupling.md § Pressure
            # level of a confined flow); the waterline rows keep the corrected form
            # (interface_weights)
            rows = self.rows.structure_rows(jmax) & ~self.rows.waterline_rows()
            K.structure_row_pressure_gradient(ps.x_all, p, ps.vol_all, ps.ff_start, ps.ff_j,
                                              ps.nf, ps.h, ps.kernel, ps.grad_scale, jmax,
                                              floored, floor_row, rg, ps.confined, rows, out)
        return out
