"""Total-Lagrangian SPH elastic body [F 34-45] (PHYSICS.md §4).

Everything is evaluated in the reference configuration: neighbour lists, volumes and
corrected kernel gradients are built once at t = 0. Time integration is velocity Verlet
(kick-drift-kick), which is symplectic, so an undamped plate keeps its energy.
"""

from __future__ import annotations

import math

import numpy as np

from fsi_sph.errors import ConfigError
from fsi_sph.geometry import fill_shapes, in_shapes
from fsi_sph.neighbors import find_neighbors
from fsi_sph.particles import Body, FieldSpec
from fsi_sph.solid import _kernels as K
from fsi_sph.solid.materials import MODELS, lame, wave_speed
from fsi_sph.sph.kernels import KERNELS, SUPPORT


def cantilever_mode(s, length, kl):
    """First-mode shape of a clamped-free beam [F 49-50], s = distance from the root:
    f(s) = (cos kL + cosh kL)(cosh ks - cos ks) + (sin kL - sinh kL)(sinh ks - sin ks)."""
    k = kl / length
    a = math.cos(kl) + math.cosh(kl)
    b = math.sin(kl) - math.sinh(kl)
    return a * (np.cosh(k * s) - np.cos(k * s)) + b * (np.sinh(k * s) - np.sin(k * s))


