"""The boundary rows of the fluid's pressure solve: the fixed walls and the coupled
structures as Adami-extrapolated rows (PHYSICS.md §5), their body force ``g - a_b`` (with
the mirror walls' share carried by the fluid), the structures' moving boundary and the
free bodies' rigid-body rows of the solve."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fsi_sph.fluid import _kernels as K
from fsi_sph.sph.interface import add_pair_terms, pair_pressure_forces, rigid_pair_terms

CARRIED_FULL = 0.9  # wall_pressure = "mirror": fluid gradient share taken as a full column


@dataclass
class RigidTerms:
    """The free bodies' rigid-body terms ``U G`` of the PPE (:meth:`BoundaryRows.rigid_terms`):
    ``U`` (rows x 3 per body) and ``G`` as its interface pairs, in the order of the serial
    sums: pair ``k`` joins the structure row ``pair_row[k]`` and the fluid row
    ``pair_fluid[k]`` of body ``pair_body[k]`` with coefficients ``pair[k]`` (x force, y force,
    torque) at both rows' columns."""

    U: np.ndarray
    pair_row: np.ndarray
    pair_fluid: np.ndarray
    pair_body: np.ndarray
    pair: np.ndarray

    def G(self, n=None):
        """``G`` dense (3 per body x ``n`` columns, default all rows), summed pair by pair in
        the pairs' order."""
        n = self.U.shape[0] if n is None else n
        G = np.zeros((self.U.shape[1], n))
        add_pair_terms(self.pair_body, self.pair_row, self.pair_fluid, self.pair, G)
        return G


