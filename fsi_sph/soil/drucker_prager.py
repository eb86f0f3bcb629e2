"""Elastoplastic Drucker-Prager soil in updated-Lagrangian SPH [S chapter 4] (PHYSICS.md §6).

One sub-step (symplectic Euler, so that the stress-velocity wave system stays stable):

1. mirror ghosts of the particles near the plane walls, neighbour list of the soil among
   ``[soil; ghosts]`` (rebuilt every sub-step: the soil flows);
2. artificial stress ``R`` (optional) and acceleration from ``sigma^n`` [S 4-9, 4-10];
3. kick ``v^{n+1} = v^n + dt (a + g - xi v^n)``, Coulomb wall friction from the walls'
   contact forces; refresh the ghosts' velocities;
4. velocity gradient and continuity from ``v^{n+1}`` [S 4-5]; Jaumann stress update and
   return mapping [S 4-42 to 4-57, 4-36 to 4-41];
5. drift ``x^{n+1} = x^n + dt v^{n+1}`` (or the XSPH velocity [S 4-71]), ``rho`` update;
   a particle that crossed a wall is put back (with the friction of that contact impulse
   on a Coulomb wall).
"""

from __future__ import annotations

import math

import numpy as np

from fsi_sph.geometry import fill_shapes
from fsi_sph.neighbors import find_neighbors
from fsi_sph.particles import Body, FieldSpec
from fsi_sph.soil import _kernels as K
from fsi_sph.sph.kernels import KERNELS, SUPPORT, kernel_w

SIDES = {"bottom": K.BOTTOM, "left": K.LEFT, "right": K.RIGHT, "top": K.TOP}
FRICTION = {"free_slip": K.FREE_SLIP, "no_slip": K.NO_SLIP, "coulomb": K.COULOMB}


def wall_arrays(walls):
    """Wall description as arrays for the kernels: (side, position, friction code, tan delta)."""
    side = np.array([SIDES[w.side] for w in walls], dtype=np.int64)
    pos = np.array([w.position for w in walls], dtype=np.float64)
    fric = np.array([FRICTION[w.friction] for w in walls], dtype=np.int64)
    mu = np.array([math.tan(math.radians(w.friction_angle_deg or 0.0)) for w in walls])
    return side, pos, fric, mu