class ElasticBody:
    """A TLSPH elastic body built from a ``SolidBody`` config section.

    Fields (allocated only for solids): ``x0, x, v, a, m, vol, F, P, f_ext, free``.
    """

    fields = (
        FieldSpec("x0", (2,)), FieldSpec("x", (2,)), FieldSpec("v", (2,)), FieldSpec("a", (2,)),
        FieldSpec("m"), FieldSpec("vol"), FieldSpec("F", (2, 2)), FieldSpec("P", (2, 2)),
        FieldSpec("f_ext", (2,)), FieldSpec("free", (), np.bool_, True),
    )
    #: fields written to each snapshot
    output_fields = ("x", "v", "u", "sigma", "von_mises", "J")

    def __init__(self, name, cfg, dx, sph, gravity):
        self.name = name
        self.cfg = cfg
        mat = cfg.material
        self.rigid = mat.model == "rigid"  # moved as a rigid body (_rigid_substep)
        self.walls = None  # a rigid body's contact with the fixed walls (touch_walls)
        self.rho0 = mat.rho0
        self.plane = mat.plane
        if self.rigid:  # no stress: F stays I, P stays 0
            self.model, self.youngs, self.lam, self.mu, self.c0 = MODELS["stvk"], 0.0, 0.0, 0.0, 0.0
        else:
            self.model = MODELS[mat.model]
            self.youngs = mat.E
            self.lam, self.mu = lame(mat.E, mat.nu, mat.plane)
            self.c0 = wave_speed(mat.E, mat.nu, mat.rho0, mat.plane)
        self.h = sph.h_over_dx * dx
        self.kernel = KERNELS[sph.kernel]
        self.gravity = np.asarray(gravity, dtype=np.float64)
        x0 = fill_shapes(cfg.blocks, dx, f"solid.{name}.blocks")
        self.body = b = Body(name, "solid", len(x0))
        b.allocate(self.fields)
        b["x0"][:] = x0
        b["x"][:] = x0
        b["vol"][:] = dx * dx
        b["m"][:] = mat.rho0 * dx * dx
        for k, shape in enumerate(cfg.clamp):
            held = in_shapes(x0, [shape])
            if not held.any():
                raise ConfigError(f"solid.{name}.clamp[{k}]: holds no particle of the body")
            b["free"][held] = False
        self._set_initial_velocity(cfg.initial_velocity)
        self._build_reference()
        self.update_stress()
        self._accelerations()
        self._compile()

    def _compile(self):
        """Call the step kernels once with dt = 0 so that JIT compilation happens at set-up,
        not inside the timed stepping loop."""
        b = self.body
        K.kick(b["v"], b["a"], self.gravity, b["f_ext"], b["m"], 0.0, 0.0, b["free"])
        K.drift(b["x"], b["v"], 0.0)

    # ------------------------------------------------------------------ set-up
    def _set_initial_velocity(self, iv):
        b = self.body
        if iv is None:
            return
        if iv.profile == "uniform":
            b["v"][:] = iv.value
        else:
            s = b["x0"][:, 0] - iv.root_x
            shape = np.where(s > 0.0, cantilever_mode(np.maximum(s, 0.0), iv.length, iv.kl), 0.0)
            scale = iv.tip_speed / cantilever_mode(iv.length, iv.length, iv.kl)
            d = np.asarray(iv.direction) / np.hypot(*iv.direction)
            b["v"][:] = (scale * shape)[:, None] * d[None, :]
        b["v"][~b["free"]] = 0.0

    def _build_reference(self):
        """Reference neighbours, kernel values and corrected gradients [F 13-14] (once)."""
        b = self.body
        self.nbr_start, self.nbr_j = find_neighbors(b["x0"], b["x0"], SUPPORT * self.h,
                                                    exclude_self=True)
        npairs = len(self.nbr_j)
        gw = np.zeros((npairs, 2))
        self.w = np.zeros(npairs)
        self.L = np.zeros((b.n, 2, 2))
        K.reference_gradients(b["x0"], b["vol"], self.nbr_start, self.nbr_j, self.h,
                              self.kernel, gw, self.w, self.L)
        self._refuse_a_line_of_particles(gw)
        self.gi = np.zeros((npairs, 2))
        self.gj = np.zeros((npairs, 2))
        K.corrected_gradients(self.nbr_start, self.nbr_j, gw, self.L, self.gi, self.gj)
        hg = self.cfg.hourglass
        self.hg_conservative = hg.model == "conservative" and hg.coefficient > 0.0
        self.H = None  # the conservative control's moments (work space of _internal)
        if self.hg_conservative:
            # G_a = sum_b V_b L_a grad W_ab (constant), H_a (updated every step)
            rows = np.repeat(np.arange(b.n), np.diff(self.nbr_start))
            self.G = np.zeros((b.n, 2))
            np.add.at(self.G, rows, b["vol"][self.nbr_j][:, None] * self.gi)
            self.H = np.zeros((b.n, 2, 2))

    def _refuse_a_line_of_particles(self, gw):
        """A body one particle thick somewhere has no neighbour across it: its moment matrix
        ``M_i = sum_j V_j (X_j - X_i) (x) grad W_ij`` [F 13-14] is singular there, and so is the
        deformation gradient [F 34] (its determinant is 0: the stress divides by it)."""
        b = self.body
        rows = np.repeat(np.arange(b.n), np.diff(self.nbr_start))
        dx0 = b["x0"][self.nbr_j] - b["x0"][rows]
        m = np.zeros((b.n, 2, 2))
        np.add.at(m, rows, b["vol"][self.nbr_j][:, None, None] * dx0[:, :, None] * gw[:, None, :])
        det = np.linalg.det(m) if b.n else np.ones(0)
        if b.n and not self.rigid and not np.all(np.abs(det) > 1e-6):
            i = int(np.argmin(np.abs(det)))
            dx = math.sqrt(float(b["vol"][i]))
            raise ConfigError(
                f"solid.{self.name}: at dx = {dx:g} m the body is one particle thick (first at "
                f"x = [{b['x0'][i, 0]:.4g}, {b['x0'][i, 1]:.4g}]); a TLSPH body needs at least "
                f"two particles across: make it thicker or lower case.dx to half its thickness")

    # ------------------------------------------------------------------ stepping
    def stable_dt(self):
        """dt_S = C h / (c_s + |v|max) (PHYSICS §4); a rigid body has no limit of its own
        (one sub-step per fluid step)."""
        if self.rigid:
            return math.inf
        vmax = math.sqrt(float(np.max(np.einsum("ij,ij->i", self.body["v"], self.body["v"]))))
        return self.cfg.cfl * self.h / (self.c0 + vmax)

    def update_stress(self):
        """F [F 36] and P [F 37-40] from the current positions."""
        b = self.body
        self._stress(b["x"], b["F"], b["P"])

    def _stress(self, x, F, P):
        K.deformation_stress(x, self.body["vol"], self.nbr_start, self.nbr_j, self.gi,
                             self.model, self.lam, self.mu, F, P)

    def _accelerations(self):
        b = self.body
        av = self.cfg.artificial_viscosity
        self._internal(b["x"], b["v"], b["F"], b["P"], av.alpha, av.beta, self.H, b["a"])

    def _internal(self, x, v, F, P, av_alpha, av_beta, H, out):
        """Internal acceleration at ``x, v`` with ``F, P`` of ``x``: stress [F 44],
        artificial viscosity [F 41-43] and hourglass control (``H``: the conservative
        control's moments, work space)."""
        b = self.body
        c_hg = self.cfg.hourglass.coefficient
        K.accelerations(x, v, b["x0"], b["vol"], F, P, self.nbr_start, self.nbr_j, self.gi,
                        self.gj, self.w, self.rho0, self.c0, self.h, av_alpha, av_beta,
                        0.0 if self.hg_conservative else c_hg, self.youngs, out)
        if self.hg_conservative:
            K.hourglass_moments(x, b["x0"], b["vol"], F, self.nbr_start, self.nbr_j, self.w, H)
            K.hourglass_conservative(x, b["x0"], b["vol"], b["m"], F, H, self.G, self.nbr_start,
                                     self.nbr_j, self.gj, self.w, c_hg * self.youngs, out)

    def internal_acceleration(self, x):
        """Internal acceleration at positions ``x`` and zero velocity (stress and hourglass
        control; no gravity, external force or artificial viscosity, which acts on
        velocities only), leaving the body's fields as they are (fsi_sph/solid/modes.py)."""
        n = self.body.n
        F, P, H = np.empty((n, 2, 2)), np.empty((n, 2, 2)), np.empty((n, 2, 2))
        out = np.empty((n, 2))
        self._stress(x, F, P)
        self._internal(x, np.zeros((n, 2)), F, P, 0.0, 0.0, H, out)
        return out

    def substep(self, dt):
        """One velocity-Verlet step: kick (dt/2), drift, stress, forces, kick (dt/2).

        The external force ``f_ext`` (N/m, e.g. from the fluid) is held over the step.
        """
        if self.rigid:
            self._rigid_substep(dt)
            return
        b = self.body
        half = 0.5 * dt
        xi = self.cfg.damping
        K.kick(b["v"], b["a"], self.gravity, b["f_ext"], b["m"], xi, half, b["free"])
        K.drift(b["x"], b["v"], dt)
        self.update_stress()
        self._accelerations()
        K.kick(b["v"], b["a"], self.gravity, b["f_ext"], b["m"], xi, half, b["free"])

    def substeps(self, dt, n):
        """``n`` sub-steps of ``dt``: one numba call for the plain elastic body
        (:func:`_kernels.substeps`, the loops of :meth:`substep` in the same order: bit for bit
        the same), :meth:`substep` ``n`` times for a rigid body or the conservative hourglass
        control."""
        if self.rigid or self.hg_conservative:
            for _ in range(n):
                self.substep(dt)
            return
        b = self.body
        av = self.cfg.artificial_viscosity
        K.substeps(n, dt, b["x"], b["v"], b["x0"], b["vol"], b["m"], b["F"], b["P"], b["a"],
                   b["f_ext"], b["free"], self.gravity, self.cfg.damping, self.nbr_start,
                   self.nbr_j, self.gi, self.gj, self.w, self.model, self.lam, self.mu,
                   self.rho0, self.c0, self.h, av.alpha, av.beta, self.cfg.hourglass.coefficient,
                   self.youngs)

    def _rigid_substep(self, dt):
        """A rigid body (``material.model = "rigid"``) under its weight and the held external
        force ``f_ext``: the centre of mass and the rotation about it advance by
        semi-implicit Euler (``V += dt F / M``, ``omega += dt T / I``, then the positions by
        the new ``V`` and an exact rotation by ``dt omega``), so the particles keep their
        distances exactly; ``a`` (every acceleration but the external ones) is 0. Newton-Euler
        for a rigid body in the plane (not in PHYSICS.md; tested against the analytic
        rotation and translation, tests/unit/test_rigid_body.py)."""
        b = self.body
        m, x, v, f = b["m"], b["x"], b["v"], b["f_ext"]
        mass = m.sum()
        xc = m @ x / mass
        r = x - xc
        inertia = float(m @ np.einsum("ij,ij->i", r, r))
        vc = m @ v / mass + dt * (f.sum(axis=0) / mass + self.gravity)
        omega = float(m @ (r[:, 0] * v[:, 1] - r[:, 1] * v[:, 0])) / inertia
        omega += dt * float(np.sum(r[:, 0] * f[:, 1] - r[:, 1] * f[:, 0])) / inertia
        if self.walls is not None:  # no approach into a fixed wall (fsi_sph/solid/contact.py)
            vc, omega = self.walls.resolve(x, xc, vc, omega, mass, inertia)
        c, s = math.cos(dt * omega), math.sin(dt * omega)
        r = np.column_stack([c * r[:, 0] - s * r[:, 1], s * r[:, 0] + c * r[:, 1]])
        x[:] = xc + dt * vc + r
        v[:] = vc + omega * np.column_stack([-r[:, 1], r[:, 0]])
        b["a"][:] = 0.0

    def touch_walls(self, wall_x, spacing):
        """Fixed wall particles this body, if rigid, may not move into."""
        if self.rigid and len(wall_x):
            from fsi_sph.solid.contact import WallContact

            self.walls = WallContact(wall_x, spacing)

    # ------------------------------------------------------------------ diagnostics
    def set_gravity(self, g):
        """The body force per unit mass from now on (a shaken frame's, fsi_sph/frame.py)."""
        self.gravity[:] = g

    def kinetic_energy(self):
        b = self.body
        return 0.5 * float(np.sum(b["m"] * np.einsum("ij,ij->i", b["v"], b["v"])))

    def strain_energy(self):
        return float(K.strain_energy(self.body["F"], self.body["vol"], self.model, self.lam,
                                     self.mu))

    def hourglass_energy(self):
        """Penalty energy of the conservative hourglass control (0 for the other model)."""
        if not self.hg_conservative:
            return 0.0
        b = self.body
        return float(K.hourglass_energy(b["x"], b["x0"], b["vol"], b["F"], self.nbr_start,
                                        self.nbr_j, self.w,
                                        self.cfg.hourglass.coefficient * self.youngs))

    def momentum(self):
        b = self.body
        return np.sum(b["m"][:, None] * b["v"], axis=0)

    def snapshot(self):
        """Fields written to the output at a snapshot."""
        b = self.body
        sigma = K.cauchy_stress(b["F"], b["P"])
        s00, s11, s01 = sigma[:, 0, 0], sigma[:, 1, 1], sigma[:, 0, 1]
        # sigma_zz: nu (s00 + s11) in plane strain (small strain), 0 in plane stress and in a
        # rigid body (no elastic constants: a floating rigid body's first snapshot divided
        # by zero here)
        elastic = self.lam + self.mu > 0.0
        szz = self.lam / (self.lam + self.mu) * 0.5 * (s00 + s11) \
            if self.plane == "strain" and elastic else np.zeros_like(s00)
        vm = np.sqrt(0.5 * ((s00 - s11) ** 2 + (s11 - szz) ** 2 + (szz - s00) ** 2) + 3 * s01**2)
        return {"x": b["x"].copy(), "v": b["v"].copy(), "u": b["x"] - b["x0"], "sigma": sigma,
                "von_mises": vm, "J": np.linalg.det(b["F"])}

    def static(self):
        """Fields that never change, written once."""
        b = self.body
        return {"x0": b["x0"], "m": b["m"], "vol": b["vol"],
                "clamped": (~b["free"]).astype(np.int8)}
