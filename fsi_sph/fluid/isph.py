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
   (docs/numerics/fluid.md, "Position update").

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

The fluid is its particle set (:class:`~fsi_sph.fluid.particle_set.FluidParticles`: the
stacked rows, their neighbour lists and the operators every part reads) with the parts
that act on it, each with its own state:

- ``rows`` (:mod:`~fsi_sph.fluid.rows`): the roles of the stacked rows;
- ``boundary`` (:mod:`~fsi_sph.fluid.boundary`): walls and structures as rows of the solve;
- ``gradient`` (:mod:`~fsi_sph.fluid.pressure_gradient`): the correction step's gradient;
- ``pressure`` (:mod:`~fsi_sph.fluid.pressure_solve`, :mod:`~fsi_sph.fluid.increments`):
  the PPE and the incremental projection's increments;
- ``kinematic_guard`` (:mod:`~fsi_sph.fluid.kinematic_guard`): no particle into a boundary;
- ``motion`` (:mod:`~fsi_sph.fluid.motion`): shift, explicit predictor, correction;
- ``viscous`` (:mod:`~fsi_sph.fluid.viscous`, only with a viscosity law, the implicit step
  or the stress operator): the viscous predictor.
"""

from __future__ import annotations

import math

import numpy as np

from fsi_sph.fluid import _kernels as K
from fsi_sph.fluid import amg, free_surface, krylov
from fsi_sph.fluid.boundary import BoundaryRows
from fsi_sph.fluid.kinematic_guard import KinematicGuard
from fsi_sph.fluid.motion import Motion
from fsi_sph.fluid.particle_set import FluidParticles
from fsi_sph.fluid.ppe import assemble
from fsi_sph.fluid.pressure_gradient import PressureGradient
from fsi_sph.fluid.pressure_solve import PressureSolve
from fsi_sph.fluid.rows import RowRoles
from fsi_sph.neighbors import find_neighbors
from fsi_sph.sph.kernels import kernel_w


class IncompressibleFluid(FluidParticles):
    """The ISPH fluid of a ``FluidSection`` and, if given, its ``WallsSection`` walls: the
    step's verbs in the order :meth:`Simulation.step` calls them, each handing the work to
    the part that owns it (module docstring)."""

    def __init__(self, cfg, walls_cfg, dx, sph, gravity, structures=()):
        super().__init__(cfg, walls_cfg, dx, sph, gravity, structures)
        self.rows = RowRoles(self)
        self.boundary = BoundaryRows(self, self.rows)
        self.kinematic_guard = KinematicGuard(self)
        self.boundary.set_structures(np.zeros((self.ns, 2)), np.zeros((self.ns, 2)))
        self.gradient = PressureGradient(self, self.rows, self.boundary)
        self.pressure = PressureSolve(self, self.rows, self.boundary, self.gradient)
        # viscosity law, implicit viscous step, periodicity (rheology.py, viscous.py,
        # periodic.py); the plain explicit Newtonian fluid takes none of these paths
        self.viscous = None
        if (cfg.material.viscosity != "newtonian" or cfg.viscous_step == "implicit"
                or cfg.viscous_operator == "stress"):
            from fsi_sph.fluid.rheology import ViscosityLaw
            from fsi_sph.fluid.viscous import ViscousStep

            self.viscous = ViscousStep(self, self.rows, self.gradient, self.pressure,
                                       ViscosityLaw(cfg, dx, gravity))
        self.motion = Motion(self, self.rows, self.gradient, self.pressure,
                             self.kinematic_guard, free_slip=self.viscous is None,
                             boundary=self.boundary)
        self.dt_limits = {}
        if cfg.periodic_x is not None:
            from fsi_sph.fluid.periodic import Periodic

            self.periodic = Periodic(cfg.periodic_x, self)
        self.update_neighbors()
        warm_up(self.kernel)
        self.confined = self.fills_its_channel()

    def fills_its_channel(self):
        """Whether the fluid is confined: a through-flow (an outflow holds the pressure)
        whose initial lattice has no free-surface row, i.e. the fluid fills the space
        between its walls and open lines, as in a pipe or a closed channel. Such a flow has
        no free surface to find later: a gap that opens in it (behind a body, at low
        pressure) is a volume error, not a surface. So its rows are all Poisson rows
        (:func:`free_surface.detect` with ``surface=False``) and the density relaxation
        pulls back an expansion on every row away from the fixed walls
        (:meth:`RowRoles.truncated_for_relaxation`). Decided once, from the scene as built
        (the same on a restart). Measured on the Turek-Hron channel (D/dx = 10): as a
        free-surface fluid it opened voids 4-5 dx wide along the flag that never closed (the
        relaxation left their edge rows out as truncated supports) and lost 7 % of its
        particles by 5 s; confined, 0.8 % (docs/validation/turek_hron_cfd2.md). A rule of
        this code, not in PHYSICS.md; tests/unit/test_open_boundary.py."""
        if self.open is None or not len(self.open.out_line):
            return False
        self.detect_free_surface()
        return not bool(np.any(self.body["class"] != K.INTERIOR))

    # ------------------------------------------------------------------ coupling
    def set_structures(self, v_bar, a_bar, a_other=None, rho_s=None, rigid=None):
        """The structures' moving boundary (:meth:`BoundaryRows.set_structures`)."""
        self.boundary.set_structures(v_bar, a_bar, a_other, rho_s, rigid)

    def waterline_rows(self):
        """The waterline rows (:meth:`RowRoles.waterline_rows`)."""
        return self.rows.waterline_rows()

    def interface_weights(self):
        """The pair weights of the interface rows (:meth:`RowRoles.interface_weights`)."""
        return self.rows.interface_weights()

    @property
    def guard_force(self):
        """The kinematic guard's force on the structure particles (N/m each)."""
        return self.kinematic_guard.force

    # ------------------------------------------------------------------ open boundaries
    def exchange_open_boundaries(self, t, dt):
        """Open boundaries (:mod:`~fsi_sph.fluid.open_boundary`), at the start of the step
        ``t -> t + dt``: the particles that crossed an open line become fluid or buffer
        particles (the fluid count changes, and with it the stacked layout), then the
        buffers get their velocities for the step."""
        op = self.open
        lo = self.nf + self.n_fixed
        p_buffer = self.p_all[lo:lo + op.n].copy()
        keep, new_x, new_v, new_p, p_buffer = op.exchange(
            self.body["x"], self.body["v"], p_buffer, self.rho * self.dx * self.dx)
        if len(new_x) or not keep.all() or len(p_buffer) != self.n_walls - self.n_fixed:
            old_rows = self.rows_before_exchange(keep, op.joined_rows)
            self.relayout(keep, new_x, new_v, new_p, p_buffer)
            self.resized()
            self.pressure.ppe.remap(old_rows)
        self.buffer_velocities(t, dt)

    def buffer_velocities(self, t, dt, fluid_corner=None):
        """The buffers' velocities for the step ``t -> t + dt``
        (:meth:`OpenBoundaries.set_velocities`) and their stacked rows."""
        self.open.set_velocities(t, dt, self.body["x"], self.body["v"], self.kernel,
                                 fluid_corner)
        self.buffer_rows()

    def rows_before_exchange(self, keep, joined_rows):
        """For each stacked row after the exchange (``[fluid | walls | inflow | outflow |
        structures]``), its row before it: the kept fluid rows; each new fluid particle the
        row of the inflow buffer particle it was (the same place: that buffer particle
        itself moved one depth back); the fixed walls and the inflow buffer in order, the
        outflow buffer's rows that stay and then the fluid rows that joined it, the
        structures. (The pressure solver's kept AMG hierarchy follows this map. With ``-1``
        for a new particle, an empty row of the interpolation, the CFD2 channel rebuilt its
        hierarchy at 226 of its first 600 steps; with the buffer particle's row, at 42, and
        took 13.2 instead of 16.1 iterations a step: docs/numerics/fluid.md § Open
        boundaries.)

        ``keep``: one entry per fluid row before the exchange; ``joined_rows``: the fluid
        rows that joined the outflow buffer, in its order. (A fluid split over ranks passes
        the whole fluid's, fsi_sph/parallel/open_ranks.py.)"""
        op = self.open
        nf, n_fixed, n_in = len(keep), self.n_fixed, op.n_in
        return np.concatenate([
            np.flatnonzero(keep), nf + n_fixed + op.crossed,
            nf + np.arange(n_fixed + n_in),
            nf + n_fixed + n_in + np.flatnonzero(op.stay), joined_rows,
            nf + self.n_walls + np.arange(self.ns)])

    def buffer_rows(self):
        """The buffers' positions, velocities and body force in the stacked arrays."""
        lo, hi = self.nf + self.n_fixed, self.nf + self.n_walls
        self.x_all[lo:hi] = self.open.positions()
        self.v_all[lo:hi] = self.open.velocities()
        self.v_b[self.n_fixed:self.n_walls] = self.open.velocities()
        self.g_b[self.n_fixed:self.n_walls] = self.open.body_force(self.gravity)

    def resized(self):
        """A new fluid particle count: the parts' per-row work arrays follow it."""
        self.motion.resize()
        self.pressure.resize()
        self.kinematic_guard.resize()

    def energy_supply(self):
        """Kinetic energy the inflows can bring (J/m): the fluid's mass at the largest
        inflow speed so far (the guard's bound grows with it)."""
        if self.open is None:
            return 0.0
        return 0.5 * float(np.sum(self.body["m"])) * self.open.u_max ** 2

    def mass_flux(self):
        """Mass (kg/m) that entered and left through the open lines at the last exchange."""
        return self.open.mass_in, self.open.mass_out

    # ------------------------------------------------------------------ state
    def extra_state(self):
        """State outside the fluid body's arrays (:meth:`PressureSolve.extra_state`; the
        open boundaries' buffers)."""
        state = self.pressure.extra_state()
        if self.open is not None:
            state.update({f"open.{k}": v for k, v in self.open.state().items()})
            state["open.nf"] = np.array(self.nf)
        return state

    def load_extra_state(self, state):
        """Put the extra state back; with open boundaries first the buffers and the fluid
        count (the body's arrays are then copied into a body of the saved size)."""
        if self.open is not None:
            self.open.load_state({k[5:]: v for k, v in state.items() if k.startswith("open.")})
            nf = int(state["open.nf"])
            self.relayout(np.zeros(self.nf, dtype=bool), np.zeros((nf, 2)), np.zeros((nf, 2)),
                          np.zeros(nf), np.zeros(self.open.n))
            self.resized()
            self.buffer_rows()
        self.pressure.load_extra_state(state)

    def at_snapshot(self):
        """Called at every scheduled snapshot (a restart point): the solvers' kept AMG
        hierarchies are rebuilt at their next solve, as a restarted run builds them, so a
        restart continues bit for bit."""
        self.pressure.at_snapshot()
        if self.viscous is not None:
            self.viscous.at_snapshot()

    @property
    def last_stats(self):
        """PPEStats of the last pressure solve."""
        return self.pressure.last_stats

    # ------------------------------------------------------------------ step verbs
    def set_gravity(self, g):
        """The body force per unit mass from now on (a shaken frame's, fsi_sph/frame.py): the
        fluid's, the walls' (at rest in the frame) and the walls' pressure floor ``rho g``."""
        self.gravity[:] = g
        self.g_b[:self.n_walls] = g
        self.rows.floor_rg[self.rows.wall_rows] = self.rho * self.gravity

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
        lim["advective"] = self.advective_dt(vmax)
        lim["viscous"] = 0.125 * self.h * self.h / numax if numax > 0.0 else math.inf
        lim["force"] = 0.25 * math.sqrt(self.h / amax) if amax > 0.0 else math.inf
        lim["nu_max"] = numax
        dt = min(dt, lim["advective"], lim["force"])
        if self.cfg.viscous_step == "explicit":
            dt = min(dt, lim["viscous"])
        return dt

    def advective_dt(self, speed):
        """The advective limit ``cfl h / speed`` of [F 48] (infinite at rest)."""
        return self.cfg.cfl * self.h / speed if speed > 0.0 else math.inf

    def update_neighbors(self):
        """CSR neighbour lists at the current positions, then the rows' roles."""
        self.build_neighbor_lists()
        self.rows.assign()

    def detect_free_surface(self):
        """``div r``, ``alpha`` [F 21], classes and normals [F 27-28] of the fluid rows."""
        b = self.body
        free_surface.detect(
            self.x_all, self.vol_all, self.ff_start, self.ff_j, self.nf, self.h, self.kernel,
            b["divr"], b["grad_c"], b["sigma"], b["alpha"], b["class"], b["normal"],
            scan=self.cfg.surface_scan, isolated=self.cfg.surface_isolated_rows,
            pocket=self.cfg.surface_pocket_rows, surface=not self.confined)
        self.rows.new_surface()  # waterline_rows: found anew for this alpha

    @property
    def shifting_enabled(self):
        """Whether the scene declares particle shifting (``[fluid.shifting]``)."""
        return self.motion.shifting is not None

    def shift(self, dt):
        """Particle shifting [F 22-33] with the Taylor correction of u and p [F 33]."""
        self.motion.shift(dt)

    def predict(self, dt):
        """Intermediate velocity [F 16]: the pressure's start of the step (incremental
        projection), then the viscous step (a viscosity law, the implicit step) or the
        explicit one (with the Smagorinsky viscosity [F 3] if enabled), then, with
        ``fluid.wall_contact = "inelastic"``, the walls' contact on it
        (:meth:`KinematicGuard.inelastic_contact`)."""
        self.pressure.begin_step(dt)
        if self.viscous is not None:  # mu(I) or the implicit step (viscous.py)
            self.viscous.predict(dt)
        else:
            self.motion.predict(dt)
        if self.cfg.wall_contact == "inelastic":
            self.kinematic_guard.inelastic_contact(dt)

    def solve_pressure(self, dt):
        """The PPE [F 17, F 20-21] (:meth:`PressureSolve.solve`); returns PPEStats."""
        return self.pressure.solve(dt)

    def correct(self, dt, interface_force=None):
        """``u^{n+1}`` [F 18] and ``r^{n+1}`` [F 19] (:meth:`Motion.correct`)."""
        self.motion.correct(dt, interface_force)
        if self.open is not None:
            self.open.move(dt)
            self.buffer_rows()

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
    for level_free in (False, True):
        K.structure_row_pressure_gradient(x, p, vol, start, j, n, h, kind, 1.0, n, none, none,
                                          rg, level_free, ~none, gp)
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
    krylov.warm_up()
    out = np.zeros(1)
    s1, j1 = find_neighbors(x[:1], x, 2 * h)
    K.shepard_at(x[:1], x, p, s1, j1, h, kind, out)
    _ = kernel_w
