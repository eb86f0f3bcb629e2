"""Incompressible SPH fluid, projection method [F 15-21] (PHYSICS.md §2-3).

One fluid step ``dt`` (the order :meth:`Simulation.step` calls the verbs in):

1. ``update_neighbors``: CSR lists fluid <- (fluid, walls) and walls <- fluid at ``x^n``.
2. ``detect_free_surface``: ``div r``, the [F 21] blend ``alpha``, classes and normals.
3. ``shift`` (only with ``[fluid.shifting]``): the particle shift of the previous step's end
   [F 22-33], done here where fresh neighbour lists exist, with the Taylor correction of ``u``
   and ``p``.
4. ``predict``: ``u* = u^n + dt ((nu + nu_T) lap u^n + g)`` [F 16].
5. ``solve_pressure``: the PPE [F 17, F 20] for fluid and wall pressures (one sparse system).
6. ``correct``: ``u^{n+1} = u* - dt grad p / rho`` [F 18] and
   ``r^{n+1} = r^n + dt u^{n+1} + dt (u^{n+1} - u^n) / 2`` (``fluid.position_update =
   "damped"``, the default) or ``r^n + dt (u^n + u^{n+1}) / 2`` [F 19] (``"trapezoid"``).
   With the pressure solved at ``r^n`` (below) the trapezoid amplifies oscillations
   (docs/fluid.md, "Position update").

With ``fluid.projection = "incremental"`` (pressure correction: Goda 1979, J. Comput. Phys.
30:76; van Kan 1986, SIAM J. Sci. Stat. Comput. 7:870) steps 4-6 become::

    u* = u^n + dt (visc + g - grad p^n / rho)          (the lagged pressure acceleration)
    PPE for phi = p^{n+1} - p^n, source -rho div u* / dt; p^{n+1} = 0 at the free surface
    u^{n+1} = u* - dt grad phi / rho,   p^{n+1} = p^n + phi

so that the viscous step (implicit for the mu(I) law) sees the pressure gradient it has to
resist, and the splitting error of the standard form (a kick ``dt grad p^{n+1} / rho`` after
the viscous solve, resisted only in the next step) is of the size of the increment.

The PPE is evaluated at ``r^n`` rather than at the predicted ``r* = r^n + dt u^n`` [F 15]; the
two differ by O(dt) within one first-order projection step, and ``r^n`` reuses the step's
neighbour list (the choice of Cummins & Rudman 1999). With forces at ``r^n`` the trapezoidal
move [F 19] is not stable for oscillations (short free-surface waves grew), hence the damped
move by default.

Density and particle mass are constant: ``vol = dx^2``, ``m = rho0 dx^2``.
"""

from __future__ import annotations

import math

import numpy as np

from fsi_sph.fluid import _kernels as K
from fsi_sph.fluid import amg, free_surface
from fsi_sph.fluid.ppe import PPEStats, PressureSolver, assemble, increment_rhs
from fsi_sph.fluid.shifting import Shifting
from fsi_sph.fluid.walls import Walls
from fsi_sph.geometry import fill_shapes
from fsi_sph.neighbors import find_neighbors
from fsi_sph.particles import Body, FieldSpec
from fsi_sph.sph.kernels import KERNELS, SUPPORT, kernel_dw, kernel_w

ETA = 0.1  # Morris regularisation eta = 0.1 h [F 11]
FRONT_MIN_NEIGHBORS = 3  # fluid neighbours of a particle counted in the surge front
CARRIED_FULL = 0.9  # wall_pressure = "mirror": fluid gradient share taken as a full column
DIVR_FULL = 1.95  # div r below this: the kernel support is taken as truncated (full: ~2)
DIVR_GAP = 1.8  # fluid.relaxation_gap_rows: a nearly full support (_truncated_for_relaxation)


def lattice_offsets(dx, h):
    """Offsets ``(x_j - x_i)`` (m) of the neighbours of a particle of a full, uniform square
    lattice of spacing ``dx`` within the support ``2h`` (self excluded): 20 for h = 1.2 dx."""
    m = int(math.ceil(SUPPORT * h / dx)) + 1
    ix, iy = np.meshgrid(np.arange(-m, m + 1), np.arange(-m, m + 1), indexing="ij")
    d = np.column_stack([ix.ravel(), iy.ravel()]) * dx
    r = np.hypot(d[:, 0], d[:, 1])
    return d[(r > 0) & (r < SUPPORT * h)]


def lattice_scales(dx, h, kind):
    """Lattice constants of a full, uniform square lattice of spacing ``dx``.

    Returns ``(grad_scale, lap_scale, diag)``: ``1 / M_xx`` with the gradient moment
    ``M = sum_j V_j (x_j - x_i) (x) grad W_ij``; ``4 / sum_j c_ij r_ij^2`` for the Morris
    coefficients ``c_ij``; and the diagonal ``sum_j c_ij`` of an interior PPE row (with
    ``lap_scale`` applied).
    """
    d = lattice_offsets(dx, h)
    r = np.hypot(d[:, 0], d[:, 1])
    dw = np.array([kernel_dw(kind, ri, h) for ri in r])
    vol = dx * dx
    mxx = -np.sum(vol * d[:, 0] ** 2 * dw / r)
    c = -2.0 * vol * r * dw / (r * r + (ETA * h) ** 2)
    lap_scale = 4.0 / np.sum(c * r * r)
    return 1.0 / mxx, lap_scale, lap_scale * np.sum(c)


def lattice_sigma(dx, h, kind):
    """Kernel sum ``sum_j V_j W_ij`` (self included) on a full square lattice."""
    m = int(math.ceil(SUPPORT * h / dx)) + 1
    ix, iy = np.meshgrid(np.arange(-m, m + 1), np.arange(-m, m + 1), indexing="ij")
    r = np.hypot(ix.ravel(), iy.ravel()) * dx
    return float(sum(dx * dx * kernel_w(kind, ri, h) for ri in r))


