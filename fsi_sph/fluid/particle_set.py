"""The fluid's particle set: the fluid body, the boundary rows stacked after it, their
neighbour lists and the operators every part of the fluid reads (``sync``, correction
matrices, gradients, velocity divergence), plus the diagnostics of the fluid body.

Density and particle mass are constant: ``vol = dx^2``, ``m = rho0 dx^2``.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from fsi_sph.fluid import _kernels as K
from fsi_sph.fluid.lattice import ETA, lattice_offsets, lattice_scales, lattice_sigma
from fsi_sph.fluid.open_boundary import OpenBoundaries
from fsi_sph.fluid.walls import Walls
from fsi_sph.geometry import fill_shapes, in_shapes
from fsi_sph.neighbors import find_neighbors
from fsi_sph.particles import Body, FieldSpec
from fsi_sph.sph.kernels import KERNELS, SUPPORT

FRONT_MIN_NEIGHBORS = 3  # fluid neighbours of a particle counted in the surge front

log = logging.getLogger(__name__)


def _carve(x, structure, dx):
    """The fluid positions ``x`` without those within half a spacing of a particle of
    ``structure`` or inside its blocks (the fluid is carved around a coupled structure that
    its blocks overlap; the count is logged)."""
    near_start, _ = find_neighbors(x, structure.body["x"], 0.5 * dx)
    inside = in_shapes(x, structure.cfg.blocks)
    keep = (np.diff(near_start) == 0) & ~inside
    if len(x) > np.count_nonzero(keep):
        log.info("fluid: %d particles inside solid.%s carved out", len(x) - np.count_nonzero(keep),
                 structure.name)
    return x[keep]


class FluidParticles:
    """The particles of the ISPH fluid of a ``FluidSection`` and the boundary rows it sees
    (its ``WallsSection`` walls, the coupled structures, periodic images), stacked
    ``[fluid | walls | structures | images]`` (``x_all, v_all, vol_all, nu_all, p_all``;
    the boundary rows' ``v_b, g_b, wall_n, implicit``), with their CSR neighbour lists
    (``ff_*``: fluid rows over all sources, ``wf_*``: boundary rows over fluid sources), the
    correction matrices ``L`` and the gradients at the current positions.

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
            # and those inside a round body, whose rings leave sites off the lattice free
            x = x[~in_shapes(x, [s for s in walls_cfg.boxes if s.shape == "circle"])]
        for st in structures:  # and so are those on a site of, or inside, a coupled structure
            x = _carve(x, st, dx)
        self.open = None  # the open boundaries' buffers (open_boundary.py)
        self.confined = False  # no free surface (IncompressibleFluid.fills_its_channel)
        if cfg.inflow or cfg.outflow:
            self.open = OpenBoundaries(cfg, dx, self.h)
            x = x[~self.open.inside(x)]
        if cfg.jitter > 0.0:  # one realization of the initial lattice (fluid.jitter)
            rng = np.random.default_rng(cfg.jitter_seed)
            x = x + cfg.jitter * dx * rng.uniform(-1.0, 1.0, size=x.shape)
        self.body = b = Body("fluid", "fluid", len(x))
        b.allocate(self.fields)
        if cfg.shifting is not None:
            b.allocate(self.shifting_fields)
        b["x"][:] = x
        b["vol"][:] = dx * dx
        b["m"][:] = self.rho * dx * dx
        b["nu"][:] = self.nu0
        b["v"][:] = cfg.initial_velocity
        self.nf = b.n
        # boundary particles: the fixed walls, then the particles of the coupled structures
        # (moving boundaries, PHYSICS.md §5); the loops see them all as "wall" rows
        self.n_fixed = self.walls.body.n if self.walls is not None else 0
        # the boundary rows that are not structures: the fixed walls, then the buffers
        self.n_walls = self.n_fixed + (self.open.n if self.open is not None else 0)
        self.structures = list(structures)  # ElasticBody objects, fixed order
        self.ns = sum(s.body.n for s in self.structures)
        self.nw = self.n_walls + self.ns
        n = self.nf + self.nw
        # a pressure has been solved for (p_all holds it): the incremental projection's p^n
        # and the mirror walls' lagged gradient exist from then on
        self.p_known = False
        # boundary velocity u_b and body force g - a_b of the boundary rows (Adami)
        self.v_b = np.zeros((self.nw, 2))
        self.g_b = np.tile(self.gravity, (self.nw, 1))
        # rho c / rho_s on structure rows whose acceleration the PPE takes implicitly
        self.implicit = np.zeros(self.nw)
        # stacked fluid + boundary arrays seen by the loops (boundary after the fluid)
        self.x_all = np.zeros((n, 2))
        self.v_all = np.zeros((n, 2))
        self.vol_all = np.full(n, dx * dx)
        self.nu_all = np.full(n, self.nu0)
        self.p_all = np.zeros(n)
        self.wall_n = np.zeros((self.nw, 2))
        if self.walls is not None:
            xw = self.walls.body["x"]
            self.x_all[self.nf:self.nf + self.n_fixed] = xw
            self.wall_n[:self.n_fixed] = self.fixed_wall_normals(xw)
        if self.open is not None:
            self.x_all[self.nf + self.n_fixed:self.nf + self.n_walls] = self.open.positions()
        self.grad_scale, self.lap_scale, self.diag_ref = lattice_scales(dx, self.h, self.kernel)
        self.sigma0 = lattice_sigma(dx, self.h, self.kernel)
        self.n_full = len(lattice_offsets(dx, self.h))
        self.v_old = np.zeros((self.nf, 2))
        # weight of u^{n+1} in the position update (the rest on u^n)
        self.w_new = 0.5 if cfg.position_update == "trapezoid" else 1.5
        self.v_star = np.zeros((self.nf, 2))
        self.grad_p = np.zeros((self.nf, 2))
        self.grad_v = np.zeros((self.nf, 2, 2))
        self.L = np.zeros((self.nf, 2, 2))
        self._L_key, self._L_x = None, np.empty((0, 2))  # what self.L was computed for
        self._lists_made = 0  # neighbour lists built so far
        self.periodic = None  # periodic images (periodic.py), set by the fluid

    @property
    def n(self):
        return self.nf

    def relayout(self, keep, new_x, new_v, new_p, p_buffer):
        """A new fluid particle count (open boundaries, restart): the fluid rows ``keep``
        and the new particles ``new_x, new_v, new_p`` appended; the buffers as ``self.open``
        now holds them, with the pressures ``p_buffer``. The stacked arrays are laid out
        anew, ``[fluid | walls | buffers | structures]``, the walls' and structures' rows
        carried over; the per-fluid-row work arrays are reallocated (each step fills them)."""
        b = self.body
        n_add = len(new_x)
        b.select(keep, n_add)
        new = slice(b.n - n_add, b.n)
        b["x"][new] = new_x
        b["v"][new] = new_v
        b["p"][new] = new_p
        b["vol"][new] = self.dx * self.dx
        b["m"][new] = self.rho * self.dx * self.dx
        b["nu"][new] = self.nu0
        self.restack(p_buffer)

    def restack(self, p_buffer):
        """The stacked arrays for the current fluid body and buffers (:meth:`relayout`);
        without open boundaries ``p_buffer`` is empty."""
        nf_old = self.nf
        tail = self.n_walls + self.ns  # (old) end of the structure rows
        n_open = self.open.n if self.open is not None else 0
        fixed = slice(nf_old, nf_old + self.n_fixed)
        structures = slice(nf_old + self.n_walls, nf_old + tail)
        b = self.body
        self.nf = nf = b.n
        if self.open is None:
            gb = opos = ovel = np.zeros((0, 2))
        else:
            gb = self.open.body_force(self.gravity)
            opos, ovel = self.open.positions(), self.open.velocities()

        def stack(a, fluid_rows, open_rows, offset):
            head = a[fixed.start - offset:fixed.stop - offset]
            end = a[structures.start - offset:structures.stop - offset]
            return np.ascontiguousarray(np.concatenate([fluid_rows, head, open_rows, end]))

        empty = np.zeros((0, 2))
        self.x_all = stack(self.x_all, b["x"], opos, 0)
        self.v_all = stack(self.v_all, b["v"], ovel, 0)
        self.p_all = stack(self.p_all, b["p"], p_buffer, 0)
        self.vol_all = stack(self.vol_all, b["vol"], np.full(n_open, self.dx * self.dx), 0)
        self.nu_all = stack(self.nu_all, b["nu"], np.full(n_open, self.nu0), 0)
        self.v_b = stack(self.v_b, empty, ovel, nf_old)
        self.g_b = stack(self.g_b, empty, gb, nf_old)
        self.implicit = stack(self.implicit, np.zeros(0), np.zeros(n_open), nf_old)
        self.wall_n = stack(self.wall_n, empty, np.zeros((n_open, 2)), nf_old)
        self.n_walls = self.n_fixed + n_open
        self.nw = self.n_walls + self.ns
        self.v_old = np.zeros((nf, 2))
        self.v_star = np.zeros((nf, 2))
        self.grad_p = np.zeros((nf, 2))
        self.grad_v = np.zeros((nf, 2, 2))
        self.L = np.zeros((nf, 2, 2))
        self._L_key, self._L_x = None, np.empty((0, 2))

    def fixed_wall_normals(self, xw):
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

    def sync(self):
        """Copy the fluid's positions, velocities and pressures into the stacked arrays."""
        nf = self.nf
        self.x_all[:nf] = self.body["x"]
        self.v_all[:nf] = self.body["v"]
        self.p_all[:nf] = self.body["p"]
        if self.periodic is not None:
            self.periodic.sync(self)

    def build_neighbor_lists(self):
        """CSR neighbour lists at the current positions: fluid rows over fluid and wall
        sources (``ff_*``), wall rows over fluid sources (``wf_*``)."""
        if self.periodic is not None:
            self.periodic.rebuild(self)
        self.sync()
        r = SUPPORT * self.h
        xf = self.x_all[:self.nf]
        # the last lists go before the search makes the new ones (at 1 M particles the
        # search's peak memory was the largest of the step; validation/benchmark_scaling.py)
        self.ff_start = self.ff_j = self.wf_start = self.wf_j = None
        self._lists_made += 1  # (what correction_matrices' cache is keyed on)
        self.ff_start, self.ff_j = find_neighbors(xf, self.x_all, r, exclude_self=True)
        if self.nw:  # boundary rows (walls, structures) over fluid sources
            self.wf_start, self.wf_j = find_neighbors(self.x_all[self.nf:], xf, r)
        else:
            self.wf_start, self.wf_j = np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64)
        if self.periodic is not None:
            self.periodic.boundary_lists(self)

    def correction_matrices(self):
        """``self.L`` [F 13-14] at the current stacked positions, computed once per set of
        positions and neighbour lists: the mu(I) predictor's gradients, the incremental
        projection's lagged pressure gradient and the PPE all need it at the same positions
        within a step."""
        key = self._lists_made
        if (key == self._L_key and self._L_x.shape == self.x_all.shape
                and np.array_equal(self._L_x, self.x_all)):
            return
        K.correction_matrices(self.x_all, self.vol_all, self.ff_start, self.ff_j, self.h,
                              self.kernel, self.L)
        if self._L_x.shape != self.x_all.shape:
            self._L_x = np.empty_like(self.x_all)
        self._L_x[:] = self.x_all
        self._L_key = key

    def gradients(self, free_slip=False):
        """Corrected gradients of p and u at the current positions [F 7, F 13-14];
        ``free_slip``: boundary particles carry no velocity difference (zero normal
        derivative of u at walls and structures)."""
        self.sync()
        self.correction_matrices()
        K.gradients(self.x_all, self.p_all, self.v_all, self.vol_all, self.L, self.ff_start,
                    self.ff_j, self.nf, self.h, self.kernel, self.grad_p, self.grad_v,
                    self.nf if free_slip else -1)

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

    def structure_pressure(self):
        """Pressure of the structure particles from the last solve (stacked)."""
        return self.p_all[self.nf + self.n_walls:]

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
        self.sync()
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
