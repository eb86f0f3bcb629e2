"""Fluid-structure coupling [F 46-48] (PHYSICS.md §5): a staggered explicit scheme.

Per fluid step ``dt_f``:

1. the fluid solves its pressure with the structure particles as moving boundary particles;
2. :func:`interface_forces` gives the pairwise pressure force on every structure particle
   (and the opposite one on the fluid), held fixed over the structure's sub-steps;
3. :func:`advance_structure` advances the structure ``n_sub`` sub-steps,
   ``n_sub = ceil(dt_f / dt_s)`` from the two stability limits unless the case fixes it
   (the source uses 100), and returns its velocity averaged over the sub-steps,
   ``(x^{n+1} - x^n) / dt_f``, which the fluid sees as the boundary velocity.

The power exchanged is logged on both sides: the rate of work of the interface force on
the structure (``sum_s F_s . v_s``) and on the fluid (``sum_f F_f . v_f``); for a consistent
coupling they are close to opposite.
"""

from __future__ import annotations

import math

import numpy as np

from fsi_sph.errors import SimulationError
from fsi_sph.particles import FieldSpec
from fsi_sph.sph import interface as K


def substep_count(dt_f, dt_s, fixed=None, name="structure"):
    """Sub-steps of a structure within one fluid step: ``fixed`` if the case sets it, else
    ``ceil(dt_f / dt_s)`` (at least 1) [F 48 and text]. A fixed count whose solid step
    would exceed the solid's stability limit is refused with the numbers (the solid would
    blow up within a few sub-steps)."""
    if fixed is None:
        return max(1, math.ceil(dt_f / dt_s - 1e-12))
    if dt_f / fixed > dt_s * (1 + 1e-9):
        raise SimulationError(
            f"coupling.substeps = {fixed} gives {name} a solid step of {dt_f / fixed:.3g} s "
            f"in this fluid step of {dt_f:.3g} s, above its stability limit {dt_s:.3g} s: "
            f"leave coupling.substeps out (automatic: {math.ceil(dt_f / dt_s - 1e-12)} here) "
            f"or bound the fluid step with fluid.dt_max")
    return int(fixed)


def interface_forces(x_s, p_s, vol_s, x_f, p_f, vol_f, sf_start, sf_j, fs_start, fs_j, h,
                     kind, scale, out_on_structure, out_on_fluid, weights=None):
    """Pairwise interface pressure forces [F 46-47] on the structure rows (from their fluid
    neighbours ``sf``) and on the fluid rows (from their structure neighbours ``fs``), each
    pair's kernel gradient weighted by its fluid particle's matrix ``weights[f]`` (the
    identity if None; ``IncompressibleFluid.interface_weights``)."""
    if weights is None:
        weights = np.tile(np.eye(2), (len(x_f), 1, 1))
    K.pair_pressure_forces(x_s, p_s, vol_s, x_f, p_f, vol_f, sf_start, sf_j, h, kind, scale,
                           weights, False, out_on_structure)
    K.pair_pressure_forces(x_f, p_f, vol_f, x_s, p_s, vol_s, fs_start, fs_j, h, kind, scale,
                           weights, True, out_on_fluid)


def advance_structure(body, dt_f, n_sub):
    """Advance ``body`` (it has ``substep(dt)`` and ``.body['x']``, its ``f_ext`` already
    set and held) by ``n_sub`` equal sub-steps; returns the sub-step-averaged velocity."""
    x0 = body.body["x"].copy()
    substeps(body, dt_f, n_sub)
    return (body.body["x"] - x0) / dt_f


def substeps(body, dt_f, n):
    """``n`` equal sub-steps of ``dt_f / n``: the body's own loop where it has one
    (``ElasticBody.substeps``), else ``substep`` ``n`` times."""
    if hasattr(body, "substeps"):
        body.substeps(dt_f / n, n)
        return
    for _ in range(n):
        body.substep(dt_f / n)


def interface_power(force, velocity):
    """Rate of work ``sum_i F_i . v_i`` (W per metre of depth)."""
    return float(np.sum(force * velocity))