class IncompressibleFluid:
    """The ISPH fluid of a ``FluidSection`` and, if given, its ``WallsSection`` walls.

    Fields of the fluid body: ``x, v, a, p, vol, m, nu, divr, alpha, grad_c, normal, class``
    (``class``: 0 interior, 1 near-surface, 2 free surface, 3 splashed), and with shifting
    ``dr``.
    """

    fields = (
        FieldSpec("x", (2,)), FieldSpec("v", (2,)), FieldSpec("a", (2,)), FieldSpec("p"),
        FieldSpec("vol"), FieldSpec("m"), FieldSpec("nu"), FieldSpec("divr"),
        FieldSpec("alpha"), FieldSpec("sigma"), FieldSpec("grad_c", (2,)),
        FieldSpec("normal", (2,)),
        FieldSpec("class", (), np.int8),
    )
    shifting_fields = (FieldSpec("dr", (2,)),)
    output_fields = ("x", "v", "p", "divr", "class")

    def __init__(self, cfg, walls_cfg, dx, sph, gravity, structures=()):
        self.cfg = cfg
        self.dx = dx
        self.h = sph.h_over_dx * dx
        self.kernel = KERNELS[sph.kernel]
        self.eta2 = (ETA * self.h) ** 2
        self.rho = cfg.material.rho0
        self.nu0 = cfg.material.nu
        self.gravity = np.asarray(gravity, dtype=np.float64)
        x = fill_shapes(cfg.blocks, dx)
        self.walls = (Walls(walls_cfg, dx, [st.body["x"] for st in structures])
                      if walls_cfg is not None else None)
        if self.walls is not None:  # fluid particles on a wall site are dropped
            near_start, _ = find_neighbors(x, self.walls.body["x"], 0.5 * dx)
            x = x[np.diff(near_start) == 0]
        for st in structures:  # and so are those on a site of a coupled structure
            near_start, _ = find_neighbors(x, st.body["x"], 0.5 * dx)
            x = x[np.diff(near_start) == 0]
        if cfg.jitter > 0.0:  # one realization of the initial lattice (fluid.jitter)
            rng = np.random.default_rng(cfg.jitter_seed)
            x = x + cfg.jitter * dx * rng.uniform(-1.0, 1.0, size=x.shape)
        self.body = b = Body("fluid", "fluid", len(x))
        b.allocate(self.fields)
        self.shifting = Shifting(cfg.shifting, self.h) if cfg.shifting is not None else None
        if self.shifting is not None:
            b.allocate(self.shifting_fields)
        b["x"][:] = x
        b["vol"][:] = dx * dx
        b["m"][:] = self.rho * dx * dx
        b["nu"][:] = self.nu0
        b["v"][:] = cfg.initial_velocity
        self.nf = b.n
        # boundary particles: the fixed walls, then the particles of the coupled structures
        # (moving boundaries, PHYSICS.md §5); the loops see them all as "wall" rows
        self.n_walls = self.walls.body.n if self.walls is not None else 0
        self.structures = list(structures)  # ElasticBody objects, fixed order
        self.ns = sum(s.body.n for s in self.structures)
        self.nw = self.n_walls + self.ns
        n = self.nf + self.nw
        self.incremental = cfg.projection == "incremental"
        if self.incremental and self.ns:
            raise ValueError("fluid.projection = \"incremental\" with coupled structures is "
                             "not supported")
        # the last pressure increment phi (incremental projection): the next solve's warm start
        self.phi_all = np.zeros(n)
        self.relax_all = np.zeros(n)  # and the density relaxation's pressure q (the same)
        # p^n exists once a pressure has been solved for; before the first step of an
        # incremental run it is the initial pressure (_initial_pressure)
        self.p_known = False
        self.drops = np.zeros(self.nf, dtype=bool)
        self._acc_lag = np.zeros((self.nf, 2))  # grad p^n / rho of the step
        self.p_surface = np.zeros(self.nf)  # the surface rows' target (_surface_pressure)
        self._gb_cache = None  # _wall_body_force of the step (mirror walls)
        self.incremental_step = False  # this step's projection is the incremental one
        # boundary velocity u_b and body force g - a_b of the boundary rows (Adami)
        self.v_b = np.zeros((self.nw, 2))
        self.g_b = np.tile(self.gravity, (self.nw, 1))
        self.rigid = None  # free bodies whose rigid-body motion the PPE solves for
        self.g_star = None  # with them: the boundary rows' acceleration in div u*
        self._pair_w = None  # interface_weights: the pair weights (identity but waterline)
        self._waterline = None  # waterline_rows, once per free-surface detection
        # rho c / rho_s on structure rows whose acceleration the PPE takes implicitly
        self.implicit = np.zeros(self.nw)
        # stacked fluid + boundary arrays seen by the loops (boundary after the fluid)
        self.x_all = np.zeros((n, 2))
        self.v_all = np.zeros((n, 2))
        self.vol_all = np.full(n, dx * dx)
        self.nu_all = np.full(n, self.nu0)
        self.p_all = np.zeros(n)
        self.wall_n = np.zeros((self.nw, 2))
        self.guard_force = np.zeros((self.ns, 2))
        self._guard_dv = np.zeros((self.nf, 2))  # work arrays of the kinematic guard
        self._guard_row = np.zeros(self.nf, dtype=np.int64)
        self._shift_lo = np.full((self.nf, 3), -np.inf)  # the Taylor correction's limiter
        self._shift_hi = np.full((self.nf, 3), np.inf)
        self._shift_scratch = np.zeros((self.nf, 2))  # work arrays of the shift's guard
        self._zero_b = np.zeros((self.nw, 2))  # (grown when periodic images are added)
        if self.walls is not None:
            xw = self.walls.body["x"]
            self.x_all[self.nf:self.nf + self.n_walls] = xw
            self.wall_n[:self.n_walls] = self._fixed_wall_normals(xw)
        self.set_structures(np.zeros((self.ns, 2)), np.zeros((self.ns, 2)))
        self.grad_scale, self.lap_scale, self.diag_ref = lattice_scales(dx, self.h, self.kernel)
        self.sigma0 = lattice_sigma(dx, self.h, self.kernel)
        self.n_full = len(lattice_offsets(dx, self.h))
        self.ppe = PressureSolver(cfg.ppe)
        self.last_stats = PPEStats()
        self.v_old = np.zeros((self.nf, 2))
        # weight of u^{n+1} in the position update (the rest on u^n)
        self.w_new = 0.5 if cfg.position_update == "trapezoid" else 1.5
        self.v_star = np.zeros((self.nf, 2))
        self.div = np.zeros(self.nf)
        self.grad_p = np.zeros((self.nf, 2))
        self.grad_v = np.zeros((self.nf, 2, 2))
        self.L = np.zeros((self.nf, 2, 2))
        self._L_key, self._L_x = None, np.empty((0, 2))  # what self.L was computed for
        # viscosity law, implicit viscous step, periodicity (rheology.py, viscous.py,
        # periodic.py); the plain explicit Newtonian fluid takes none of these paths
        self.viscosity_law = None
        if (cfg.material.viscosity != "newtonian" or cfg.viscous_step == "implicit"
                or cfg.viscous_operator == "stress"):
            from fsi_sph.fluid.rheology import ViscosityLaw
            from fsi_sph.fluid.viscous import ViscousStats

            self.viscosity_law = ViscosityLaw(cfg, dx, gravity)
            self.viscous_stats = ViscousStats()
            self.morris_pre = None  # the implicit stress step's AMG hierarchy (viscous.py)
        self.dt_limits = {}
        self.periodic = None
        if cfg.periodic_x is not None:
            from fsi_sph.fluid.periodic import Periodic

            self.periodic = Periodic(cfg.periodic_x, self)
        self.update_neighbors()
        warm_up(self.kernel)

    @property
    def n(self):
        return self.nf

    def _fixed_wall_normals(self, xw):
        """Outward normals of the fixed wall particles over the rigid boundary: the walls and
        the clamped particles of the coupled structures (which never move). A structure's
        root set into the floor thus closes the floor: the wall particles beside it keep an
        upward normal instead of one tilted towards the gap the root fills, through which
        fluid particles otherwise sank into the seam between wall and root (seen under a
        clamped plate holding water). The structures' own normals are set each step with
        their positions."""
        clamped = [st.body["x"][~st.body["free"]] for st in self.structures
                   if "free" in st.body]
        xb = np.vstack([xw, *clamped]) if clamped else xw
        start, j = find_neighbors(xb, xb, SUPPORT * self.h, exclude_self=True)
        normals = np.zeros((len(xb), 2))
        K.wall_normals(xb, np.full(len(xb), self.dx * self.dx), start, j, self.h, self.kernel,
                       normals)
        return normals[:len(xw)]

    # ------------------------------------------------------------------ coupling
    def set_structures(self, v_bar, a_bar, a_other=None, rho_s=None, rigid=None):
        """Moving boundary (PHYSICS.md §5): the structures' current positions, their velocity
        averaged over the last sub-cycle ``v_bar`` and acceleration ``a_bar`` (stacked in
        ``self.structures`` order). ``rigid = (a_rigid, body_of, mass, inertia, centre)``:
        the structures are free bodies that the solve sees as rigid, their rigid-body
        acceleration under the fluid's force taken implicitly (:meth:`_rigid_terms`);
        ``a_rigid`` is the rigid-body part of ``a_bar`` at each particle."""
        if not self.ns:
            return
        k = self.nf + self.n_walls
        for s in self.structures:
            xs = s.body["x"]
            self.x_all[k:k + s.body.n] = xs
            # outward surface normals of the structure over its own particles (zero inside),
            # with the body's total-Lagrangian neighbour pairs (fixed; no search per step)
            K.wall_normals(xs, self.vol_all[k:k + s.body.n], s.nbr_start, s.nbr_j, self.h,
                           self.kernel, self.wall_n[k - self.nf:k - self.nf + s.body.n])
            k += s.body.n
        self.v_b[self.n_walls:] = v_bar
        self.v_all[self.nf + self.n_walls:] = v_bar
        if a_other is None:  # explicit: the last sub-cycle's mean acceleration
            self.g_b[self.n_walls:] = self.gravity - a_bar
        else:  # implicit: every acceleration but the fluid's; the fluid's is solved for
            self.g_b[self.n_walls:] = self.gravity - a_other
            self.implicit[self.n_walls:] = self.rho * self.grad_scale / rho_s
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
            self.g_star = self.g_b.copy()
            self.g_star[self.n_walls:] = self.gravity
        self.rigid = rigid
        if rigid is not None:
            # the solve sees each body as rigid: its rows take a_w = g + a_rigid(p), so
            # g - a_w = -a_rigid(p), all of it in the matrix (_rigid_terms); div u* takes
            # u_w + dt (g - a_rigid,last) (a_rigid,last: the rigid part of the last
            # sub-cycle's mean acceleration), so that the step ends at
            # u_w + dt (a_rigid(p) - a_rigid,last), the increment of the rigid motion taken
            # implicitly (with the last one's, the explicit scheme's lagged velocity)
            self.g_star = self.g_b.copy()
            self.g_star[self.n_walls:] = self.gravity - rigid[0]
            self.g_b[self.n_walls:] = 0.0

    def _rigid_terms(self):
        """``(U, G)`` of the free bodies' rigid-body rows, added to the PPE matrix as ``U G``
        (scaled like the other boundary rows by ``diag_ref``). A structure row ``w`` of body
        ``b`` is Adami's extrapolation with the body's rigid acceleration under the fluid's
        generalised force ``G_b p`` (x, y force; torque about the centre of mass)::

            p_w - sum_f w_wf p_f + rho rbar_w . (F_b / M_b + (T_b / I_b) z x r_w) = 0

        (:func:`fsi_sph.sph.interface.rigid_mode_terms`; ``g - a_w`` without the fluid's
        share is 0: the body's weight gives it ``g``, its internal forces neither net force
        nor torque, and its deformation is not seen)."""
        from fsi_sph.sph.interface import rigid_mode_terms

        _, body_of, mass, inertia, centre = self.rigid
        nb0 = self.nf + self.n_walls
        n = len(self.p_all)
        ns = n - nb0
        k0 = self.wf_start[self.n_walls]
        sf_start = np.ascontiguousarray(self.wf_start[self.n_walls:] - k0)
        sf_j = np.ascontiguousarray(self.wf_j[k0:])
        rbar = np.zeros((ns, 2))
        G = np.zeros((3 * len(mass), n))
        rigid_mode_terms(self.x_all[nb0:], self.vol_all[nb0:], self.x_all[:self.nf],
                         self.vol_all[:self.nf], sf_start, sf_j, self.h, self.kernel,
                         self.grad_scale, self.interface_weights(), body_of, centre, nb0, rbar,
                         G)
        lever = self.x_all[nb0:] - centre[body_of]
        c = self.diag_ref * self.rho
        U = np.zeros((n, 3 * len(mass)))
        rows = nb0 + np.arange(ns)
        U[rows, 3 * body_of] = c * rbar[:, 0] / mass[body_of]
        U[rows, 3 * body_of + 1] = c * rbar[:, 1] / mass[body_of]
        U[rows, 3 * body_of + 2] = c * (rbar[:, 1] * lever[:, 0]
                                        - rbar[:, 0] * lever[:, 1]) / inertia[body_of]
        return U, G

    def extra_state(self):
        """State outside the fluid body's arrays that the next step needs (restart): the
        stacked fluid, wall and structure pressures, the warm start of the next solve, and
        whether a pressure is known yet (the incremental projection's p^n, the mirror walls'
        lagged gradient)."""
        state = {"p_all": self.p_all.copy(), "p_known": np.array(self.p_known)}
        if self.incremental:
            state["phi_all"] = self.phi_all.copy()
        return state

    def load_extra_state(self, state):
        p = state["p_all"]
        if len(p) == len(self.p_all):
            self.p_all[:] = p
        else:  # periodic images come and go: fluid and walls are what carries over, the
            # images' rows are filled from their originals at the next neighbour update
            n = self.nf + self.n_walls
            self.p_all[:n] = p[:n]
        if "phi_all" in state:  # (the increment's warm start is resized when needed)
            self.phi_all = np.array(state["phi_all"])
        if "p_known" in state:
            self.p_known = bool(state["p_known"])
        if self.walls is not None:
            self.walls.body["p"][:] = self.p_all[self.nf:self.nf + self.n_walls]

    def at_snapshot(self):
        """Called when a snapshot is written: rebuild the AMG hierarchy at the next solve."""
        self.ppe.reset()

    def structure_pressure(self):
        """Pressure of the structure particles from the last solve (stacked)."""
        return self.p_all[self.nf + self.n_walls:]

    # ------------------------------------------------------------------ helpers
    def _sync(self):
        """Copy the fluid's positions, velocities and pressures into the stacked arrays."""
        nf = self.nf
        self.x_all[:nf] = self.body["x"]
        self.v_all[:nf] = self.body["v"]
        self.p_all[:nf] = self.body["p"]
        if self.periodic is not None:
            self.periodic.sync(self)

    # ------------------------------------------------------------------ step verbs
    def stable_dt(self):
        """[F 48]: ``min(cfl h / |u|max, 0.125 h^2 / nu_max, 0.25 sqrt(h / |a|max), dt_max)``,
        ``|a|max`` at least ``|g|``."""
        b = self.body
        vmax = math.sqrt(float(np.max(np.einsum("ij,ij->i", b["v"], b["v"]), initial=0.0)))
        amax = math.sqrt(float(np.max(np.einsum("ij,ij->i", b["a"], b["a"]), initial=0.0)))
        amax = max(amax, float(np.hypot(*self.gravity)))
        dt = self.cfg.dt_max
        numax = float(np.max(b["nu"], initial=0.0))
        lim = self.dt_limits  # every limit, recorded (the implicit step drops the viscous one)
        lim["advective"] = self.cfg.cfl * self.h / vmax if vmax > 0.0 else math.inf
        lim["viscous"] = 0.125 * self.h * self.h / numax if numax > 0.0 else math.inf
        lim["force"] = 0.25 * math.sqrt(self.h / amax) if amax > 0.0 else math.inf
        lim["nu_max"] = numax
        dt = min(dt, lim["advective"], lim["force"])
        if self.cfg.viscous_step == "explicit":
            dt = min(dt, lim["viscous"])
        return dt

    def update_neighbors(self):
        """CSR neighbour lists at the current positions: fluid rows over fluid and wall
        sources (``ff_*``), wall rows over fluid sources (``wf_*``)."""
        if self.periodic is not None:
            self.periodic.rebuild(self)
        self._sync()
        r = SUPPORT * self.h
        xf = self.x_all[:self.nf]
        self.ff_start, self.ff_j = find_neighbors(xf, self.x_all, r, exclude_self=True)
        if self.nw:  # boundary rows (walls, structures) over fluid sources
            self.wf_start, self.wf_j = find_neighbors(self.x_all[self.nf:], xf, r)
        else:
            self.wf_start, self.wf_j = np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64)
        if self.periodic is not None:
            self.periodic.boundary_lists(self)
        self._set_row_roles()

    def detect_free_surface(self):
        """``div r``, ``alpha`` [F 21], classes and normals [F 27-28] of the fluid rows."""
        b = self.body
        free_surface.detect(
            self.x_all, self.vol_all, self.ff_start, self.ff_j, self.nf, self.h, self.kernel,
            b["divr"], b["grad_c"], b["sigma"], b["alpha"], b["class"], b["normal"],
            scan=self.cfg.surface_scan, isolated=self.cfg.surface_isolated_rows)
        self._waterline = None  # waterline_rows: found anew for this alpha

    def _correction_matrices(self):
        """``self.L`` [F 13-14] at the current stacked positions, computed once per set of
        positions and neighbour lists: the mu(I) predictor's gradients, the incremental
        projection's lagged pressure gradient and the PPE all need it at the same positions
        within a step."""
        key = (id(self.ff_start), id(self.ff_j))
        if (key == self._L_key and self._L_x.shape == self.x_all.shape
                and np.array_equal(self._L_x, self.x_all)):
            return
        K.correction_matrices(self.x_all, self.vol_all, self.ff_start, self.ff_j, self.h,
                              self.kernel, self.L)
        if self._L_x.shape != self.x_all.shape:
            self._L_x = np.empty_like(self.x_all)
        self._L_x[:] = self.x_all
        self._L_key = key

    def _gradients(self, free_slip=False):
        """Corrected gradients of p and u at the current positions [F 7, F 13-14];
        ``free_slip``: boundary particles carry no velocity difference (zero normal
        derivative of u at walls and structures)."""
        self._sync()
        self._correction_matrices()
        K.gradients(self.x_all, self.p_all, self.v_all, self.vol_all, self.L, self.ff_start,
                    self.ff_j, self.nf, self.h, self.kernel, self.grad_p, self.grad_v,
                    self.nf if free_slip else -1)

    def shift(self, dt):
        """Particle shifting [F 22-33] with the Taylor correction of u and p [F 33]."""
        if self.shifting is None:
            return
        b = self.body
        self._sync()
        self.shifting.vectors(self.x_all, self.v_all, self.vol_all, self.ff_start, self.ff_j,
                              self.nf, self.h, self.kernel, dt, b["class"], b["normal"], b["dr"])
        self._guard_shift(b["dr"])
        if self.shifting.cfg.taylor_correction:
            # Newtonian fluid: the velocity's Taylor correction [F 33] takes the walls as
            # free-slip. With their zero (no-slip) velocity in the gradient, a particle that
            # slides along a wall at speed U sees a shear of order U / dx, and every shift
            # away from the wall (the usual direction: the colour gradient pushes particles
            # off a wall they came too close to) added dr U / dx to its speed. A thin sheet
            # on the floor at 2 m/s threw particles at 5-9 m/s that way (measured).
            # (The viscosity laws keep their no-slip walls: viscous.py.)
            free_slip = self.viscosity_law is None
            self._gradients(free_slip=free_slip)
            K.neighbour_bounds(self.p_all, self.v_all, self.ff_start, self.ff_j, self.nf,
                               self.nf if free_slip else -1, self._shift_lo, self._shift_hi)
        self.shifting.apply(b["dr"], self.grad_p, self.grad_v, self._shift_lo,
                            self._shift_hi, b["x"], b["p"], b["v"])
        self._sync()

    def predict(self, dt):
        """Intermediate velocity [F 16] (with the Smagorinsky viscosity [F 3] if enabled),
        then, with ``fluid.wall_contact = "inelastic"``, the walls' contact on it
        (:meth:`_inelastic_contact`)."""
        self._predict(dt)
        if self.cfg.wall_contact == "inelastic":
            self._inelastic_contact(dt)

    def _inelastic_contact(self, dt):
        """The kinematic guard (:func:`_kernels.boundary_guard` with ``stop``, swept over
        the step ``dt u*``) applied to the intermediate velocity ``u*`` at the fixed walls,
        before the pressure solve: a particle in the guard's band or reaching it within the
        step loses its whole velocity into the wall (restitution 0), so the projection does
        not stop it with an impulsive pressure ``~ rho u_n dx / dt`` that its neighbours
        also feel (at a granular front 5-10 kPa against a hydrostatic 0.1-0.2 kPa, which
        pushed the tip particles ahead; other kicks at the thin front remain, session notes
        2026-11-30f). No equation in PHYSICS.md: a contact rule for grains."""
        self._shift_scratch[:] = self.v_star  # (free outside the shift's guard)
        self._guard_walls(dt, self._shift_scratch, self.v_star, stop=True)

    def _guard_walls(self, dt, v_old, v, stop=False):
        """The kinematic guard at the fixed walls (and their periodic images)."""
        nf = self.nf
        (wlo, whi, wgap), _ = self._guard_ranges()
        if whi > wlo:
            K.boundary_guard(self.x_all, self.ff_start, self.ff_j, nf, wlo, whi,
                             self.wall_n[:whi - nf], self.v_b[:whi - nf], wgap, dt, v_old, v,
                             self._guard_dv, self._guard_row, stop, self.w_new)

    def _predict(self, dt):
        if self.incremental and not self.p_known:
            self._initial_pressure(dt)
        self.incremental_step = self.incremental
        self._gb_cache = None  # new positions and p^n: the mirror walls' force anew
        if self.incremental_step:
            self._carried_pressure()
            self._refresh_wall_pressure()
        if self.viscosity_law is not None:  # mu(I) or the implicit step (viscous.py)
            from fsi_sph.fluid.viscous import predict

            return predict(self, dt)
        b = self.body
        self._sync()
        if self.cfg.smagorinsky is not None:
            self._gradients()
            cs_dx2 = (self.cfg.smagorinsky.cs * self.dx) ** 2
            K.smagorinsky(self.grad_v, cs_dx2, self.nu0, b["nu"])
            self.nu_all[:self.nf] = b["nu"]
        self.v_old[:] = b["v"]
        g = self.gravity
        K.predict_velocity(self.x_all, self.v_all, self.vol_all, self.nu_all, self.ff_start,
                           self.ff_j, self.nf, self.h, self.kernel, self.eta2, g[0], g[1], dt,
                           self.v_star)
        if self.incremental_step:  # [Goda 1979]: u* = u^n + dt (visc + g - grad p^n / rho)
            self.v_star -= dt * self.lagged_pressure_acceleration()

    def _initial_pressure(self, dt):
        """``p^0`` of the incremental projection: the standard PPE's pressure for
        ``u* = u^0 + dt g`` (no viscous term), the pressure that holds the body force against
        the walls and the incompressibility of the initial state; hydrostatic in a fluid at
        rest. (``p^0 = 0`` would give a first step whose increment builds up the whole
        hydrostatic pressure against walls that enter with ``u*_w = u_w``.)"""
        self.incremental_step = False
        self.v_star[:] = self.body["v"] + dt * self.gravity
        self.solve_pressure(dt)

    def _carried_pressure(self):
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
        b = self.body
        self.drops = 4 * self._fluid_neighbour_counts() < self.n_full
        b["p"][self.drops] = 0.0

    def _refresh_wall_pressure(self):
        """Incremental projection: the fixed walls' ``p^n`` re-extrapolated from the fluid's
        ``p^n`` at the current positions by the standard wall row (Adami; ``ppe_fill``),
        ``p_w = <p_f>_w + rho g . (x_w - <x_f>_w)`` (Shepard averages ``<>_w`` over the fluid
        neighbours), 0 without fluid neighbours. The last solve's wall pressures belong to
        the last step's neighbours: a wall particle the front has just reached still has
        ``p_w = 0``, which the lagged gradient would read as suction into the wall. Since the
        rows are linear, ``p^{n+1}_w = p^n_w + phi_w`` still satisfies the standard row, and
        the increment's wall rows are homogeneous (``increment_rhs`` gives 0 there)."""
        nf, nwall = self.nf, self.n_walls
        if not nwall:
            return
        self._sync()
        xw = self.x_all[nf:nf + nwall]
        mean = np.empty((nwall, 3))  # <p_f>, <x_f>, <y_f>
        for k, field in enumerate((self.p_all, self.x_all[:, 0], self.x_all[:, 1])):
            K.shepard_at(xw, self.x_all, np.ascontiguousarray(field), self.wf_start,
                         self.wf_j, self.h, self.kernel, mean[:, k])
        rbar = xw - mean[:, 1:]
        gb = self._wall_body_force()[:nwall]
        pw = mean[:, 0] + self.rho * np.einsum("ij,ij->i", gb, rbar)
        self.p_all[nf:nf + nwall] = np.where(np.isfinite(pw), pw, 0.0)
        self._sync()  # (the periodic wall images)

    def lagged_pressure_acceleration(self):
        """``grad p^n / rho`` of the fluid rows for the incremental predictor (Goda 1979),
        with the correction step's operator (:meth:`_pressure_gradient`) at the current
        positions: the last solve's ``p`` (Taylor-corrected by the shift), walls included."""
        self._sync()
        self._correction_matrices()
        out = np.empty((self.nf, 2))
        self._pressure_gradient(self.p_all, out)
        out /= self.rho
        self._acc_lag = out
        return out

    def _pressure_gradient(self, p, out, floor="pressure"):
        """The correction step's gradient of the stacked field ``p`` at the fluid rows
        (``self.L`` current): conservative [F 10] or corrected [F 7, F 13], over the fluid,
        the walls and the periodic images (the structures are left to the coupling).
        With ``fluid.wall_suction = false`` the fixed walls cannot pull
        (:func:`_kernels.wall_floor`): ``floor`` = "pressure" (a pressure: hydrostatic
        carry), "increment" (an increment of it: none) or None (no floor: the density
        relaxation's displacement pressure). The floor acts on the rows that are not
        interior (free-surface and near-surface class, :meth:`_floor_rows`)."""
        jmax = self.nf + self.nw - self.ns
        rg = self.no_rg
        floored = self.no_rows
        if not self.cfg.wall_suction and floor is not None:
            floored = self.wall_rows
            if floor == "pressure":  # the walls' own extrapolation force (_wall_body_force)
                rg = self.floor_rg
                if self.cfg.wall_pressure == "mirror":
                    rg[self.nf:self.nf + self.n_walls] = (
                        self.rho * self._wall_body_force()[:self.n_walls])
        rows = self._floor_rows() if floored is not self.no_rows else self.no_rows
        return self._gradient_kernel(p, jmax, floored, rows, rg, out)

    def _gradient_kernel(self, p, jmax, floored, floor_row, rg, out):
        form = self.cfg.pressure_gradient
        if form == "conservative":
            K.pressure_gradient(self.x_all, p, self.vol_all, self.ff_start, self.ff_j, self.nf,
                                self.h, self.kernel, self.grad_scale, jmax, floored, floor_row,
                                rg, out)
            return out
        K.corrected_pressure_gradient(self.x_all, p, self.vol_all, self.L, self.ff_start,
                                      self.ff_j, self.nf, self.h, self.kernel, jmax, floored,
                                      floor_row, rg, out)
        if form == "interface_conservative" and self.ns:
            # the rows beside a structure take the pair form [F 10], the one that balances the
            # interface force [F 46-47] (under a uniform pressure both vanish there); the
            # waterline rows keep the corrected form (interface_weights)
            rows = self._structure_rows(jmax) & ~self.waterline_rows()
            cons = np.empty_like(out)
            K.pressure_gradient(self.x_all, p, self.vol_all, self.ff_start, self.ff_j, self.nf,
                                self.h, self.kernel, self.grad_scale, jmax, floored, floor_row,
                                rg, cons)
            out[rows] = cons[rows]
        return out

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
        if self._waterline is None or len(self._waterline) != self.nf:
            if self.cfg.pressure_gradient != "interface_conservative" or not self.ns:
                self._waterline = np.zeros(self.nf, dtype=bool)
            else:
                near = self._structure_rows(self.nf + self.nw - self.ns)
                self._waterline = near & (self.body["alpha"] == 0.0)
        return self._waterline

    def interface_weights(self):
        """Per fluid row, the matrix ``W_f`` that weights its pair terms with the structure
        [F 46-47] (``sph.interface.pair_pressure_forces``, the rigid and implicit rows
        of the solve): the identity, or ``L_f / c`` on the waterline rows
        (:meth:`waterline_rows`), so that ``c W_f = L_f`` there."""
        if self._pair_w is None or len(self._pair_w) != self.nf:
            self._pair_w = np.tile(np.eye(2), (self.nf, 1, 1))
            self._pair_w_rows = np.zeros(0, dtype=np.int64)
        self._pair_w[self._pair_w_rows] = np.eye(2)
        rows = np.flatnonzero(self.waterline_rows())
        if len(rows):
            self._correction_matrices()
            self._pair_w[rows] = self.L[rows] / self.grad_scale
        self._pair_w_rows = rows
        return self._pair_w

    def _structure_rows(self, jmax):
        """Fluid rows with a coupled structure particle (global index ``>= jmax``) among
        their neighbours (``pressure_gradient = "interface_conservative"``), found once per
        neighbour update (:meth:`_set_row_roles` clears it)."""
        if self._near_structure is None:
            near = np.zeros(self.nf, dtype=bool)
            near[self._row_of()[self.ff_j[:self.ff_start[self.nf]] >= jmax]] = True
            self._near_structure = near
        return self._near_structure

    def _row_of(self):
        """The fluid row of each entry of the fluid rows' neighbour lists."""
        if self._row_of_pairs is None:
            self._row_of_pairs = np.repeat(np.arange(self.nf),
                                           np.diff(self.ff_start[:self.nf + 1]))
        return self._row_of_pairs

    def _floor_rows(self):
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
        that no floor at all shows too; docs/session_notes_2026-12-01c.md)."""
        return self.body["class"] != K.INTERIOR

    def _set_row_roles(self):
        """Roles of the stacked rows ``[fluid | walls | structures | periodic images]``, set
        whenever the layout may change (:meth:`update_neighbors`): ``fluid_of``, the fluid
        particle a row is (itself or an image's original; -1 for the others: the viscous
        step's unknown of a row, the collision model's partner); ``wall_rows``, the fixed
        wall particles and the walls' periodic images (the floor of ``wall_suction =
        false``), with ``floor_rg = rho g`` on them (the mirror walls' rows are refreshed
        in :meth:`_pressure_gradient`); ``no_rows`` all False, ``no_rg`` all 0."""
        n = len(self.x_all)
        self.fluid_of = np.full(n, -1, dtype=np.int64)
        self.fluid_of[:self.nf] = np.arange(self.nf)
        self.wall_rows = np.zeros(n, dtype=np.bool_)
        self.wall_rows[self.nf:self.nf + self.n_walls] = True
        if self.periodic is not None:
            rows, src = self.periodic.rows, self.periodic.src
            self.fluid_of[rows] = np.where(src < self.nf, src, -1)
            self.wall_rows[rows] = src >= self.nf
        # counted anew for these lists: _fluid_neighbour_counts, _structure_rows, _row_of
        self._n_fluid = self._near_structure = self._row_of_pairs = self._waterline = None
        self.no_rows = np.zeros(n, dtype=np.bool_)
        self.no_rg = np.zeros((n, 2))
        self.floor_rg = np.zeros((n, 2))
        self.floor_rg[self.wall_rows] = self.rho * self.gravity

    def velocity_divergence(self, v_fluid, v_wall=(0.0, 0.0), out=None):
        """``div u`` of the fluid rows for a fluid velocity field and a velocity of the
        boundary particles (uniform, or one row per boundary particle)."""
        self.v_all[:self.nf] = v_fluid
        self.v_all[self.nf:] = v_wall
        out = np.zeros(self.nf) if out is None else out
        K.velocity_divergence(self.x_all, self.v_all, self.vol_all, self.ff_start, self.ff_j,
                              self.nf, self.h, self.kernel, self.grad_scale, out)
        self.v_all[self.nf:] = self.v_b  # what the viscous term sees
        return out

    def solve_pressure(self, dt):
        """Assemble and solve the PPE [F 17, F 20-21]; fluid and wall pressures; PPEStats.
        Incremental projection: the PPE for the increment ``phi`` [Goda 1979]
        (:meth:`_solve_increment`)."""
        import time

        b = self.body
        t0 = time.perf_counter()
        # Walls enter div u* with the predicted velocity u*_w = u_w + dt (g - a_w) of a static
        # wall (u_w = a_w = 0), the velocity that Adami's extrapolation (the g term of the
        # wall rows) takes back to u_w in the correction. With u*_w = u_w instead, the wall
        # flux would be counted twice, once through div u* and once through the extrapolated
        # wall pressure, and a tank at rest would not stay at rest.
        # A moving boundary (structure particle) likewise enters with u_b + dt (g - a_b)
        # when its acceleration a_b is known (explicit), with u_b + dt g when the solve takes
        # it implicitly (set_structures).
        # Incremental projection [Goda 1979]: the walls' p^n already holds the g term
        # (_refresh_wall_pressure), so the increment's wall rows carry none: the walls enter
        # with their own velocity, which is also the no-slip mirror target of the viscous
        # step (viscous.py), so both see the same u*_w.
        g_star = self.g_b if self.g_star is None else self.g_star
        vb_star = self.v_b.copy() if self.incremental_step else self.v_b + dt * g_star
        if self.periodic is not None:
            self.periodic.boundary_star(self, vb_star)
        self.velocity_divergence(self.v_star, vb_star, self.div)
        source = -self.rho / dt * self.div
        relax = self._relaxation_source(dt)
        if relax is not None and not self.incremental_step:
            source += relax
        self._correction_matrices()
        # rows whose kernel support is truncated (free surface, near it, or beside the end
        # of a wall) get the consistent (corrected) Laplacian and pressure gradient
        # (FluidSection.laplacian = "consistent": every row)
        if self.cfg.laplacian == "consistent":
            self.consistent = np.ones(self.nf, dtype=np.bool_)
        else:
            self.consistent = (b["class"] != K.INTERIOR) | (b["divr"] < DIVR_FULL)
        alpha = b["alpha"]
        if self.incremental_step:  # drops: free-surface rows (_carried_pressure)
            alpha = np.where(self.drops, 0.0, alpha)
        A, rhs = assemble(self.x_all, self.vol_all, alpha, source, self.L, self.consistent,
                          self.ff_start, self.ff_j,
                          self.wf_start, self.wf_j, self.nf, self.nw, self.h, self.kernel,
                          self.eta2, self.lap_scale, self.diag_ref, self.rho,
                          self._wall_body_force(), self.implicit,
                          self.interface_weights() if self.ns else None)
        if self.cfg.surface_offset > 0.0:
            self._offset_surface_rows(A, rhs, alpha)
        if self.incremental_step:
            p, stats = self._solve_increment(A, rhs, source, alpha, relax, t0)
        else:
            if self.periodic is not None:
                A, rhs = self.periodic.constrain(A, rhs, self.diag_ref)
            t1 = time.perf_counter()
            low_rank = self._rigid_terms() if self.rigid is not None else None
            p, stats = self.ppe.solve(A, rhs, self.p_all, self.nf, low_rank)
            stats.assemble_time = t1 - t0
            if self.incremental:  # the initial pressure p^0 (_initial_pressure)
                self.phi_all = np.zeros(len(p))
        if self.cfg.tension_cutoff:
            p = self._cut_tension(p)
        self.p_known = True
        self.p_all[:] = p
        b["p"][:] = p[:self.nf]
        if self.walls is not None:
            self.walls.body["p"][:] = p[self.nf:self.nf + self.n_walls]
        self.last_stats = stats
        self.A, self.rhs = A, rhs
        return stats

    def _surface_pressure(self):
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
        b = self.body
        if self.incremental_step:
            grad = self._acc_lag * self.rho
        else:
            grad = np.empty((self.nf, 2))
            self._pressure_gradient(self.p_all, grad)
        dpdn = np.einsum("ij,ij->i", b["normal"], grad)
        head = self.rho * np.maximum(-(b["normal"] @ self.gravity), 0.0)
        ps = self.cfg.surface_offset * self.dx * np.clip(-dpdn, 0.0, head)
        ps[np.diff(self.ff_start) == 0] = 0.0
        if self.incremental_step:
            ps[self.drops] = 0.0
        return ps

    def _offset_surface_rows(self, A, rhs, alpha):
        """Move the free-surface rows' target from ``p = 0`` to :meth:`_surface_pressure`:
        a row ``D_i p_i - alpha_i sum_j a_ij p_j = alpha_i source_i`` (:func:`ppe.assemble`,
        [F 20-21]) gets ``+ (1 - alpha_i) D_i p_s,i`` on its right-hand side (pure Dirichlet
        rows: ``p_i = p_s,i``). In place; the incremental projection's right-hand side
        (:func:`ppe.increment_rhs`) inherits it."""
        nf = self.nf
        blend = np.where(np.diff(self.ff_start) == 0, 0.0, np.clip(alpha, 0.0, 1.0))
        self.p_surface = self._surface_pressure()
        rhs[:nf] += (1.0 - blend) * A.diagonal()[:nf] * self.p_surface

    def _wall_body_force(self):
        """The body force ``g - a_b`` of the boundary rows in Adami's extrapolation
        ``p_w = <p_f> + rho (g - a_w) . (x_w - <x_f>)`` (``self.g_b``). With
        ``fluid.wall_pressure = "mirror"`` a fixed wall's row uses ``n (n . g) + c t (t .
        g)``: the hydrostatic term along its normal ``n`` in full, and along the wall
        (``t``) the share ``c`` of it that the fluid beside the wall carries itself, ``c =
        clip(t . G_w / (0.9 t . g), 0, 1)`` with ``G_w = <grad p_f / rho>_w`` the Shepard
        average of the last pressure's gradient taken over fluid neighbours only
        (:meth:`_fluid_only_gradient`). In a fluid at rest ``G = g`` (to 0.2-1.6 % next to
        a wall and its waterline, hence the 0.9: with ``c = t . G / t . g`` itself those
        few per cent drove currents of 0.02 sqrt(g H) in the tank) and nothing changes; for
        a droplet or a film on a vertical wall the fluid has no pressure gradient along the
        wall, ``c = 0``, and the droplet falls instead of being held by the walls'
        hydrostatic field (tests/unit/test_wall_droplet.py). A boundary rule with no
        equation in PHYSICS.md (which leaves the wall pressure to the implementation)."""
        if self.cfg.wall_pressure != "mirror" or not self.n_walls or not self.p_known:
            return self.g_b  # (before the first solve there is no gradient to read)
        nf, nwall = self.nf, self.n_walls
        gb = self.g_b.copy()  # (the structures' rows as set_structures left them)
        if self._gb_cache is not None:  # the fixed walls' rows: once per step (predict)
            gb[:nwall] = self._gb_cache
            return gb
        grad = self._fluid_only_gradient() / self.rho
        src = self.fluid_of
        avg = np.empty((nwall, 2))
        for k in range(2):
            field = np.where(src >= 0, grad[np.maximum(src, 0), k], 0.0)
            K.shepard_at(self.x_all[nf:nf + nwall], self.x_all, field, self.wf_start,
                         self.wf_j, self.h, self.kernel, avg[:, k])
        n = self.wall_n[:nwall]
        t = np.column_stack([-n[:, 1], n[:, 0]])
        along = np.einsum("ij,ij->i", t, np.where(np.isfinite(avg), avg, 0.0))
        g_t = t @ self.gravity
        with np.errstate(divide="ignore", invalid="ignore"):
            carried = np.clip(along / (CARRIED_FULL * g_t), 0.0, 1.0)
        # floors (within ~15 deg of level): the whole term, as Adami's (a floor's normals
        # wobble by a fraction of a degree next to a corner, and a few Pa of difference
        # from the exact hydrostatic wall pressure drive cm/s currents in a tank at rest)
        carried = np.where(np.abs(g_t) > 0.25 * np.linalg.norm(self.gravity), carried, 1.0)
        has_n = np.einsum("ij,ij->i", n, n) > 0.5
        mirror = n * (n @ self.gravity)[:, None] + (carried * g_t)[:, None] * t
        gb[:nwall] = np.where(has_n[:, None], mirror, gb[:nwall])
        self._gb_cache = gb[:nwall].copy()
        return gb

    def _fluid_only_gradient(self):
        """Corrected gradient [F 7, F 13] of the last pressure at the fluid rows over their
        fluid neighbours only (periodic fluid images included), with its own correction
        matrices: the fluid's pressure gradient without the walls' extrapolated pressures
        (a lone particle: 0). Computed only on the rows beside a fixed wall (the others get
        0: nothing reads them)."""
        nf = self.nf
        start = np.empty(nf + 1, dtype=np.int64)
        j = K.fluid_sublists(self.ff_start, self.ff_j, self.fluid_of, self._rows_beside_walls(),
                             start)
        L = np.empty((nf, 2, 2))
        K.correction_matrices(self.x_all, self.vol_all, start, j, self.h, self.kernel, L)
        gp = np.empty((nf, 2))
        K.corrected_pressure_gradient(self.x_all, self.p_all, self.vol_all, L, start, j, nf,
                                      self.h, self.kernel, len(self.x_all), self.no_rows,
                                      self.no_rows, self.no_rg, gp)
        return gp

    def _rows_beside_walls(self):
        """The fluid rows that are neighbours of a fixed wall particle: the only rows whose
        fluid-only gradient the walls' Shepard average reads (:meth:`_wall_body_force`)."""
        near = np.zeros(self.nf, dtype=bool)
        src = self.fluid_of[self.wf_j[:self.wf_start[self.n_walls]]]
        near[src[src >= 0]] = True
        return near

    def _cut_tension(self, p):
        """``max(p, 0)`` for a cohesionless material (``fluid.tension_cutoff``): the fluid,
        the fixed walls (whose pressure is extrapolated from the fluid's) and the periodic
        images; with the incremental projection the increment that :meth:`correct` applies
        becomes ``max(p^n + phi, 0) - p^n``. Where the cut-off acts, ``u^{n+1}`` keeps the
        divergence of ``u*``: the material opens instead of pulling (no tension between
        grains)."""
        rows = np.ones(len(p), dtype=bool)  # [fluid | walls | structures or images]
        rows[self.nf + self.n_walls:self.nf + self.nw] = False  # structures: their own stress
        cut = np.where(rows, np.maximum(p, 0.0), p)
        if self.incremental_step:
            self.phi_all += cut - p
        return cut

    def _relaxation_source(self, dt):
        """The density-error term of the PPE source, or None without density relaxation.

        Density-error (compression-only) term of the stabilised ISPH source (Asai et al.
        2012): lap p = rho div u* / dt + relax rho (sigma0 - sigma) / (sigma0 dt^2), applied
        where sigma > sigma0 in the interior, so that particles that have drifted together
        (a divergence-free projection does not see it) are pushed apart."""
        b = self.body
        relax = self.cfg.density_relaxation
        if relax <= 0.0:
            return None
        excess = (b["sigma"] - self.sigma0) / self.sigma0
        if self.cfg.density_relaxation_sign == "compression":
            excess = np.maximum(excess, 0.0)
        else:  # "both": an expansion (sigma < sigma0) pulls back too, where the kernel
            # support is full (a truncated support also has sigma < sigma0); under a
            # sustained shear the shifting otherwise lets a layer slowly dilate (issue 6)
            excess[(excess < 0.0) & self._truncated_for_relaxation()] = 0.0
        excess[b["class"] != K.INTERIOR] = 0.0
        return relax * self.rho / (dt * dt) * excess

    def _truncated_for_relaxation(self):
        """Rows whose kernel sum is not compared with ``sigma0`` for an expansion: ``div r <
        DIVR_FULL``; with ``fluid.relaxation_gap_rows`` not those with ``div r >= DIVR_GAP``
        and at least half a full support of fluid neighbours, whose deficit is a gap (the
        bed row of a sheared layer lifted off the floor: ``div r`` falls below
        ``DIVR_FULL`` and nothing pulled it back; a row at a free surface or at a thin front
        has fewer fluid neighbours). A rule with no equation in PHYSICS.md; measured in
        docs/session_notes_2026-12-01c.md; the mu(I) cases set it."""
        b = self.body
        truncated = b["divr"] < DIVR_FULL
        if self.cfg.relaxation_gap_rows:
            gap = (b["divr"] >= DIVR_GAP) & (2 * self._fluid_neighbour_counts() >= self.n_full)
            truncated &= ~gap
        return truncated

    def _fluid_neighbour_counts(self):
        """Number of fluid neighbours of each fluid row (periodic fluid images included),
        counted once per neighbour update (:meth:`_set_row_roles` clears it)."""
        if self._n_fluid is None:
            j = self.ff_j[:self.ff_start[self.nf]]
            inner = self.fluid_of[j] >= 0  # the fluid images are fluid neighbours too
            self._n_fluid = np.bincount(self._row_of()[inner], minlength=self.nf)
        return self._n_fluid

    def _solve_increment(self, A, rhs, source, alpha, relax, t0):
        """The incremental projection's solves [Goda 1979] (the matrix ``A``, the divergence
        right-hand side ``rhs`` and its ``source`` from :meth:`solve_pressure`): the
        increment ``phi`` (:func:`ppe.increment_rhs`: ``p^{n+1} = 0`` at the free surface,
        the wall rows' condition on ``p^{n+1}``; with ``incremental_damping = beta`` the
        right-hand side is blended with the standard one, :meth:`_standard_increment_rhs`,
        so that ``p^{n+1} = (1 - beta) (p^n + phi) + beta p_standard``) and, with density
        relaxation, its pressure ``q`` (source
        only, ``q = 0`` at the free surface and no wall term), which :meth:`correct` turns
        into a displacement. ``p^{n+1} = p^n + phi`` keeps ``q`` out: a pressure that only
        moves particles apart is not a pressure of the flow. Accumulated in ``p`` its
        particle-scale part, which the gradient hardly sees and the next increments
        therefore never take back, grew without bound (collapse at dt 2e-4 s: +-60 times
        the hydrostatic pressure). Returns ``(p^{n+1}, PPEStats)``."""
        import time

        nf = self.nf
        dirichlet = (alpha <= 0.0) | (np.diff(self.ff_start) == 0)
        rhs_phi = increment_rhs(A, rhs, self.p_all, alpha, dirichlet, nf)
        beta = self.cfg.incremental_damping
        if beta > 0.0:
            rhs_phi *= 1.0 - beta
            rhs_phi += beta * self._standard_increment_rhs(A, rhs, source, alpha, dirichlet)
        if self.periodic is not None:
            A, rhs_phi = self.periodic.constrain(A, rhs_phi, self.diag_ref)
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
        return self.p_all + self.phi_all, stats

    def _standard_increment_rhs(self, A, rhs, source, alpha, dirichlet):
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
        nf = self.nf
        vb = self.g_b.copy()
        if self.periodic is not None:
            rows, src = self.periodic.fluid_images()
            vb[rows - nf] = self._acc_lag[src]
        div_g = self.velocity_divergence(self._acc_lag, vb, np.empty(nf))
        b_s = rhs.copy()  # the wall rows of the standard PPE
        b_s[:nf] = np.where(dirichlet, 0.0, alpha * (source - self.rho * div_g))
        if self.cfg.surface_offset > 0.0:  # the surface rows' target (_offset_surface_rows)
            b_s[:nf] += ((1.0 - np.where(dirichlet, 0.0, alpha)) * A.diagonal()[:nf]
                         * self.p_surface)
        return b_s - A @ self.p_all

    def correct(self, dt, interface_force=None):
        """``u^{n+1} = u* - dt grad p / rho`` [F 18] with the conservative gradient [F 10];
        ``r^{n+1} = r^n + dt (u^n + u^{n+1}) / 2`` [F 19]; ``a = (u^{n+1} - u^n) / dt``.
        Incremental projection: ``u^{n+1} = u* - dt grad phi / rho`` [Goda 1979], and the
        density relaxation's pressure ``q`` (:meth:`_solve_increment`) moves the particles
        by ``-dt^2 grad q / rho`` without entering their velocity (as a velocity, the next
        increment would take it back and keep the pressure that does so: ``p`` drifted to
        2-3 times hydrostatic in the collapse at dt 2e-4 s).

        With coupled structures the pressure gradient leaves out the structure particles and
        ``interface_force`` (N/m per fluid particle, the pair force [F 46-47] that the
        structures receive with the opposite sign) is applied instead."""
        b = self.body
        if self.incremental_step:
            self._pressure_gradient(self.phi_all, self.grad_p, floor="increment")
        else:
            self._pressure_gradient(self.p_all, self.grad_p)
        v = b["v"]
        np.multiply(self.grad_p, -dt / self.rho, out=v)
        v += self.v_star
        if interface_force is not None:
            v += (dt / b["m"])[:, None] * interface_force
        if self.cfg.collision is not None:
            self._collide(v)
        b["a"][:] = (v - self.v_old) / dt
        self._guard(dt, v)
        # [F 19] (trapezoid, w_new = 0.5) or FluidSection.position_update = "damped"
        # (r^n + dt u^{n+1} + dt (u^{n+1} - u^n) / 2, w_new = 1.5)
        b["x"] += dt * (self.w_new * v + (1.0 - self.w_new) * self.v_old)
        if self.incremental_step and self.cfg.density_relaxation > 0.0:
            self._relaxation_shift(dt)

    def _collide(self, v):
        """The particle collision model (``fluid.collision``, :func:`_kernels.collision_dv`)
        on the corrected velocities ``v``: approaching pairs of fluid particles closer than
        the contact distance lose their approach."""
        c = self.cfg.collision
        dv = np.empty((self.nf, 2))
        K.collision_dv(self.x_all, v, self.body["m"], self.ff_start, self.ff_j, self.nf,
                       self.fluid_of, c.distance * self.dx, c.restitution, dv)
        v += dv

    def _relaxation_shift(self, dt):
        """The incremental projection's density relaxation as a displacement
        ``dr = -dt^2 grad q / rho`` (:meth:`correct`), none into a wall (the shift guard)."""
        dr = self._pressure_gradient(self.relax_all, np.empty((self.nf, 2)), floor=None)
        dr *= -dt * dt / self.rho
        self._guard_shift(dr)
        self.body["x"] += dr

    def _guard_ranges(self):
        """The kinematic guard's source ranges and distances: the fixed walls (and their
        periodic images) from dx/2, the coupled structures from 2h/3, where the cubic
        spline's kernel gradient peaks. Closer to a structure than that, the pair repulsion
        [F 46-47] weakens as a fluid particle approaches, the fluid pressure behind it wins,
        and it drifts into the surface layer (seen on the gate's upstream face: particles
        sliding down it at 0.3-0.5 dx from its particles, some ending between them). (The
        walls keep dx/2: thick layers, no such drift seen.)"""
        nf, nwall = self.nf, self.nw - self.ns
        return ((nf, nf + nwall, 0.5 * self.dx), (nf + nwall, nf + self.nw, 2.0 * self.h / 3.0))

    def _guard_shift(self, dr):
        """No shift into a boundary: within the guard distance of a wall or structure surface
        (:meth:`_guard_ranges`) the inward part of the shift ``dr`` is removed. Close to a
        boundary particle the colour gradient of the shift weakens as the kernel gradient
        does, and the shift alone walked particles into the gate's surface layer (measured)."""
        nf = self.nf
        if len(self._zero_b) < self.nw:  # periodic images change the boundary count
            self._zero_b = np.zeros((self.nw, 2))
        for lo, hi, gap in self._guard_ranges():
            if hi > lo:  # boundary at rest for a shift, swept as a displacement (dt = 1)
                self._shift_scratch[:] = dr
                K.boundary_guard(self.x_all, self.ff_start, self.ff_j, nf, lo, hi,
                                 self.wall_n[lo - nf:hi - nf], self._zero_b[lo - nf:hi - nf],
                                 gap, 1.0, self._shift_scratch, dr, self._guard_dv,
                                 self._guard_row)

    def _guard(self, dt, v):
        """The kinematic guard (:func:`_kernels.boundary_guard`, :meth:`_guard_ranges`) at the
        fixed walls, then at the coupled structures' surfaces; there the fluid's momentum
        change goes to the structure particles as ``self.guard_force`` (N/m per structure
        particle), opposite and equal."""
        nf = self.nf
        self._guard_walls(dt, self.v_old, v)
        _, (slo, shi, sgap) = self._guard_ranges()
        if shi > slo:
            K.boundary_guard(self.x_all, self.ff_start, self.ff_j, nf, slo, shi,
                             self.wall_n[slo - nf:], self.v_b[slo - nf:], sgap, dt, self.v_old,
                             v, self._guard_dv, self._guard_row, False, self.w_new)
            self.guard_force[:] = 0.0
            hit = self._guard_row >= 0
            if hit.any():
                np.add.at(self.guard_force, self._guard_row[hit],
                          -(self.body["m"][hit] / dt)[:, None] * self._guard_dv[hit])

    # ------------------------------------------------------------------ diagnostics
    def kinetic_energy(self):
        b = self.body
        return 0.5 * float(np.sum(b["m"] * np.einsum("ij,ij->i", b["v"], b["v"])))

    def momentum(self):
        b = self.body
        return np.sum(b["m"][:, None] * b["v"], axis=0)

    def max_speed(self):
        v = self.body["v"]
        return math.sqrt(float(np.max(np.einsum("ij,ij->i", v, v), initial=0.0)))

    def pressure_at(self, points):
        """Shepard interpolation of the fluid and wall pressures at ``points`` (m, 2)."""
        self._sync()
        points = np.atleast_2d(np.asarray(points, dtype=np.float64))
        start, j = find_neighbors(points, self.x_all, SUPPORT * self.h)
        out = np.empty(len(points))
        K.shepard_at(points, self.x_all, self.p_all, start, j, self.h, self.kernel, out)
        return out

    def surge_front(self, min_neighbors=FRONT_MIN_NEIGHBORS):
        """Largest x of the fluid particles with at least ``min_neighbors`` fluid neighbours
        (a particle sliding alone along the floor ahead of the flow is a droplet, not the
        front of the fluid body)."""
        b = self.body
        n_fluid = np.zeros(self.nf, dtype=np.int64)
        if self.nf:
            rows = np.repeat(np.arange(self.nf), np.diff(self.ff_start))
            np.add.at(n_fluid, rows[self.ff_j < self.nf], 1)
        keep = n_fluid >= min_neighbors
        return float(np.max(b["x"][keep, 0])) if keep.any() else float("nan")

    def snapshot(self):
        """Fluid fields written at a snapshot; the walls' pressure goes with the walls."""
        b = self.body
        return {k: b[k].copy() for k in self.output_fields}

    def wall_snapshot(self):
        return {"x": self.walls.body["x"].copy(), "p": self.walls.body["p"].copy()}

    def static(self):
        b = self.body
        return {"m": b["m"], "vol": b["vol"]}