class BoundaryRows:
    """Walls and structures as rows of the solve, over a particle set ``ps`` with the row
    roles ``rows``."""

    def __init__(self, ps, rows):
        self.ps = ps
        self.rows = rows
        self.rigid = None  # free bodies whose rigid-body motion the PPE solves for
        # on several ranks: the structure rows whose fluid neighbours this rank holds in
        # full (fsi_sph/parallel/ranks.py); only they add to the rigid-body terms
        self.owned_structures = None
        self.g_star = None  # with them: the boundary rows' acceleration in div u*
        self._gb_cache = None  # wall_body_force of the step (mirror walls)

    def new_step(self):
        """New positions and ``p^n``: the mirror walls' body force is computed anew."""
        self._gb_cache = None

    def set_structures(self, v_bar, a_bar, a_other=None, rho_s=None, rigid=None):
        """Moving boundary (PHYSICS.md §5): the structures' current positions, their velocity
        averaged over the last sub-cycle ``v_bar`` and acceleration ``a_bar`` (stacked in
        ``ps.structures`` order). ``rigid = (a_rigid, body_of, mass, inertia, centre)``:
        the structures are free bodies that the solve sees as rigid, their rigid-body
        acceleration under the fluid's force taken implicitly (:meth:`rigid_terms`);
        ``a_rigid`` is the rigid-body part of ``a_bar`` at each particle."""
        ps = self.ps
        if not ps.ns:
            return
        k = ps.nf + ps.n_walls
        for s in ps.structures:
            xs = s.body["x"]
            ps.x_all[k:k + s.body.n] = xs
            # outward surface normals of the structure over its own particles (zero inside),
            # with the body's total-Lagrangian neighbour pairs (fixed; no search per step)
            K.wall_normals(xs, ps.vol_all[k:k + s.body.n], s.nbr_start, s.nbr_j, ps.h,
                           ps.kernel, ps.wall_n[k - ps.nf:k - ps.nf + s.body.n])
            k += s.body.n
        ps.v_b[ps.n_walls:] = v_bar
        ps.v_all[ps.nf + ps.n_walls:] = v_bar
        if a_other is None:  # explicit: the last sub-cycle's mean acceleration
            ps.g_b[ps.n_walls:] = ps.gravity - a_bar
        else:  # implicit: every acceleration but the fluid's; the fluid's is solved for
            ps.g_b[ps.n_walls:] = ps.gravity - a_other
            ps.implicit[ps.n_walls:] = ps.rho * ps.grad_scale / rho_s
        # div u* takes the boundary rows at u_b + dt g_star (solve_pressure)
        self.g_star = None
        if a_other is not None:
            # implicit: the structure particles enter div u* as the walls do, at u_b + dt g;
            # the rows' extrapolation then ends the step with them at u_b + dt (a_other +
            # f(p) / m), their whole acceleration. With u_b + dt (g - a_other) they ended at
            # u_b + dt f(p) / m, without the internal force that balances the fluid's: the
            # fluid saw a loaded gate run away from it at up to dt * 380 m/s^2, ran into it
            # (the kinematic guard caught it) and the gate's peak depended on dt (-5.5 /
            # -10.7 % at dt_max 2e-4 / 5e-5 s; now 40.1 mm at 2e-4, 39.5 / 39.2 mm at 2e-4
            # / 5e-5 s, 3 across)
            self.g_star = ps.g_b.copy()
            self.g_star[ps.n_walls:] = ps.gravity
        self.rigid = rigid
        if rigid is not None:
            # the solve sees each body as rigid: its rows take a_w = g + a_rigid(p), so
            # g - a_w = -a_rigid(p), all of it in the matrix (rigid_terms); div u* takes
            # u_w + dt (g - a_rigid,last) (a_rigid,last: the rigid part of the last
            # sub-cycle's mean acceleration), so that the step ends at
            # u_w + dt (a_rigid(p) - a_rigid,last), the increment of the rigid motion taken
            # implicitly (with the last one's, the explicit scheme's lagged velocity)
            self.g_star = ps.g_b.copy()
            self.g_star[ps.n_walls:] = ps.gravity - rigid[0]
            ps.g_b[ps.n_walls:] = 0.0

    def rigid_terms(self):
        """:class:`RigidTerms` of the free bodies' rigid-body rows, added to the PPE matrix as
        ``U G`` (scaled like the other boundary rows by ``diag_ref``). A structure row ``w``
        of body ``b`` is Adami's extrapolation with the body's rigid acceleration under the
        fluid's generalised force ``G_b p`` (x, y force; torque about the centre of mass)::

            p_w - sum_f w_wf p_f + rho rbar_w . (F_b / M_b + (T_b / I_b) z x r_w) = 0

        (:func:`fsi_sph.sph.interface.rigid_pair_terms`; ``g - a_w`` without the fluid's
        share is 0: the body's weight gives it ``g``, its internal forces neither net force
        nor torque, and its deformation is not seen). On several ranks only the structure
        rows in ``owned_structures`` have pairs (and rows of ``U``)."""
        ps = self.ps
        _, body_of, mass, inertia, centre = self.rigid
        nb0 = ps.nf + ps.n_walls
        n = len(ps.p_all)
        ns = n - nb0
        k0 = ps.wf_start[ps.n_walls]
        sf_start = np.ascontiguousarray(ps.wf_start[ps.n_walls:] - k0)
        sf_j = np.ascontiguousarray(ps.wf_j[k0:])
        if self.owned_structures is not None:
            sf_start, sf_j = rows_kept(sf_start, sf_j, self.owned_structures)
        rbar = np.zeros((ns, 2))
        pair = np.empty((len(sf_j), 3))
        rigid_pair_terms(ps.x_all[nb0:], ps.vol_all[nb0:], ps.x_all[:ps.nf], ps.vol_all[:ps.nf],
                         sf_start, sf_j, ps.h, ps.kernel, ps.grad_scale,
                         self.rows.interface_weights(), body_of, centre, rbar, pair)
        lever = ps.x_all[nb0:] - centre[body_of]
        c = ps.diag_ref * ps.rho
        U = np.zeros((n, 3 * len(mass)))
        rows = nb0 + np.arange(ns)
        U[rows, 3 * body_of] = c * rbar[:, 0] / mass[body_of]
        U[rows, 3 * body_of + 1] = c * rbar[:, 1] / mass[body_of]
        U[rows, 3 * body_of + 2] = c * (rbar[:, 1] * lever[:, 0]
                                        - rbar[:, 0] * lever[:, 1]) / inertia[body_of]
        pair_row = nb0 + np.repeat(np.arange(ns), np.diff(sf_start))
        return RigidTerms(U, pair_row, sf_j.astype(np.int64), body_of[pair_row - nb0], pair)

    def wall_body_force(self):
        """The body force ``g - a_b`` of the boundary rows in Adami's extrapolation
        ``p_w = <p_f> + rho (g - a_w) . (x_w - <x_f>)`` (``ps.g_b``). With
        ``fluid.wall_pressure = "mirror"`` a fixed wall's row uses ``n (n . g) + c t (t .
        g)``: the hydrostatic term along its normal ``n`` in full, and along the wall
        (``t``) the share ``c`` of it that the fluid beside the wall carries itself, ``c =
        clip(t . G_w / (0.9 t . g), 0, 1)`` with ``G_w = <grad p_f / rho>_w`` the Shepard
        average of the last pressure's gradient taken over fluid neighbours only
        (:meth:`fluid_only_gradient`). In a fluid at rest ``G = g`` (to 0.2-1.6 % next to
        a wall and its waterline, hence the 0.9: with ``c = t . G / t . g`` itself those
        few per cent drove currents of 0.02 sqrt(g H) in the tank) and nothing changes; for
        a droplet or a film on a vertical wall the fluid has no pressure gradient along the
        wall, ``c = 0``, and the droplet falls instead of being held by the walls'
        hydrostatic field (tests/unit/test_wall_droplet.py). A boundary rule with no
        equation in PHYSICS.md (which leaves the wall pressure to the implementation)."""
        ps = self.ps
        if ps.cfg.wall_pressure != "mirror" or not ps.n_walls or not ps.p_known:
            return ps.g_b  # (before the first solve there is no gradient to read)
        if not np.any(ps.gravity):  # no body force: the mirror's term is zero (a channel)
            return ps.g_b
        nf, nwall = ps.nf, ps.n_walls
        gb = ps.g_b.copy()  # (the structures' rows as set_structures left them)
        if self._gb_cache is not None:  # the fixed walls' rows: once per step (predict)
            gb[:nwall] = self._gb_cache
            return gb
        grad = self.fluid_only_gradient() / ps.rho
        src = self.rows.fluid_of
        avg = np.empty((nwall, 2))
        for k in range(2):
            field = np.where(src >= 0, grad[np.maximum(src, 0), k], 0.0)
            K.shepard_at(ps.x_all[nf:nf + nwall], ps.x_all, field, ps.wf_start,
                         ps.wf_j, ps.h, ps.kernel, avg[:, k])
        n = ps.wall_n[:nwall]
        t = np.column_stack([-n[:, 1], n[:, 0]])
        along = np.einsum("ij,ij->i", t, np.where(np.isfinite(avg), avg, 0.0))
        g_t = t @ ps.gravity
        with np.errstate(divide="ignore", invalid="ignore"):
            carried = np.clip(along / (CARRIED_FULL * g_t), 0.0, 1.0)
        # floors (within ~15 deg of level): the whole term, as Adami's (a floor's normals
        # wobble by a fraction of a degree next to a corner, and a few Pa of difference
        # from the exact hydrostatic wall pressure drive cm/s currents in a tank at rest)
        carried = np.where(np.abs(g_t) > 0.25 * np.linalg.norm(ps.gravity), carried, 1.0)
        has_n = np.einsum("ij,ij->i", n, n) > 0.5
        mirror = n * (n @ ps.gravity)[:, None] + (carried * g_t)[:, None] * t
        gb[:nwall] = np.where(has_n[:, None], mirror, gb[:nwall])
        self._gb_cache = gb[:nwall].copy()
        return gb

    def fluid_only_gradient(self):
        """Corrected gradient [F 7, F 13] of the last pressure at the fluid rows over their
        fluid neighbours only (periodic fluid images included), with its own correction
        matrices: the fluid's pressure gradient without the walls' extrapolated pressures
        (a lone particle: 0). Computed only on the rows beside a fixed wall (the others get
        0: nothing reads them)."""
        ps = self.ps
        nf = ps.nf
        start = np.empty(nf + 1, dtype=np.int64)
        j = K.fluid_sublists(ps.ff_start, ps.ff_j, self.rows.fluid_of, self.rows.beside_walls(),
                             start)
        L = np.empty((nf, 2, 2))
        K.correction_matrices(ps.x_all, ps.vol_all, start, j, ps.h, ps.kernel, L)
        gp = np.empty((nf, 2))
        K.corrected_pressure_gradient(ps.x_all, ps.p_all, ps.vol_all, L, start, j, nf,
                                      ps.h, ps.kernel, len(ps.x_all), self.rows.no_rows,
                                      self.rows.no_rows, self.rows.no_rg, gp)
        return gp

    def fluid_average(self, fields, n_rows):
        """Shepard averages ``<f>_w = sum_f f_f W_wf / sum_f W_wf`` over the fluid
        neighbours of the first ``n_rows`` boundary rows, one column per stacked field
        (NaN without fluid neighbours)."""
        ps = self.ps
        xw = ps.x_all[ps.nf:ps.nf + n_rows]
        mean = np.empty((n_rows, len(fields)))
        for k, field in enumerate(fields):
            K.shepard_at(xw, ps.x_all, np.ascontiguousarray(field), ps.wf_start,
                         ps.wf_j, ps.h, ps.kernel, mean[:, k])
        return mean

    def no_slip_velocity(self):
        """Velocity of the boundary rows in the viscous term with a no-slip surface
        (Adami et al. 2012, J. Comput. Phys. 231:7057, eq. 23): ``u_w = 2 v_w - <u_f>_w``,
        the fluid's velocity mirrored about the wall's own ``v_w`` so that it vanishes
        relative to the wall at the wall's surface and not a few layers inside it; ``v_w``
        where no fluid is near, and the buffers of the open boundaries at their own
        (prescribed or extrapolated) velocity."""
        ps = self.ps
        mean = self.fluid_average((ps.v_all[:, 0], ps.v_all[:, 1]), ps.nw)
        u_w = np.where(np.isfinite(mean), 2.0 * ps.v_b - mean, ps.v_b)
        u_w[ps.n_fixed:ps.n_walls] = ps.v_b[ps.n_fixed:ps.n_walls]
        return u_w

    def fluid_forces(self, level=None, split=False):
        """Force of the fluid on every boundary row (N/m; walls, buffers, structures), from
        the pressures of the last solve and the velocities of the step: the pressure pair
        term of the interface [F 46-47] (:func:`~fsi_sph.sph.interface.pair_pressure_forces`,
        the coupling's own term with its pair weights) plus the reaction to the viscous
        term the fluid felt from the row [F 11-12]: the Morris pair sum of
        :func:`~fsi_sph.fluid._kernels.predict_velocity` gathered on the boundary row, with
        the row's velocity as the viscous term saw it (the no-slip mirror of a through-flow),
        times the row's mass ``rho V_w`` (equal volumes: action = reaction pair by pair).
        The pair term takes the pressures relative to ``level`` (Pa; a force probe of a
        confined flow passes the level beside its body, :mod:`fsi_sph.fluid.gauge`).
        ``split``: return the pressure and the viscous parts as two arrays instead of their
        sum (a body's pressure drag and skin friction)."""
        ps = self.ps
        nf, nb = ps.nf, ps.nw
        ps.sync()
        xb, xf = ps.x_all[nf:nf + nb], ps.x_all[:nf]
        start, j = ps.wf_start[:nb + 1], ps.wf_j[:ps.wf_start[nb]]
        weights = (self.rows.interface_weights() if ps.ns
                   else np.tile(np.eye(2), (nf, 1, 1)))
        out = np.zeros((nb, 2))
        p = ps.p_all - level if level else ps.p_all
        pair_pressure_forces(xb, p[nf:nf + nb], ps.vol_all[nf:nf + nb], xf,
                             p[:nf], ps.vol_all[:nf], start, j, ps.h, ps.kernel,
                             ps.grad_scale, weights, False, out)
        u_b = self.no_slip_velocity() if ps.open is not None else ps.v_b
        x = np.vstack([xb, xf])  # boundary rows first, their fluid sources after them
        v = np.vstack([u_b, ps.v_all[:nf]])
        vol = np.concatenate([ps.vol_all[nf:nf + nb], ps.vol_all[:nf]])
        nu = np.concatenate([np.full(nb, ps.nu0), ps.nu_all[:nf]])
        acc = np.empty((nb, 2))
        K.predict_velocity(x, v, vol, nu, start, j + nb, nb, ps.h, ps.kernel, ps.eta2,
                           0.0, 0.0, 1.0, acc)
        acc -= u_b
        viscous = ps.rho * ps.vol_all[nf:nf + nb, None] * acc
        if split:
            return out, viscous
        return out + viscous

    def refresh_wall_pressure(self):
        """Incremental projection: the fixed walls' ``p^n`` re-extrapolated from the fluid's
        ``p^n`` at the current positions by the standard wall row (Adami; ``ppe_fill``),
        ``p_w = <p_f>_w + rho g . (x_w - <x_f>_w)`` (Shepard averages ``<>_w`` over the fluid
        neighbours), 0 without fluid neighbours. The last solve's wall pressures belong to
        the last step's neighbours: a wall particle the front has just reached still has
        ``p_w = 0``, which the lagged gradient would read as suction into the wall. Since the
        rows are linear, ``p^{n+1}_w = p^n_w + phi_w`` still satisfies the standard row, and
        the increment's wall rows are homogeneous (``increment_rhs`` gives 0 there)."""
        ps = self.ps
        nf, nwall = ps.nf, ps.n_walls
        if not nwall:
            return
        ps.sync()
        xw = ps.x_all[nf:nf + nwall]
        mean = self.fluid_average((ps.p_all, ps.x_all[:, 0], ps.x_all[:, 1]), nwall)
        rbar = xw - mean[:, 1:]
        gb = self.wall_body_force()[:nwall]
        pw = mean[:, 0] + ps.rho * np.einsum("ij,ij->i", gb, rbar)
        ps.p_all[nf:nf + nwall] = np.where(np.isfinite(pw), pw, 0.0)
        ps.sync()  # (the periodic wall images)


def rows_kept(start, j, keep):
    """The CSR lists ``(start, j)`` with the rows where ``keep`` is false emptied."""
    lengths = np.diff(start) * keep
    new_start = np.zeros(len(start), dtype=start.dtype)
    np.cumsum(lengths, out=new_start[1:])
    return new_start, np.ascontiguousarray(j[np.repeat(keep, np.diff(start))])