class FsiCoupling:
    """The coupled structures of a scene and the fluid they bound (PHYSICS.md §5).

    Per fluid step: :meth:`before_fluid` hands the fluid the structures' positions, averaged
    velocities and accelerations; after the pressure solve :meth:`forces` gives the pairwise
    interface forces (the fluid's share goes to ``fluid.correct``); :meth:`advance` sub-cycles
    the structures with their share held fixed and logs the interface power on both sides.
    """

    def __init__(self, cfg, fluid, bodies, scheme):
        self.cfg = cfg
        self.scheme = scheme  # structure_acceleration, "auto" resolved (Config.structure_scheme)
        self.fluid = fluid
        self.bodies = list(bodies)
        ns = sum(b.body.n for b in self.bodies)
        self.slices = []
        k = 0
        for b in self.bodies:
            self.slices.append(slice(k, k + b.body.n))
            k += b.body.n
            # the sub-cycle's mean velocity and acceleration, kept with the body (restart)
            b.body.allocate((FieldSpec("v_bar", (2,)), FieldSpec("a_bar", (2,))))
        self.v_bar = np.zeros((ns, 2))
        self.a_bar = np.zeros((ns, 2))
        self.on_structure = np.zeros((ns, 2))
        self.on_fluid = np.zeros((fluid.nf, 2))
        self.power_structure = 0.0
        self.power_fluid = 0.0
        self.n_sub = {}
        # on several ranks: each structure particle's force taken from the rank that owns
        # it (fsi_sph/parallel/ranks.py); None in a serial run
        self.owned_rows = None
        self.fluid_power = interface_power  # (on several ranks: over every rank's fluid)

    def before_fluid(self):
        for b, sl in zip(self.bodies, self.slices, strict=True):
            self.v_bar[sl] = b.body["v_bar"]
            self.a_bar[sl] = b.body["a_bar"]
        if self.scheme == "explicit":
            self.fluid.set_structures(self.v_bar, self.a_bar)
            return
        if self.scheme == "rigid":
            self.fluid.set_structures(self.v_bar, self.a_bar, rigid=self._rigid_split())
            return
        # implicit: hand the solve every acceleration but the fluid's (internal + gravity;
        # zero on clamped particles, which also get no implicit term: rho_s = inf)
        g = self.fluid.gravity
        a_other = np.zeros_like(self.a_bar)
        rho_s = np.full(len(self.a_bar), np.inf)
        for b, sl in zip(self.bodies, self.slices, strict=True):
            free = b.body["free"]
            a_other[sl] = np.where(free[:, None], b.body["a"] + g, 0.0)
            rho_s[sl] = np.where(free, b.rho0, np.inf)
        self.fluid.set_structures(self.v_bar, self.a_bar, a_other, rho_s)

    def _rigid_split(self):
        """``(a_rigid, body_of, mass, inertia, centre)`` for ``fluid.set_structures``: each
        body's mass, moment of inertia about its centre of mass and that centre, and the
        rigid-body part of the last sub-cycle's mean acceleration ``a_bar`` at each particle
        (its mass-weighted translation and rotation about the centre)."""
        ns = len(self.a_bar)
        a_rigid = np.empty((ns, 2))
        body_of = np.empty(ns, dtype=np.int64)
        mass = np.empty(len(self.bodies))
        inertia = np.empty(len(self.bodies))
        centre = np.empty((len(self.bodies), 2))
        for k, (b, sl) in enumerate(zip(self.bodies, self.slices, strict=True)):
            m = b.body["m"]
            x = b.body["x"]
            a = self.a_bar[sl]
            mass[k] = m.sum()
            centre[k] = m @ x / mass[k]
            r = x - centre[k]
            inertia[k] = float(m @ np.einsum("ij,ij->i", r, r))
            trans = m @ a / mass[k]
            spin = float(m @ (r[:, 0] * a[:, 1] - r[:, 1] * a[:, 0])) / inertia[k]
            a_rigid[sl] = trans + spin * np.column_stack([-r[:, 1], r[:, 0]])
            body_of[sl] = k
        return a_rigid, body_of, mass, inertia, centre

    def forces(self):
        """Interface forces [F 46-47] from the pressures of the last solve, at the current
        positions; returns the fluid's share (N/m per fluid particle)."""
        from fsi_sph.neighbors import transpose_csr

        fl = self.fluid
        if len(self.on_fluid) != fl.nf:  # open boundaries change the fluid's count
            self.on_fluid = np.zeros((fl.nf, 2))
        nb0 = fl.nf + fl.n_walls
        x_s = fl.x_all[nb0:]
        x_f = fl.x_all[:fl.nf]
        # the structure rows' fluid neighbours are the fluid's own boundary lists (rows after
        # the walls, built this step); the fluid rows' structure neighbours their transpose
        k0 = fl.wf_start[fl.n_walls]
        sf = (fl.wf_start[fl.n_walls:] - k0, fl.wf_j[k0:])
        fs = transpose_csr(*sf, fl.nf)
        # the waterline rows weight their pair terms by L_f (fluid.waterline_rows)
        interface_forces(x_s, fl.p_all[nb0:], fl.vol_all[nb0:], x_f, fl.p_all[:fl.nf],
                         fl.vol_all[:fl.nf], *sf, *fs, fl.h, fl.kernel, fl.grad_scale,
                         self.on_structure, self.on_fluid, fl.interface_weights())
        return self.on_fluid

    def advance(self, dt):
        """Sub-cycle every coupled structure over ``dt`` with its interface force held (plus
        the reaction of the fluid's kinematic guard at the structure surfaces, if it acted)."""
        force = self.on_structure + self.fluid.guard_force
        if self.owned_rows is not None:
            force = self.owned_rows(force)
        for b, sl in zip(self.bodies, self.slices, strict=True):
            b.body["f_ext"][:] = force[sl]
            v0 = b.body["v"].copy()
            n = substep_count(dt, b.stable_dt(), self.cfg.substeps, b.name)
            self.v_bar[sl] = advance_structure(b, dt, n)
            self.a_bar[sl] = (b.body["v"] - v0) / dt
            b.body["v_bar"][:] = self.v_bar[sl]
            b.body["a_bar"][:] = self.a_bar[sl]
            self.n_sub[b.name] = n
        self.power_structure = interface_power(force, self.v_bar)
        self.power_fluid = self.fluid_power(self.on_fluid, self.fluid.body["v"])
        return self.n_sub
