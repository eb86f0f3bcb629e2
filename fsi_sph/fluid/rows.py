"""The roles of the stacked rows of the fluid's particle set: which fluid particle a row is
(``fluid_of``), the fixed walls and their images (``wall_rows``), the fluid rows beside a
coupled structure, the waterline rows and their pair weights, the rows the walls' floor acts
on, the fluid neighbour counts. Found once per neighbour update (:meth:`assign`)
or free-surface detection (:meth:`new_surface`) and kept until then."""

from __future__ import annotations

import numpy as np

from fsi_sph.fluid import _kernels as K
from fsi_sph.fluid.lattice import DIVR_FULL

DIVR_GAP = 1.8  # fluid.relaxation_gap_rows: a nearly full support (truncated_for_relaxation)


class RowRoles:
    """Row roles of a :class:`~fsi_sph.fluid.particle_set.FluidParticles` ``ps``."""

    def __init__(self, ps):
        self.ps = ps
        self._pair_w = None  # interface_weights: the pair weights (identity but waterline)
        self._waterline = None  # waterline_rows, once per free-surface detection

    def new_surface(self):
        """A new free-surface detection: the waterline rows are found anew for its alpha."""
        self._waterline = None

    def assign(self):
        """Roles of the stacked rows ``[fluid | walls | structures | periodic images]``, set
        whenever the layout may change (:meth:`update_neighbors`): ``fluid_of``, the fluid
        particle a row is (itself or an image's original; -1 for the others: the viscous
        step's unknown of a row, the collision model's partner); ``wall_rows``, the fixed
        wall particles and the walls' periodic images (the floor of ``wall_suction =
        false``), with ``floor_rg = rho g`` on them (the mirror walls' rows are refreshed
        in :meth:`PressureGradient.apply`); ``no_rows`` all False, ``no_rg`` all 0."""
        ps = self.ps
        n = len(ps.x_all)
        self.fluid_of = np.full(n, -1, dtype=np.int64)
        self.fluid_of[:ps.nf] = np.arange(ps.nf)
        self.wall_rows = np.zeros(n, dtype=np.bool_)
        self.wall_rows[ps.nf:ps.nf + ps.n_walls] = True
        if ps.periodic is not None:
            rows, src = ps.periodic.rows, ps.periodic.src
            self.fluid_of[rows] = np.where(src < ps.nf, src, -1)
            self.wall_rows[rows] = src >= ps.nf
        # counted anew for these lists: fluid_neighbour_counts, structure_rows, row_of
        self._n_fluid = self._near_structure = self._row_of_pairs = self._waterline = None
        self.no_rows = np.zeros(n, dtype=np.bool_)
        self.no_rg = np.zeros((n, 2))
        self.floor_rg = np.zeros((n, 2))
        self.floor_rg[self.wall_rows] = ps.rho * ps.gravity

    def row_of(self):
        """The fluid row of each entry of the fluid rows' neighbour lists."""
        ps = self.ps
        if self._row_of_pairs is None:
            self._row_of_pairs = np.repeat(np.arange(ps.nf),
                                           np.diff(ps.ff_start[:ps.nf + 1]))
        return self._row_of_pairs

    def structure_rows(self, jmax):
        """Fluid rows with a coupled structure particle (global index ``>= jmax``) among
        their neighbours (``pressure_gradient = "interface_conservative"``), found once per
        neighbour update (:meth:`assign` clears it)."""
        ps = self.ps
        if self._near_structure is None:
            near = np.zeros(ps.nf, dtype=bool)
            near[self.row_of()[ps.ff_j[:ps.ff_start[ps.nf]] >= jmax]] = True
            self._near_structure = near
        return self._near_structure

    def waterline_rows(self):
        """Free-surface rows (``p = 0``: ``alpha = 0`` [F 21]) beside a coupled structure
        (``pressure_gradient = "interface_conservative"``). On them the pair form [F 10] is
        the difference form (``p_i = 0``), but over a support cut by the surface it gives
        half the hydrostatic gradient, and the surface particles slid down a structure's
        face; they take the corrected form [F 7, F 13] over the fluid and the walls and the
        same correction ``L_i`` on their pair terms with the structure
        (:meth:`interface_weights`): together the corrected gradient over the whole
        support, exact for a linear pressure, with action = reaction kept pair by pair.
        Found once per free-surface detection and neighbour update."""
        ps = self.ps
        if self._waterline is None or len(self._waterline) != ps.nf:
            if ps.cfg.pressure_gradient != "interface_conservative" or not ps.ns:
                self._waterline = np.zeros(ps.nf, dtype=bool)
            else:
                near = self.structure_rows(ps.nf + ps.nw - ps.ns)
                self._waterline = near & (ps.body["alpha"] == 0.0)
        return self._waterline

    def interface_weights(self):
        """Per fluid row, the matrix ``W_f`` that weights its pair terms with the structure
        [F 46-47] (``sph.interface.pair_pressure_forces``, the rigid and implicit rows
        of the solve): the identity, or ``L_f / c`` on the waterline rows
        (:meth:`waterline_rows`), so that ``c W_f = L_f`` there."""
        ps = self.ps
        if self._pair_w is None or len(self._pair_w) != ps.nf:
            self._pair_w = np.tile(np.eye(2), (ps.nf, 1, 1))
            self._pair_w_rows = np.zeros(0, dtype=np.int64)
        self._pair_w[self._pair_w_rows] = np.eye(2)
        rows = np.flatnonzero(self.waterline_rows())
        if len(rows):
            ps.correction_matrices()
            self._pair_w[rows] = ps.L[rows] / ps.grad_scale
        self._pair_w_rows = rows
        return self._pair_w

    def floor_rows(self):
        """The fluid rows on which the walls' floor (``fluid.wall_suction = false``) acts:
        those that are not interior. The floor is for the row whose walls extrapolate their
        pressure from a support of free-surface rows at ``p = 0`` (a particle pressed against
        the floor at the tip of a granular front, :func:`_kernels.wall_floor`). Beside an
        interior row the walls average over Poisson rows, and there a floor taken pair by
        pair only rectifies the particle-scale noise of the pressure: ``max(p_w, p_i + rho
        g . r)`` is never below the hydrostatic wall pressure and on average above it. Under
        the incremental projection, whose carried pressure holds such noise, that bias
        lifted the bed row of a periodic granular layer 5 particles thick (Bagnold case,
        H/dx = 5) from 0.50 to 0.63-0.81 dx, the layer dilated and ran away (profile error
        28 % averaged over 1.5-3 s, 68 % at 3 s; with the floor on non-interior rows only:
        6.4 % and 8.2 %, the bed row at 0.54 dx, as with no floor at all; over three
        draws 28.8 -> 9.6 %, with a slower degradation after 2.6 s left in jittered draws
        that no floor at all shows too; docs/numerics/fluid.md, "Walls without suction")."""
        ps = self.ps
        return ps.body["class"] != K.INTERIOR

    def fluid_neighbour_counts(self):
        """Number of fluid neighbours of each fluid row (periodic fluid images included),
        counted once per neighbour update (:meth:`assign` clears it)."""
        ps = self.ps
        if self._n_fluid is None:  # (the fluid images are fluid neighbours too)
            self._n_fluid = np.empty(ps.nf, dtype=np.int64)
            K.fluid_neighbour_counts(ps.ff_start, ps.ff_j, self.fluid_of, self._n_fluid)
        return self._n_fluid

    def beside_walls(self, fixed_only=False):
        """The fluid rows that are neighbours of a fixed wall particle (or of an open
        boundary's buffer particle, unless ``fixed_only``): the only rows whose fluid-only
        gradient the walls' Shepard average reads (:meth:`BoundaryRows.wall_body_force`)."""
        ps = self.ps
        near = np.zeros(ps.nf, dtype=bool)
        last = ps.n_fixed if fixed_only else ps.n_walls
        src = self.fluid_of[ps.wf_j[:ps.wf_start[last]]]
        near[src[src >= 0]] = True
        return near

    def truncated_for_relaxation(self):
        """Rows whose kernel sum is not compared with ``sigma0`` for an expansion: ``div r <
        DIVR_FULL``; with ``fluid.relaxation_gap_rows`` not those with ``div r >= DIVR_GAP``
        and at least half a full support of fluid neighbours, whose deficit is a gap (the
        bed row of a sheared layer lifted off the floor: ``div r`` falls below
        ``DIVR_FULL`` and nothing pulled it back; a row at a free surface or at a thin front
        has fewer fluid neighbours). A rule with no equation in PHYSICS.md; measured in
        docs/numerics/granular.md, "Density relaxation"; the mu(I) cases set it."""
        ps = self.ps
        b = ps.body
        truncated = b["divr"] < DIVR_FULL
        if ps.cfg.relaxation_gap_rows:
            gap = (b["divr"] >= DIVR_GAP) & (2 * self.fluid_neighbour_counts() >= ps.n_full)
            truncated &= ~gap
        if ps.confined:  # no free surface: away from the walls a deficit is an expansion
            truncated &= self.beside_walls(fixed_only=True)
        return truncated