def warm_up(kind):
    """Compile (or load from the cache) every loop on a tiny problem, so that JIT time is
    spent at set-up, not inside the timed stepping loop."""
    dx = 1.0
    h = 1.2
    ix, iy = np.meshgrid(np.arange(4), np.arange(4), indexing="ij")
    x = np.column_stack([ix.ravel(), iy.ravel()]).astype(np.float64) * dx
    n = len(x)
    vol = np.ones(n)
    v = np.zeros((n, 2))
    p = np.zeros(n)
    start, j = find_neighbors(x, x, 2 * h, exclude_self=True)
    divr = np.zeros(n)
    gc = np.zeros((n, 2))
    alpha = np.ones(n)
    cls = np.zeros(n, dtype=np.int8)
    nrm = np.zeros((n, 2))
    free_surface.detect(x, vol, start, j, n, h, kind, divr, gc, divr.copy(), alpha, cls, nrm)
    L = np.zeros((n, 2, 2))
    K.correction_matrices(x, vol, start, j, h, kind, L)
    gp = np.zeros((n, 2))
    gv = np.zeros((n, 2, 2))
    K.gradients(x, p, v, vol, L, start, j, n, h, kind, gp, gv, -1)
    nu = np.zeros(n)
    K.smagorinsky(gv, 0.0, 0.0, nu)
    vs = np.zeros((n, 2))
    K.predict_velocity(x, v, vol, nu, start, j, n, h, kind, 0.01, 0.0, -1.0, 0.0, vs)
    div = np.zeros(n)
    K.velocity_divergence(x, v, vol, start, j, n, h, kind, 1.0, div)
    ws = np.zeros(1, dtype=np.int64)
    assemble(x, vol, alpha, div, L, cls == 0, start, j, ws, np.zeros(0, dtype=np.int64), n, 0, h,
             kind, 0.01, 1.0, 1.0, 1.0, np.zeros((0, 2)))
    none = np.zeros(n, dtype=np.bool_)
    rg = np.zeros((n, 2))
    K.pressure_gradient(x, p, vol, start, j, n, h, kind, 1.0, n, none, none, rg, gp)
    K.corrected_pressure_gradient(x, p, vol, L, start, j, n, h, kind, n, none, none, rg, gp)
    dr = np.zeros((n, 2))
    for model in (0, 1, 2):
        K.shift_vectors(x, v, vol, start, j, n, h, kind, model, 1.0, 0.0, 0.1, cls, nrm, dr)
    lo, hi = np.zeros((n, 3)), np.zeros((n, 3))
    K.neighbour_bounds(p, v, start, j, n, -1, lo, hi)
    K.apply_shift(dr, gp, gv, True, lo, hi, x, p, v)
    K.wall_normals(x, vol, start, j, h, kind, nrm)
    K.boundary_guard(x, start, j, n, n, n, nrm, nrm, 0.5, 0.1, v, vs, np.zeros((n, 2)),
                     np.zeros(n, dtype=np.int64))
    amg.warm_up()
    out = np.zeros(1)
    s1, j1 = find_neighbors(x[:1], x, 2 * h)
    K.shepard_at(x[:1], x, p, s1, j1, h, kind, out)
    _ = kernel_w