class DruckerPragerBody:
    """A Drucker-Prager soil body built from a ``SoilBody`` config section.

    Fields: ``x0, x, v, a, m, rho, sigma (n, 2, 2), szz, eps_p, L, drho`` (+ ``R`` with
    artificial stress, ``vhat`` with XSPH). The combined work arrays (soil rows then ghost
    rows) are kept privately and grow when more ghosts are needed.
    """

    fields = (
        FieldSpec("x0", (2,)), FieldSpec("x", (2,)), FieldSpec("v", (2,)), FieldSpec("a", (2,)),
        FieldSpec("m"), FieldSpec("rho"), FieldSpec("sigma", (2, 2)), FieldSpec("szz"),
        FieldSpec("eps_p"), FieldSpec("L", (2, 2)), FieldSpec("drho"),
    )
    output_fields = ("x", "v", "u", "sigma", "szz", "p", "von_mises", "eps_p", "rho")

    def __init__(self, name, cfg, dx, sph, gravity, walls=()):
        self.name = name
        self.cfg = cfg
        mat = cfg.material
        self.rho0 = mat.rho0
        self.G = mat.E / (2.0 * (1.0 + mat.nu))
        self.K = mat.E / (3.0 * (1.0 - 2.0 * mat.nu))
        # P-wave speed: the fastest signal of the elastic predictor (used in dt and Pi_ij)
        self.c0 = math.sqrt((self.K + 4.0 * self.G / 3.0) / mat.rho0)
        self.set_strength(mat.cohesion, math.radians(mat.friction_angle_deg),
                          math.radians(mat.dilatancy_angle_deg))
        self.dx = dx
        self.h = sph.h_over_dx * dx
        self.kernel = KERNELS[sph.kernel]
        self.w_dx = kernel_w(self.kernel, dx, self.h)
        self.gravity = np.asarray(gravity, dtype=np.float64)
        self.walls = wall_arrays(walls) if len(walls) else (
            np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64), np.zeros(0))
        x0 = fill_shapes(cfg.blocks, dx)
        self.body = b = Body(name, "soil", len(x0))
        extra = []
        if cfg.artificial_stress is not None:
            extra.append(FieldSpec("R", (2, 2)))
        if cfg.xsph is not None:
            extra.append(FieldSpec("vhat", (2,)))
        b.allocate(self.fields + tuple(extra))
        b["x0"][:] = x0
        b["x"][:] = x0
        b["rho"][:] = mat.rho0
        b["m"][:] = mat.rho0 * dx * dx
        if cfg.initial_stress is not None:
            self._geostatic(cfg.initial_stress.k0)
        self.aw = np.zeros((b.n, max(len(self.walls[0]), 1), 2))
        self._alloc_work(max(16, b.n // 2))
        # the lower corner of the neighbour search's cell grid from this body's (None: its
        # own); a body split over ranks takes the corner of all of them (parallel/split.py)
        self.grid_origin = None
        self.n_sub = 0
        self._compile()
        self.n_sub = 0

    # ------------------------------------------------------------------ set-up
    def set_strength(self, cohesion, phi, psi=0.0):
        """Set c (Pa), phi, psi (radians): e.g. reduced strengths for strength reduction."""
        self.cohesion, self.phi, self.psi = cohesion, phi, min(psi, phi)
        self.alpha, self.kc, self.alpha_psi = K.dp_parameters(phi, cohesion, self.psi)

    def _geostatic(self, k0):
        """Initial geostatic stress (config ``initial_stress``): vertical stress from the
        weight of the particle column above (surface = highest particle in the same lattice
        column + dx/2), horizontal and out-of-plane stress ``k0`` times it, returned to the
        yield surface if outside it."""
        b = self.body
        if k0 is None:
            k0 = 1.0 - math.sin(self.phi)  # Jaky
        x = b["x"]
        col = np.round((x[:, 0] - x[:, 0].min()) / self.dx).astype(np.int64)
        top = np.full(col.max() + 1, -np.inf)
        np.maximum.at(top, col, x[:, 1])
        depth = top[col] + 0.5 * self.dx - x[:, 1]
        sv = -self.rho0 * abs(self.gravity[1]) * depth
        b["sigma"][:, 0, 0] = k0 * sv
        b["sigma"][:, 1, 1] = sv
        b["szz"][:] = k0 * sv
        for i in range(b.n):
            s = b["sigma"][i]
            nx, ny, nxy, nz, _ = K.return_map(s[0, 0], s[1, 1], s[0, 1], b["szz"][i], self.alpha,
                                              self.kc, self.alpha_psi, self.G, self.K)
            s[0, 0], s[1, 1], s[0, 1], s[1, 0], b["szz"][i] = nx, ny, nxy, nxy, nz
        # the density that goes with the elastic volumetric strain of that stress
        i1 = b["sigma"][:, 0, 0] + b["sigma"][:, 1, 1] + b["szz"]
        b["rho"][:] = self.rho0 / (1.0 + i1 / (3.0 * self.K))

    def resized(self):
        """A new particle count (a rank's own particles and ghosts,
        fsi_sph/parallel/split.py): the work arrays follow it."""
        self.aw = np.zeros((self.body.n, max(len(self.walls[0]), 1), 2))
        self._alloc_work(max(16, self.body.n // 2))

    def _alloc_work(self, cap):
        n = self.body.n
        tot = n + cap
        self.cap = cap
        self.xa = np.zeros((tot, 2))
        self.va = np.zeros((tot, 2))
        self.vka = np.zeros((tot, 2))  # kinematic velocity (continuity), see fill_ghosts
        self.sa = np.zeros((tot, 2, 2))
        self.za = np.zeros(tot)
        self.ra = np.ones(tot)
        self.ma = np.zeros(tot)
        self.Ra = np.zeros((tot, 2, 2))
        self.src = np.zeros(cap, np.int64)
        self.gwall = np.full(cap, -1, np.int64)
        self.wa = np.zeros(cap, np.int64)
        self.wb = np.zeros(cap, np.int64)
        self.ng = 0

    def _compile(self):
        """Run one zero-length sub-step so that JIT compilation happens at set-up."""
        b = self.body
        snap = {k: v.copy() for k, v in b.arrays.items()}
        self.substep(0.0)
        if self.cfg.stress_filter is not None:
            self.filter_stress()
        for k, v in snap.items():
            b.arrays[k][...] = v

    # ------------------------------------------------------------------ pieces of a sub-step
    def build_ghosts(self):
        """Mirror ghosts in the plane walls and the neighbour list over [soil; ghosts]."""
        b = self.body
        n = b.n
        side, pos, fric, mu = self.walls
        radius = SUPPORT * self.h
        while True:
            self.xa[:n] = b["x"]
            ng = K.make_ghosts(self.xa, n, side, pos, radius, self.xa, self.src, self.wa,
                               self.wb)
            if ng <= self.cap:
                break
            self._alloc_work(2 * ng)
        self.ng = ng
        self.gwall[:ng] = np.where(self.wb[:ng] < 0, self.wa[:ng], -1)
        tot = n + ng
        origin = None
        if self.grid_origin is not None:  # split over ranks: the serial run's cell grid
            origin = self.grid_origin(self.xa[:tot].min(axis=0) - radius)
        self.nbr_start, self.nbr_j = find_neighbors(b["x"], self.xa[:tot], radius,
                                                    exclude_self=True, origin=origin)
        self.refresh_ghosts()

    def refresh_ghosts(self):
        """Copy soil state into the combined arrays and mirror it into the ghost rows."""
        b = self.body
        n = b.n
        self.va[:n] = b["v"]
        self.vka[:n] = b["v"]
        self.sa[:n] = b["sigma"]
        self.za[:n] = b["szz"]
        self.ra[:n] = b["rho"]
        self.ma[:n] = b["m"]
        side, pos, fric, mu = self.walls
        g = self.gravity
        K.fill_ghosts(n, self.ng, self.src, self.wa, self.wb, side, fric, mu, g[0], g[1],
                      self.xa, self.va, self.sa, self.za, self.ra, self.ma, self.vka)

    def accelerations(self):
        """Internal acceleration from the current stress [S 4-9, 4-10] into ``a``."""
        b = self.body
        n = b.n
        tot = n + self.ng
        av = self.cfg.artificial_viscosity
        ast = self.cfg.artificial_stress
        if ast is not None:
            K.artificial_stress(n, b["sigma"], b["rho"], ast.epsilon, self.Ra)
            as_n = ast.exponent
        else:
            as_n = 0.0
        K.momentum(n, self.xa[:tot], self.va[:tot], self.ra[:tot], self.ma[:tot],
                   self.sa[:tot], self.Ra[:tot], self.nbr_start, self.nbr_j, self.h,
                   self.kernel, self.c0, av.alpha, av.beta, as_n, self.w_dx, self.gwall,
                   b["a"], self.aw)

    def update_stress(self, dt):
        """Velocity gradient, continuity, Jaumann stress update and return mapping."""
        b = self.body
        n = b.n
        tot = n + self.ng
        K.velocity_gradient(n, self.xa[:tot], self.va[:tot], self.vka[:tot], self.ra[:tot],
                            self.ma[:tot], self.nbr_start, self.nbr_j, self.h, self.kernel,
                            b["L"], b["drho"])
        K.stress_update(n, b["L"], b["sigma"], b["szz"], b["eps_p"], dt, self.G, self.K,
                        self.alpha, self.kc, self.alpha_psi)

    def filter_stress(self):
        """Shepard filter of the stress (config ``stress_filter``)."""
        b = self.body
        n = b.n
        self.refresh_ghosts()
        tot = n + self.ng
        K.shepard_stress(n, self.xa[:tot], self.ra[:tot], self.ma[:tot], self.sa[:tot],
                         self.za[:tot], self.nbr_start, self.nbr_j, self.h, self.kernel,
                         b["sigma"], b["szz"])

    # ------------------------------------------------------------------ stepping
    def stable_dt(self):
        """[S 4-58]: ``dt = min(cfl h/(c + |v|max), force_factor sqrt(h/|f|max))``
        (no physical viscosity, so no viscous limit)."""
        b = self.body
        vmax = math.sqrt(float(np.max(np.einsum("ij,ij->i", b["v"], b["v"]))))
        dt = self.cfg.cfl * self.h / (self.c0 + vmax)
        f = b["a"] + self.gravity
        fmax = math.sqrt(float(np.max(np.einsum("ij,ij->i", f, f))))
        if fmax > 0.0:
            dt = min(dt, self.cfg.force_factor * math.sqrt(self.h / fmax))
        return dt

    def substep(self, dt):
        b = self.body
        n = b.n
        self.build_ghosts()
        self.accelerations()
        g = self.gravity
        K.integrate(n, b["x"], b["v"], b["v"], b["a"], b["rho"], b["drho"], g[0], g[1],
                    self.cfg.damping, dt, True)
        side, pos, fric, mu = self.walls
        if len(side):
            K.coulomb_friction(n, b["v"], self.aw, side, fric, mu, dt)
        self.refresh_ghosts()
        self.update_stress(dt)
        self.n_sub += 1
        sf = self.cfg.stress_filter
        if sf is not None and self.n_sub % sf.every == 0:
            self.filter_stress()
        if self.cfg.xsph is not None:
            tot = n + self.ng
            K.xsph(n, self.xa[:tot], self.va[:tot], self.ra[:tot], self.ma[:tot],
                   self.nbr_start, self.nbr_j, self.h, self.kernel, self.cfg.xsph.epsilon,
                   b["vhat"])
            vhat = b["vhat"]
        else:
            vhat = b["v"]
        K.integrate(n, b["x"], b["v"], vhat, b["a"], b["rho"], b["drho"], g[0], g[1],
                    self.cfg.damping, dt, False)
        if len(side):
            K.enforce_walls(b["x"], b["v"], side, pos, fric, mu, 1e-3 * self.dx)

    # ------------------------------------------------------------------ diagnostics
    def set_gravity(self, g):
        """The body force per unit mass from now on (a shaken frame's, fsi_sph/frame.py)."""
        self.gravity[:] = g

    def kinetic_energy(self):
        b = self.body
        return 0.5 * float(np.sum(b["m"] * np.einsum("ij,ij->i", b["v"], b["v"])))

    def strain_energy(self):
        """Elastic energy sum V (s:s/(4G) + I1^2/(18K)) (plane strain, 3-D stress)."""
        b = self.body
        s = b["sigma"]
        i1 = s[:, 0, 0] + s[:, 1, 1] + b["szz"]
        m = i1 / 3.0
        ss = ((s[:, 0, 0] - m) ** 2 + (s[:, 1, 1] - m) ** 2 + (b["szz"] - m) ** 2
              + 2.0 * s[:, 0, 1] ** 2)
        vol = b["m"] / b["rho"]
        return float(np.sum(vol * (ss / (4.0 * self.G) + i1**2 / (18.0 * self.K))))

    def momentum(self):
        b = self.body
        return np.sum(b["m"][:, None] * b["v"], axis=0)

    def snapshot(self):
        b = self.body
        s = b["sigma"]
        szz = b["szz"]
        vm = np.sqrt(0.5 * ((s[:, 0, 0] - s[:, 1, 1]) ** 2 + (s[:, 1, 1] - szz) ** 2
                            + (szz - s[:, 0, 0]) ** 2) + 3.0 * s[:, 0, 1] ** 2)
        return {"x": b["x"].copy(), "v": b["v"].copy(), "u": b["x"] - b["x0"],
                "sigma": s.copy(), "szz": szz.copy(),
                "p": -(s[:, 0, 0] + s[:, 1, 1] + szz) / 3.0, "von_mises": vm,
                "eps_p": b["eps_p"].copy(), "rho": b["rho"].copy()}

    def static(self):
        b = self.body
        return {"x0": b["x0"], "m": b["m"]}
