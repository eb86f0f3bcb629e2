"""Case files: TOML -> strict, typed, frozen config models.

A case file is TOML. The presence of a table enables a physics module (``[solid.NAME]``
builds a TLSPH body named NAME); absent tables cost nothing. ``extends = "file.toml"``
(or a list of files, relative to the including file) merges shared fragments table by
table, the including file winning. ``--set key.path=value`` overrides any key; the value
is read as a TOML value, or as a plain string when it is not one.

Every error is a :class:`ConfigError` whose message names the file, the key path and what
is allowed; it never escapes as a traceback from the CLI (exit code 2).

>>> cfg = load_config(None, text='[case]\\nt_end = 1.0\\ndx = 0.1\\n'
...     '[solid.bar]\\nmaterial = {rho0 = 1000.0, E = 1e6, nu = 0.3}\\n'
...     'blocks = [{origin = [0.0, 0.0], size = [1.0, 0.2]}]\\n')
>>> cfg.solid["bar"].material.model, cfg.sph.kernel
('stvk', 'cubic_spline')
"""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from fsi_sph.errors import ConfigError

Vec2 = tuple[float, float]
Positive = Annotated[float, Field(gt=0.0)]
NonNegative = Annotated[float, Field(ge=0.0)]
Name = Annotated[str, Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$", max_length=64)]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)


# ---------------------------------------------------------------------------- sections


class Shape(_Model):
    """An axis-aligned rectangle ``origin + [0, size]`` (m)."""

    shape: Literal["rectangle"] = Field("rectangle", description="primitive kind")
    origin: Vec2 = Field(description="lower-left corner (m)")
    size: tuple[Positive, Positive] = Field(description="width and height (m), > 0")


class Polygon(_Model):
    """A simple polygon given by its vertices (m), in order; closed automatically."""

    shape: Literal["polygon"] = Field(description="primitive kind")
    vertices: Annotated[list[Vec2], Field(min_length=3)] = Field(
        description="corner points [x, y] (m), at least 3, in order around the polygon")


SoilShape = Annotated[Shape | Polygon, Field(union_mode="left_to_right")]


class CaseSection(_Model):
    """Run control: duration, resolution, output cadence, gravity."""

    name: str = Field("case", description="case name, used for output folders")
    t_end: Positive = Field(description="simulated time (s)")
    dx: Positive = Field(description="initial particle spacing for all bodies (m)")
    output_every: Positive = Field(0.01, description="snapshot interval (s)")
    probe_every: NonNegative = Field(0.0, description="probe sampling interval (s); 0 = every step")
    gravity: Vec2 = Field((0.0, -9.81), description="body force per unit mass (m/s^2)")


class SphSection(_Model):
    """Shared SPH numerics."""

    kernel: Literal["cubic_spline", "wendland_c2"] = Field(
        "cubic_spline", description="smoothing kernel [F 5]; support 2h for both")
    h_over_dx: Annotated[float, Field(ge=1.0, le=2.0)] = Field(
        1.2, description="smoothing length over particle spacing")


class Material(_Model):
    """Material of a solid body: elastic TLSPH [F 37-40], plane strain (default) or plane
    stress; or ``rigid`` (a free body moved as a rigid body by the fluid's force and its
    weight: only ``rho0``)."""

    model: Literal["stvk", "hooke_almansi", "neo_hookean", "rigid"] = Field(
        "stvk", description="St Venant-Kirchhoff, the source's Hooke law on the Almansi strain, "
        "compressible Neo-Hookean, or rigid (no deformation; needs a fluid to move it)")
    rho0: Positive = Field(description="reference density (kg/m^3)")
    E: Positive | None = Field(None, description="Young's modulus (Pa); elastic models")
    nu: Annotated[float, Field(gt=-1.0, lt=0.5)] | None = Field(
        None, description="Poisson's ratio, in (-1, 0.5); elastic models")
    plane: Literal["strain", "stress"] = Field(
        "strain", description="2D idealisation: plane strain (PHYSICS.md §4) or plane stress "
        "(sigma_zz = 0: lambda replaced by 2 lambda mu/(lambda + 2 mu))")

    @model_validator(mode="after")
    def _elastic_constants(self):
        if self.model != "rigid" and (self.E is None or self.nu is None):
            missing = " and ".join(k for k in ("E", "nu") if getattr(self, k) is None)
            raise ValueError(f"model = {self.model!r} needs {missing}")
        if self.model == "rigid" and (self.E is not None or self.nu is not None):
            raise ValueError("model = 'rigid' takes no E or nu (it does not deform)")
        return self


class ArtificialViscosity(_Model):
    """Monaghan artificial viscosity mapped to the reference frame [F 41-43]."""

    alpha: NonNegative = Field(1.0, description="linear coefficient")
    beta: NonNegative = Field(0.0, description="quadratic coefficient")


class Hourglass(_Model):
    """Hourglass (zero-energy mode) control; coefficient 0 turns it off.

    ``ganzenmueller``: the penalty force of Ganzenmueller (2015) on the pair-wise difference
    between F_i X_ij and x_ij; not derived from a potential, it dissipates energy.
    ``conservative``: the exact gradient of the penalty energy
    (c/4) sum V_i V_j W_ij |F_i X_ij - x_ij|^2 / |X_ij|^2, c = coefficient * E: conserves
    energy and momentum (the energy probe reports it as ``hourglass``).
    """

    model: Literal["ganzenmueller", "conservative"] = Field(
        "ganzenmueller", description="hourglass force law")

    coefficient: NonNegative = Field(10.0, description="penalty coefficient alpha_HG")


class UniformVelocity(_Model):
    profile: Literal["uniform"]
    value: Vec2 = Field(description="initial velocity (m/s)")


class CantileverMode(_Model):
    """First bending mode of a cantilever clamped at ``root_x`` [F 49-50]: velocity along
    ``direction`` = tip_speed * f(x - root_x) / f(length); zero at x < root_x."""

    profile: Literal["cantilever_mode"]
    root_x: float = Field(description="x of the clamped root (m)")
    length: Positive = Field(description="free length L (m)")
    tip_speed: float = Field(description="initial tip speed (m/s)")
    kl: Positive = Field(1.875, description="mode wave number times L (1.875 for mode 1)")
    direction: Vec2 = Field((0.0, 1.0), description="unit direction of the velocity")


InitialVelocity = Annotated[UniformVelocity | CantileverMode, Field(discriminator="profile")]


class SolidBody(_Model):
    """One total-Lagrangian SPH elastic body [F 34-45]."""

    material: Material
    blocks: Annotated[list[Shape], Field(min_length=1)] = Field(
        description="shapes filled with particles")
    clamp: list[Shape] = Field([], description="particles inside these shapes are held fixed")
    initial_velocity: InitialVelocity | None = None
    artificial_viscosity: ArtificialViscosity = ArtificialViscosity()
    hourglass: Hourglass = Hourglass()
    damping: NonNegative = Field(
        0.0, description="Rayleigh mass-proportional damping xi (1/s) [F 45]")
    cfl: Annotated[float, Field(gt=0.0, le=1.0)] = Field(
        0.3, description="dt = cfl * h / (c_s + |v|max)")


class GuardSection(_Model):
    """Blow-up guard: checks that stop a run gone bad (see fsi_sph/guard.py)."""

    check_every: Annotated[int, Field(ge=1)] = Field(
        10, description="check every N steps (and before every snapshot)")
    domain: Shape | None = Field(
        None, description="particles must stay inside; default: the initial bounding box of "
        "the bodies and walls grown by 3 times its size on every side")
    energy_factor: Annotated[float, Field(gt=1.0)] = Field(
        10.0, description="stop when the kinetic energy exceeds this times the initial "
        "kinetic + strain energy plus the work gravity can do across the domain")


class DruckerPragerMaterial(_Model):
    """Elastoplastic Drucker-Prager soil, plane-strain Mohr-Coulomb fit [S 4-36 to 4-41]."""

    model: Literal["drucker_prager"] = Field(description="constitutive model")
    rho0: Positive = Field(description="initial density (kg/m^3)")
    E: Positive = Field(description="Young's modulus (Pa)")
    nu: Annotated[float, Field(gt=-1.0, lt=0.5)] = Field(description="Poisson's ratio")
    friction_angle_deg: Annotated[float, Field(ge=0.0, lt=90.0)] = Field(
        description="internal friction angle phi (degrees)")
    cohesion: NonNegative = Field(0.0, description="cohesion c (Pa)")
    dilatancy_angle_deg: Annotated[float, Field(ge=0.0, lt=90.0)] = Field(
        0.0, description="dilatancy angle psi (degrees), <= phi; 0 = no plastic volume change")

    @model_validator(mode="after")
    def _psi_le_phi(self):
        if self.dilatancy_angle_deg > self.friction_angle_deg:
            raise ValueError("dilatancy_angle_deg must not exceed friction_angle_deg")
        if self.friction_angle_deg == 0.0 and self.cohesion == 0.0:
            raise ValueError("a soil needs friction_angle_deg > 0 or cohesion > 0")
        return self


class SoilViscosity(_Model):
    """Monaghan artificial viscosity of the soil [S 4-10]."""

    alpha: NonNegative = Field(0.1, description="linear coefficient")
    beta: NonNegative = Field(0.1, description="quadratic coefficient")


class ArtificialStress(_Model):
    """Artificial stress against the tensile instability (Gray, Monaghan & Swift 2001)."""

    epsilon: NonNegative = Field(0.3, description="coefficient on tensile principal stresses")
    exponent: Positive = Field(2.55, description="n in f = (W_ij / W(dx))^n")


class Xsph(_Model):
    """XSPH transport velocity [S 4-71]."""

    epsilon: Annotated[float, Field(ge=0.0, le=1.0)] = Field(0.5, description="coefficient")


class StressFilter(_Model):
    """Stress regularisation: a Shepard filter of the stress every ``every`` sub-steps
    (Nguyen et al. 2017, for granular flows)."""

    every: Annotated[int, Field(ge=1)] = Field(20, description="sub-steps between filterings")


class InitialStress(_Model):
    """Geostatic initial stress: ``sigma_yy = -rho0 |g| (y_surface - y)``,
    ``sigma_xx = sigma_zz = k0 sigma_yy`` (tension positive), with ``y_surface`` the top of
    the particle column above each particle (e.g. a column held by a gate before release)."""

    k0: Annotated[float, Field(gt=0.0, le=1.0)] | None = Field(
        None, description="lateral earth pressure coefficient; default Jaky's 1 - sin(phi)")


class SoilBody(_Model):
    """One Drucker-Prager soil body (updated-Lagrangian SPH, PHYSICS.md §6)."""

    material: DruckerPragerMaterial
    blocks: Annotated[list[SoilShape], Field(min_length=1)] = Field(
        description="rectangles {origin, size} or polygons {shape = \"polygon\", vertices} "
        "filled with particles")
    artificial_viscosity: SoilViscosity = SoilViscosity()
    artificial_stress: ArtificialStress | None = Field(
        None, description="present -> artificial stress on")
    xsph: Xsph | None = Field(None, description="present -> XSPH position update")
    stress_filter: StressFilter | None = Field(
        None, description="present -> Shepard filter of the stress every few sub-steps")
    initial_stress: InitialStress | None = Field(
        None, description="present -> start from a geostatic stress state (else from zero)")
    damping: NonNegative = Field(
        0.0, description="mass-proportional damping xi (1/s): dv/dt += -xi v (quasi-static runs)")
    cfl: Annotated[float, Field(gt=0.0, le=1.0)] = Field(
        0.4, description="dt <= cfl h/(c + |v|max) [S 4-58]")
    force_factor: Annotated[float, Field(gt=0.0, le=1.0)] = Field(
        0.25, description="dt <= force_factor sqrt(h/|a|max) [S 4-58]")


class Wall(_Model):
    """A rigid plane wall bounding the soil, modelled by mirror ghost particles."""

    side: Literal["bottom", "left", "right", "top"] = Field(
        description="which side of the soil the wall is on (bottom: floor y = position)")
    position: float = Field(description="x (left/right) or y (bottom/top) of the wall (m)")
    friction: Literal["free_slip", "no_slip", "coulomb"] = Field(
        "no_slip", description="tangential condition; coulomb limits the wall shear stress to "
        "tan(friction_angle_deg) times the normal pressure")
    friction_angle_deg: Annotated[float, Field(ge=0.0, lt=90.0)] | None = Field(
        None, description="wall friction angle delta (degrees), for friction = coulomb")

    @model_validator(mode="after")
    def _angle(self):
        if (self.friction == "coulomb") != (self.friction_angle_deg is not None):
            raise ValueError("friction_angle_deg is required with friction = \"coulomb\" and "
                             "allowed only then")
        return self


class Boundary(_Model):
    """Rigid walls of the scene (used by the soil bodies)."""

    walls: Annotated[list[Wall], Field(min_length=1)] = Field(description="plane walls")




# ---------------------------------------------------------------------------- fluid


class MuIParameters(_Model):
    """mu(I) granular rheology (PHYSICS.md §7) [G 31-35]; see fsi_sph/fluid/rheology.py."""

    mu_s: Positive = Field(description="static friction coefficient mu_s (tan of the "
                           "angle of repose)")
    mu_2: Positive = Field(description="limiting friction coefficient mu_2 at large I, > mu_s")
    I0: Positive = Field(description="reference inertial number I0 [G 31, G 41]")
    d: Positive = Field(description="grain diameter (m) [G 32]")
    rho_s: Positive = Field(description="grain density (kg/m^3) [G 32]")
    eta_max: Positive = Field(description="cap on the apparent dynamic viscosity (Pa s)")
    alpha_r: Positive = Field(0.01, description="regularisation rate alpha_r (1/s) [G 35]")
    pressure_offset: Literal["half_spacing", "none"] = Field(
        "half_spacing", description="`half_spacing`: the law's confining pressure is the ISPH "
        "pressure plus rho |g| dx / 2, the head of the half spacing between the p = 0 "
        "surface-particle centres and the real free surface, added for the law only; `none`: "
        "the ISPH pressure (use it with fluid.surface_offset = 0.5 and surface_scan = "
        "false, which puts that head into the pressure field itself, so that the pressure "
        "force sees it too)")

    @model_validator(mode="after")
    def _mu2_gt_mus(self):
        if self.mu_2 <= self.mu_s:
            raise ValueError(f"mu_2 = {self.mu_2} must exceed mu_s = {self.mu_s} "
                             "(mu(I) rises from mu_s to mu_2 [G 31])")
        return self


class FluidMaterial(_Model):
    """Incompressible fluid: constant density; the viscosity law of the material.

    ``viscosity``: ``newtonian`` (constant ``nu``), ``smagorinsky`` (``nu`` plus the eddy
    viscosity [F 3], constant from ``[fluid.smagorinsky]`` or its default) or ``mu_i``
    (apparent viscosity of the mu(I) law [G 31-35] from the table ``mu_i``; ``nu`` unused).
    """

    rho0: Positive = Field(description="density (kg/m^3); the bulk density for mu_i")
    nu: NonNegative = Field(1.0e-6, description="kinematic viscosity (m^2/s)")
    viscosity: Literal["newtonian", "smagorinsky", "mu_i"] = Field(
        "newtonian", description="viscosity law of the material")
    mu_i: MuIParameters | None = Field(None, description="parameters of the mu_i law")

    @model_validator(mode="after")
    def _law_parameters(self):
        if (self.viscosity == "mu_i") != (self.mu_i is not None):
            raise ValueError(f"viscosity = {self.viscosity!r}: the `mu_i` parameter table is "
                             "required with viscosity = \"mu_i\" and allowed only then")
        return self


class PPESection(_Model):
    """Pressure Poisson equation [F 17, F 20]: pyamg AMG as preconditioner of a Krylov method.

    The AMG hierarchy is kept across steps as long as the iteration count stays low: it is
    rebuilt when a solve takes more than ``rebuild_growth`` times the iterations of the first
    solve after the last rebuild (and at least 2 more), or after ``rebuild_every`` steps.
    Between rebuilds its finest level is the current matrix (``refresh_finest``).
    """

    krylov: Literal["bicgstab", "gmres"] = Field(
        "gmres", description="Krylov method (the matrix is not symmetric): BiCGStab (two "
        "V-cycles per iteration) or flexible GMRES (one V-cycle per iteration)")
    gmres_restart: Annotated[int, Field(ge=1)] = Field(
        20, description="GMRES restart length (iterations per cycle)")
    amg: Literal["ruge_stuben", "smoothed_aggregation"] = Field(
        "ruge_stuben", description="AMG hierarchy used as the preconditioner")
    strength_theta: Annotated[float, Field(gt=0.0, lt=1.0)] = Field(
        0.25, description="Ruge-Stuben strength threshold: a_ij is a strong connection when "
        "-a_ij >= theta max_k(-a_ik)")
    rtol: Annotated[float, Field(gt=0.0, lt=1.0)] = Field(
        1.0e-6, description="relative residual ||b - A p|| / ||b|| at which the solve stops")
    maxiter: Annotated[int, Field(ge=1)] = Field(200, description="Krylov iteration limit")
    rebuild_growth: Annotated[float, Field(ge=1.0)] = Field(
        1.5, description="rebuild the AMG hierarchy when iterations exceed this factor times "
        "the iterations right after the last rebuild")
    rebuild_every: Annotated[int, Field(ge=1)] = Field(
        100, description="rebuild the AMG hierarchy at least every this many steps")
    refresh_finest: bool = Field(
        True, description="between rebuilds, smooth the finest AMG level with the current "
        "matrix (coarse levels kept)")


SHIFT_DEFAULTS = {"fickian": 2.0, "fickian_fixed": 0.1, "centroid": 0.1}


class ShiftingSection(_Model):
    """Particle shifting [F 22-33]; free- and near-surface particles shift tangentially only.

    ``fickian``: dr = -A h |u| dt grad C (Lind et al. 2012, the alternative PHYSICS.md §3
    allows); ``fickian_fixed``: dr = -A h^2 grad C; ``centroid``:
    dr = eps sum_b V_b r_ab W_ab [F 23-25].
    """

    model: Literal["fickian", "fickian_fixed", "centroid"] = Field(
        "fickian", description="shift law")
    coefficient: Positive = Field(
        description="A for fickian (dimensionless, 1-6; default 2), D / h^2 for "
        "fickian_fixed (about 0.01-0.5; default 0.1), eps for centroid (0.1-0.2; default "
        "0.1)")
    max_shift: Annotated[float, Field(gt=0.0, le=0.5)] = Field(
        0.2, description="cap on |dr| in units of h")
    taylor_correction: bool = Field(
        True, description="correct velocity and pressure by phi += dr . grad phi [F 33]")
    taylor_energy_cap: bool = Field(
        True, description="the Taylor-corrected velocity is scaled back to the particle's "
        "speed before the shift where it would be faster: the shift makes no kinetic energy "
        "(without it the dam break's spray gained energy without bound, +56 % by 3 s; "
        "docs/session_notes_2026-12-01f.md)")

    @model_validator(mode="before")
    @classmethod
    def _default_coefficient(cls, data):
        """The coefficient's default follows the law: one number for all three took
        fickian_fixed to D = 2 h^2 per step, which blew still water up in 0.2 s."""
        if isinstance(data, dict) and "coefficient" not in data:  # (an unknown law: the
            # model field's own error names the allowed ones)
            law = data.get("model", "fickian")
            data = {**data, "coefficient": SHIFT_DEFAULTS.get(law, SHIFT_DEFAULTS["fickian"])}
        return data


class SmagorinskySection(_Model):
    """Sub-particle-scale eddy viscosity nu_T = (C_s dx)^2 sqrt(2 S:S) [F 3]."""

    cs: Annotated[float, Field(gt=0.0, le=0.5)] = Field(0.12, description="Smagorinsky constant")


class CollisionSection(_Model):
    """Particle collision model: fluid particles closer than ``distance`` dx that approach
    each other lose the approach velocity as in an inelastic collision (momentum
    conserved). For granular materials, whose free-surface particles (p = 0) meet no
    pressure: without it the thin tip of a collapsing column packed 4 particles within
    0.3 dx, and the PPE row of such a clump threw them off at 10-30 m/s."""

    distance: Annotated[float, Field(gt=0.0, le=1.0)] = Field(
        0.5, description="contact distance in particle spacings")
    restitution: Annotated[float, Field(ge=0.0, le=1.0)] = Field(
        0.0, description="restitution coefficient e: the approach velocity becomes -e times "
        "itself (0: the pair stops approaching)")


class FluidSection(_Model):
    """Incompressible SPH fluid (projection method) [F 15-21]."""

    material: FluidMaterial
    blocks: Annotated[list[Shape], Field(min_length=1)] = Field(
        description="shapes filled with fluid particles")
    ppe: PPESection = PPESection()
    shifting: ShiftingSection | None = Field(None, description="absent: no shifting")
    smagorinsky: SmagorinskySection | None = Field(None, description="absent: no eddy viscosity")
    pressure_gradient: Literal["corrected", "conservative", "interface_conservative"] = Field(
        "corrected", description="pressure gradient of the correction step: `corrected` "
        "L_i sum V_j (p_j - p_i) grad W_ij [F 7, F 13] (exact for linear p also where the "
        "support is truncated, so a tank at rest stays at rest), `conservative` "
        "sum V_j (p_i + p_j) grad W_ij [F 10] (antisymmetric pair forces: momentum conserved "
        "to round-off, but a free-surface particle sees half the hydrostatic gradient and "
        "still water blows up after ~0.5 s) or `interface_conservative`: conservative on the "
        "rows with a coupled structure within their support (where the interface force "
        "[F 46-47] must balance), corrected elsewhere (holds still water around a submerged "
        "structure; the coupled cases use it with [fluid.collision], without which their "
        "shallow draining water threw particles out at 0.25-0.5 s)")
    density_relaxation: Annotated[float, Field(ge=0.0, le=1.0)] = Field(
        0.0, description="coefficient of the compression-only density-error term added to "
        "the PPE source (Asai et al. 2012); 0 = the pure divergence-free projection [F 17]")
    density_relaxation_sign: Literal["compression", "both"] = Field(
        "compression", description="which interior density errors the relaxation term acts "
        "on: `compression` (sigma > sigma0 only, Asai et al.) or `both` (also an expansion, "
        "sigma < sigma0, so that a sheared layer does not dilate)")
    relaxation_gap_rows: bool = Field(
        False, description="with density_relaxation_sign = `both`: the expansion is also "
        "pulled back on interior particles whose support is nearly full (div r >= 1.8, "
        "not only >= 1.95) and that have at least half a full support of fluid neighbours: "
        "a bed row lifted off the floor, which the layer otherwise lets dilate (thin "
        "granular layers 4-5 particles thick hold their profile: 39 -> 8 %), but at a "
        "granular front one of 19 draws threw a particle (4.7 m/s, above the inviscid "
        "front); set by the mu(I) cases, measured in docs/session_notes_2026-12-01c.md")
    laplacian: Literal["consistent", "morris"] = Field(
        "consistent", description="PPE Laplacian of the fluid rows [F 11-12, F 20]: "
        "`consistent`: the Morris sum made exact for linear pressure fields on every row "
        "(its first-moment error taken out with the corrected gradient [F 13-14], "
        "_kernels.ppe_fill); `morris`: that correction only on rows with a truncated "
        "support, the plain Morris sum (an M-matrix) in the interior. With `morris` the "
        "hydrostatic pressure seen at displaced particles is not linear, which drives a "
        "growing oscillation of rows against each other: still water blew up after 2.5-3.5 s "
        "(docs/session_notes_2026-12-01f.md)")
    position_update: Literal["damped", "trapezoid"] = Field(
        "damped", description="particle move of the correction step: `trapezoid` "
        "r^{n+1} = r^n + dt (u^n + u^{n+1}) / 2 [F 19]; `damped` r^{n+1} = r^n + dt u^{n+1} + "
        "dt (u^{n+1} - u^n) / 2. The pressure is solved at r^n (not at the predicted r* of "
        "[F 15]), and with forces at r^n the trapezoid amplifies every oscillation by "
        "(1 + (omega dt)^2 / 2)^(1/2) per step (short free-surface waves grew by 2 % per "
        "step in a tank at rest); `damped` takes it down by about (omega dt)^2 / 4 per step, "
        "as the predicted positions of [F 15] would (negligible for waves with "
        "omega dt << 1)")
    cfl: Annotated[float, Field(gt=0.0, le=0.5)] = Field(
        0.2, description="advective limit dt = cfl h / |u|max [F 48]")
    dt_max: Positive = Field(1.0, description="upper bound on the fluid time step (s)")
    jitter: Annotated[float, Field(ge=0.0, le=0.1)] = Field(
        0.0, description="each initial fluid particle is moved by a random displacement, "
        "uniform in [-jitter, jitter] dx per component (seeded by `jitter_seed`): one "
        "realization of a flow whose details depend on the lattice's accidents (a granular "
        "tail one or two particles thick); 0 = the regular lattice")
    jitter_seed: Annotated[int, Field(ge=0)] = Field(
        0, description="seed of the random generator of `jitter`")
    initial_velocity: Vec2 = Field(
        (0.0, 0.0), description="velocity of every fluid particle at t = 0 (m/s)")
    viscous_step: Literal["explicit", "implicit"] = Field(
        "explicit", description="`explicit`: the viscous term of [F 16] at u^n, dt bounded by "
        "0.125 h^2 / nu_max; `implicit`: (I - dt nu lap) u** = u^n, u* = u** + dt g, solved "
        "as a sparse system (pyamg-preconditioned CG), no viscous bound on dt "
        "(fsi_sph/fluid/viscous.py)")
    viscous_rtol: Annotated[float, Field(gt=0.0, lt=1.0)] = Field(
        1.0e-8, description="relative residual of the implicit viscous solve")
    viscous_operator: Literal["morris", "stress"] = Field(
        "morris", description="`morris`: the viscous term is div(eta grad u) [F 11-12] per "
        "velocity component; `stress`: div(2 eta D), the Morris form plus the divergence of "
        "eta (grad u)^T, which differs where eta varies (mu(I) law; fsi_sph/fluid/viscous.py)")
    projection: Literal["standard", "incremental"] = Field(
        "standard", description="`standard`: the non-incremental projection [F 16-18], the "
        "PPE for p^{n+1}; `incremental`: the pressure-correction form (Goda 1979, van Kan "
        "1986): u* with the lagged pressure acceleration -grad p^n / rho, the PPE for the "
        "increment phi = p^{n+1} - p^n, u^{n+1} = u* - dt grad phi / rho "
        "(fsi_sph/fluid/increments.py; fixed walls and periodicity only, no coupled "
        "structures)")
    incremental_damping: Annotated[float, Field(ge=0.0, le=1.0)] = Field(
        0.0, description="incremental projection only: the fraction beta of the "
        "non-incremental pressure (the standard PPE of u* + dt grad p^n / rho) mixed into "
        "p^{n+1} every step, p^{n+1} = (1 - beta) (p^n + phi) + beta p_standard; damps the "
        "particle-scale pressure noise that the carried pressure accumulates (the gradient "
        "hardly sees it, so no increment takes it back); 0 = the pure incremental form. "
        "Experimental: 0.1 made the sand collapse's run-out independent of dt but blew up "
        "the a = 0.5 glass-bead collapse at 0.38 s (docs/incr_notes_2026-11-30.md)")
    surface_offset: Annotated[float, Field(ge=0.0, le=1.0)] = Field(
        0.0, description="distance (in dx) from a free-surface particle to the free surface "
        "it stands for; the surface rows' pressure condition p = 0 holds there, so a surface "
        "particle takes p_s = offset dx max(0, -n . grad p^n), the last pressure extrapolated "
        "along the surface normal n, at most offset dx rho max(0, -g . n) (in a layer at rest "
        "rho g cos(theta) dx / 2 with 0.5; 0 in free fall). 0 = the particle is on the "
        "surface (PHYSICS.md [F 20-21] as written). "
        "With 0 a layer k particles thick carries the weight of k - 1/2 of them: 10 % short "
        "at 5 rows, which a frictional (mu(I)) material reads as 10 % less friction "
        "(fsi_sph/fluid/pressure_solve.py PressureSolve.surface_pressure)")
    surface_scan: bool = Field(
        True, description="free-surface detection: besides div r < 1.4 [F 21], a particle "
        "whose umbrella region along its outward normal holds no neighbour (Marrone et al. "
        "2010) is a free-surface (p = 0) particle; catches the face of a thin front whose "
        "div r is raised by neighbours crowded behind it, which div r alone left a Poisson "
        "row and which was thrown off (fsi_sph/fluid/free_surface.py); false = div r only")
    surface_isolated_rows: bool = Field(
        True, description="free-surface detection: a particle whose fluid neighbours are all "
        "free-surface particles is a free-surface (p = 0) particle too; as a Poisson row "
        "supported only by surface rows and by walls that extrapolate their pressure from it, "
        "it built up tens of kPa in a few steps at a granular front and was thrown "
        "(fsi_sph/fluid/free_surface.py); false = off")
    collision: CollisionSection | None = Field(
        None, description="absent: no particle collision model")
    wall_pressure: Literal["adami", "mirror"] = Field(
        "mirror", description="pressure of the fixed wall particles in the PPE: `adami` "
        "p_w = <p_f> + rho g . (x_w - <x_f>) (Adami et al. 2012), whose hydrostatic term "
        "also holds a droplet beside a vertical wall; `mirror` (default): the hydrostatic term "
        "along the wall's normal only, and along the wall the fluid's own (fluid-only, lagged) "
        "pressure gradient: the same at rest, and a droplet or film on a vertical wall "
        "falls (fsi_sph/fluid/boundary.py BoundaryRows.wall_body_force)")
    wall_contact: Literal["projection", "inelastic"] = Field(
        "projection", description="`projection`: the pressure solve keeps the fluid out of "
        "the fixed walls (the kinematic guard acts on the corrected velocity only); "
        "`inelastic`: before the solve, a particle at or reaching half a spacing from a "
        "wall loses its velocity into it (a grain's contact, restitution 0), so that no "
        "impulsive pressure stops it and kicks its neighbours (fsi_sph/fluid/"
        "kinematic_guard.py KinematicGuard.inelastic_contact)")
    wall_suction: bool = Field(
        True, description="false: a fixed wall cannot pull a fluid particle: in the "
        "correction's pressure gradient a wall particle's pressure is at least the fluid "
        "particle's own, carried hydrostatically to it (at a granular front Adami's wall "
        "pressure fell below that of a particle pressed against the floor, which was then "
        "pushed into it and its pressure grew 2.5-fold per step; fsi_sph/fluid/_kernels/"
        "pressure.py wall_floor). The floor acts on free-surface and near-surface particles only: "
        "beside interior particles it only rectified the pressure's particle-scale noise "
        "into a push off the wall that lifted a thin flowing layer (fsi_sph/fluid/rows.py "
        "RowRoles.floor_rows)")
    tension_cutoff: bool = Field(
        False, description="cohesionless material: negative pressures are set to 0 after "
        "every pressure solve, and the correction uses the cut-off field, so a region in "
        "tension dilates (grains separate) instead of pulling its neighbours (a granular toe "
        "particle flagged interior for one step drew -4.4 kPa and was thrown off at 2.7 m/s "
        "without it; fsi_sph/fluid/isph.py). Where it acts the mu(I) law sees p = 0: no "
        "friction")
    periodic_x: Vec2 | None = Field(
        None, description="[x_min, x_max] (m): the fluid (and its walls) is periodic in x "
        "with period x_max - x_min (fsi_sph/fluid/periodic.py); absent: not periodic")

    @model_validator(mode="after")
    def _fluid_options(self):
        law = self.material.viscosity
        if self.smagorinsky is not None and law == "mu_i":
            raise ValueError("[fluid.smagorinsky] applies to the newtonian and smagorinsky "
                             "viscosity laws, not to material.viscosity = \"mu_i\"")
        if self.periodic_x is not None and not self.periodic_x[1] > self.periodic_x[0]:
            raise ValueError(f"periodic_x = {list(self.periodic_x)}: need x_max > x_min")
        if self.surface_offset > 0.0 and self.surface_scan:
            raise ValueError(
                f"surface_offset = {self.surface_offset} needs surface_scan = false: the "
                "umbrella scan makes a waterline particle against a side wall a surface "
                "particle, whose normal tilts away from the wall, and the offset's pressure "
                "extrapolated along it made a tank at rest drift (5e-3 m/s in 0.3 s)")
        mu_i = self.material.mu_i
        if (self.surface_offset > 0.0 and mu_i is not None
                and mu_i.pressure_offset == "half_spacing"):
            raise ValueError(
                f"surface_offset = {self.surface_offset} puts the head between the surface "
                "particles and the free surface into the pressure itself; "
                "material.mu_i.pressure_offset = \"half_spacing\" would add it a second "
                "time: set pressure_offset = \"none\" (or surface_offset = 0)")
        return self


class WallsSection(_Model):
    """Fixed wall particles in several layers; their pressure comes from the PPE solve.

    ``tanks`` are open-top containers given by their inner (fluid-side) rectangle: wall layers
    are laid outside its left, right and bottom sides. ``boxes`` are filled with wall
    particles as they are.
    """

    layers: Annotated[int, Field(ge=1, le=8)] = Field(
        3, description="wall particle layers of a tank; need layers * dx >= 2 h")
    tanks: list[Shape] = Field([], description="open-top tanks, inner rectangle (m)")
    boxes: list[Shape] = Field([], description="rectangles filled with wall particles (m)")

    @model_validator(mode="after")
    def _not_empty(self):
        if not self.tanks and not self.boxes:
            raise ValueError("[walls] needs at least one of `tanks` or `boxes`")
        return self


class CouplingSection(_Model):
    """Fluid-structure coupling (PHYSICS.md §5): the listed solids are moving boundaries of
    the fluid and receive its interface pressure force [F 46-48]."""

    structures: Annotated[list[Name], Field(min_length=1)] = Field(
        description="names of the [solid.NAME] bodies coupled to the fluid")
    substeps: Annotated[int, Field(ge=1)] | None = Field(
        None, description="solid sub-steps per fluid step; default ceil(dt_fluid / dt_solid) "
        "from the two stability limits (the source uses 100)")
    structure_acceleration: Literal["auto", "implicit", "explicit", "rigid"] = Field(
        "auto", description="how the pressure solve sees the structures' acceleration: "
        "`implicit` solves for the fluid's share particle by particle (clamped structures: "
        "the gate, the obstacle; a free bulky body blows up with it), `rigid` sees each body "
        "as rigid and solves for its acceleration (translation and rotation) under the "
        "fluid's force (free bodies: floating, sinking, rising; no clamp; the body itself "
        "still deforms in its sub-cycles), `explicit` takes the last sub-cycle's (the plain "
        "staggered scheme; unstable when the added mass exceeds the structure's mass), "
        "`auto` picks `implicit` when every coupled structure is clamped and `rigid` when "
        "none is")


class Probe(_Model):
    """A time series recorded during the run."""

    name: Name
    kind: Literal["point_displacement", "energy", "pressure", "surge_front",
                  "fluid_stats"] = Field(
        description="point_displacement: the particle nearest to `at` in the reference "
        "configuration; energy: kinetic and strain energy of a body; pressure: fluid pressure "
        "at `at` (Shepard interpolation over fluid and wall particles); surge_front: largest "
        "x of the fluid particles with at least 3 fluid neighbours; fluid_stats: max speed and "
        "kinetic energy of the fluid")
    body: Name
    at: Vec2 | None = Field(None, description="position (m), for point_displacement and pressure")

    @model_validator(mode="after")
    def _needs_at(self):
        if self.kind in ("point_displacement", "pressure") and self.at is None:
            raise ValueError(f"a {self.kind} probe needs `at = [x, y]`")
        return self


class Config(_Model):
    """A whole scene."""

    case: CaseSection
    sph: SphSection = SphSection()
    guard: GuardSection = GuardSection()
    fluid: FluidSection | None = Field(None, description="absent: no fluid")
    walls: WallsSection | None = Field(None, description="absent: no wall particles")
    solid: dict[Name, SolidBody] = Field({}, description="TLSPH elastic bodies by name")
    soil: dict[Name, SoilBody] = Field({}, description="Drucker-Prager soil bodies by name")
    boundary: Boundary | None = Field(None, description="rigid plane walls")
    coupling: CouplingSection | None = Field(None, description="absent: bodies ignore each "
                                             "other")
    probes: list[Probe] = []

    @model_validator(mode="after")
    def _cross_references(self):
        bodies = set(self.solid) | set(self.soil)
        both = set(self.solid) & set(self.soil)
        if both:
            raise ValueError(f"body name(s) used for both a solid and a soil: {sorted(both)}")
        if self.fluid is not None:
            if "fluid" in bodies:
                raise ValueError("the body name `fluid` is reserved for the fluid")
            bodies.add("fluid")
        if not bodies:
            raise ValueError("the scene has no body: add a [fluid], [solid.NAME] or "
                             "[soil.NAME] table")
        if self.fluid is not None and self.fluid.periodic_x is not None:
            period = self.fluid.periodic_x[1] - self.fluid.periodic_x[0]
            support = 2.0 * self.sph.h_over_dx * self.case.dx
            if period < 2.0 * support + self.case.dx:
                raise ValueError(f"fluid.periodic_x: period {period:g} m is shorter than two "
                                 f"kernel supports plus dx ({2.0 * support + self.case.dx:g} m)"
                                 ": a particle would meet two images of one neighbour")
        if self.walls is not None and self.fluid is None:
            raise ValueError("[walls] without [fluid]: walls only bound the fluid")
        for name, sec in self.solid.items():
            if sec.material.model != "rigid":
                continue
            if sec.clamp:
                raise ValueError(f"solid.{name}: a rigid body cannot be clamped (a fixed "
                                 f"rigid obstacle is a [walls] box)")
            if self.coupling is None or name not in self.coupling.structures:
                raise ValueError(f"solid.{name}: a rigid body moves only under a fluid's "
                                 f"force; list it in coupling.structures")
        fluid_kinds = ("pressure", "surge_front", "fluid_stats")
        if self.coupling is not None:
            if self.fluid is None:
                raise ValueError("[coupling] needs a [fluid] table")
            if self.fluid.pressure_gradient == "corrected":
                raise ValueError(
                    "[coupling] needs fluid.pressure_gradient = \"interface_conservative\" "
                    "(or \"conservative\"): the interface "
                    "force is the pair form V_s V_f (p_s + p_f) grad W [F 46-47], which balances "
                    "only against the same form on the fluid side (a difference-form gradient "
                    "beside it pushes the fluid off the structure under a uniform pressure)")
            if self.fluid.periodic_x is not None:
                raise ValueError("[coupling] with fluid.periodic_x is not supported")
            if self.fluid.projection == "incremental":
                raise ValueError("[coupling] with fluid.projection = \"incremental\" is not "
                                 "supported (the structures' predicted velocity in the "
                                 "increment's PPE is not worked out)")
            for k, name in enumerate(self.coupling.structures):
                if name not in self.solid:
                    raise ValueError(f"coupling.structures[{k}] = {name!r} names no solid; "
                                     f"solids are: {', '.join(sorted(self.solid)) or 'none'}")
            self._check_structure_scheme()
        seen = set()
        for k, p in enumerate(self.probes):
            if p.body not in bodies:
                raise ValueError(f"probes[{k}].body = {p.body!r} names no body; "
                                 f"bodies are: {', '.join(sorted(bodies))}")
            if (p.kind in fluid_kinds) != (p.body == "fluid"):
                raise ValueError(f"probes[{k}]: kind {p.kind!r} does not apply to body "
                                 f"{p.body!r}")
            if p.name in seen:
                raise ValueError(f"probes[{k}].name = {p.name!r} is used twice")
            seen.add(p.name)
        return self

    def structure_scheme(self) -> str:
        """``coupling.structure_acceleration`` with ``auto`` resolved: ``implicit`` when every
        coupled structure is clamped, ``rigid`` when none is."""
        scheme = self.coupling.structure_acceleration
        if scheme != "auto":
            return scheme
        return "rigid" if self._clamped_and_free()[1] else "implicit"

    def _clamped_and_free(self):
        """The coupled structures' names, clamped and free."""
        names = self.coupling.structures
        return ([n for n in names if self.solid[n].clamp],
                [n for n in names if not self.solid[n].clamp])

    def _check_structure_scheme(self):
        """Each scheme's structures: ``implicit`` clamped ones (a free bulky body blows up
        with it), ``rigid`` free ones; ``auto`` cannot mix them."""
        clamped, free = self._clamped_and_free()
        scheme = self.coupling.structure_acceleration
        if scheme == "rigid" and clamped:
            raise ValueError(
                f"coupling.structure_acceleration = \"rigid\" is for free bodies, but "
                f"solid.{clamped[0]} has a clamp; use \"implicit\" for clamped structures")
        if scheme == "implicit" and free:
            raise ValueError(
                f"coupling.structure_acceleration = \"implicit\" is for clamped structures, "
                f"but solid.{free[0]} has no clamp (a free body's surface is not held by its "
                f"neighbours in the implicit rows: a free square in still water blew up in "
                f"170 steps); use \"rigid\" for free bodies")
        if scheme == "auto" and clamped and free:
            raise ValueError(
                f"coupling.structures mixes clamped ({', '.join(clamped)}) and free "
                f"({', '.join(free)}) solids: `auto` picks \"implicit\" for clamped and "
                f"\"rigid\" for free ones, not both in one scene; set "
                f"coupling.structure_acceleration = \"explicit\" (stable only where each "
                f"structure outweighs its added mass) or couple one kind")

    def modules(self) -> list[str]:
        """The physics modules this scene enables, in the order the step runs them."""
        mods = []
        if self.fluid is not None:
            mods.append("isph_fluid")
            if self.walls is not None:
                mods.append("walls")
            if self.fluid.shifting is not None:
                mods.append(f"shifting:{self.fluid.shifting.model}")
            if self.fluid.smagorinsky is not None or self.fluid.material.viscosity != "newtonian":
                mods.append(self.fluid.material.viscosity if self.fluid.material.viscosity
                            != "newtonian" else "smagorinsky")
            if self.fluid.viscous_step == "implicit":
                mods.append("implicit_viscosity")
            if self.fluid.periodic_x is not None:
                mods.append("periodic_x")
        for name, sec in self.solid.items():
            kind = "rigid_body" if sec.material.model == "rigid" else "tlsph_elastic_solid"
            mods.append(f"{kind}:{name}")
        if self.coupling is not None:
            mods.append("fsi_coupling:" + ",".join(self.coupling.structures)
                        + f"({self.structure_scheme()})")
        for name in self.soil:
            mods.append(f"drucker_prager_soil:{name}")
        if self.boundary is not None:
            mods.append(f"plane_walls:{len(self.boundary.walls)}")
        return mods

    def to_json(self) -> str:
        return json.dumps(self.model_dump(mode="json"), indent=1)


# ---------------------------------------------------------------------------- loading


def _read_toml(path: Path, included_from: str | None) -> dict:
    where = f" (extends of {included_from})" if included_from else ""
    if not path.exists():
        raise ConfigError(f"{path}: file not found{where}")
    if path.is_dir():
        raise ConfigError(f"{path}: is a directory, expected a .toml case file{where}")
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise ConfigError(f"{path}: cannot read file{where}: {e.strerror}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: not a UTF-8 text file{where}") from None
    return _parse_toml(text, str(path))


def _parse_toml(text: str, label: str) -> dict:
    if not text.strip():
        raise ConfigError(f"{label}: file is empty; a case needs at least a [case] table")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{label}: TOML syntax error: {e}") from None
    if not data:
        raise ConfigError(f"{label}: file has no keys or tables; a case needs at least a "
                          "[case] table")
    return data


def _merge(base: dict, top: dict) -> dict:
    """Deep merge: tables merge key by key, everything else in ``top`` replaces ``base``."""
    out = dict(base)
    for k, v in top.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = _merge(out[k], v)
        else:
            out[k] = v
    return out


def _resolve_extends(data: dict, path: Path | None, stack: tuple[Path, ...]) -> dict:
    ext = data.pop("extends", None)
    if ext is None:
        return data
    label = str(path) if path else "<text>"
    if isinstance(ext, str):
        ext = [ext]
    if not isinstance(ext, list) or not all(isinstance(e, str) for e in ext):
        raise ConfigError(f"{label}: extends: expected a file name or a list of file names")
    base: dict = {}
    for e in ext:
        parent = path.parent if path else Path.cwd()
        target = (parent / e).resolve()
        if target in stack:
            chain = " -> ".join(str(p) for p in (*stack, target))
            raise ConfigError(f"{label}: extends: cycle: {chain}")
        sub = _read_toml(target, label)
        sub = _resolve_extends(sub, target, (*stack, target))
        base = _merge(base, sub)
    return _merge(base, data)


def _parse_value(text: str) -> Any:
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def apply_overrides(data: dict, overrides: list[str], label: str) -> dict:
    """Apply ``key.path=value`` overrides to the raw (merged) table."""
    data = json.loads(json.dumps(data))  # deep copy of plain TOML data
    for item in overrides:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key or any(not part for part in key.split(".")):
            raise ConfigError(f"--set {item!r}: expected KEY.PATH=VALUE, e.g. case.dx=0.002")
        node = data
        parts = key.split(".")
        for part in parts[:-1]:
            nxt = node.setdefault(part, {})
            if not isinstance(nxt, dict):
                raise ConfigError(f"{label}: --set {key}: {part!r} is a value, not a table")
            node = nxt
        node[parts[-1]] = _parse_value(value.strip())
    return data


def _allowed_keys(loc: tuple) -> list[str] | None:
    """Field names allowed in the table that holds ``loc[-1]`` (None if unknown)."""
    ann: Any = Config
    for part in loc[:-1]:
        ann = _child(ann, part)
        if ann is None:
            return None
    model = _inner_model(ann)
    return sorted(model.model_fields) if model is not None else None


def _child(ann: Any, part: Any) -> Any:
    """The annotation of item ``part`` (a field name, dict key or list index) of ``ann``."""
    meta = getattr(ann, "__metadata__", None)
    if meta is not None:  # Annotated[X, ...]
        return _child(ann.__origin__, part)
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        field = ann.model_fields.get(part) if isinstance(part, str) else None
        return field.annotation if field is not None else None
    origin = getattr(ann, "__origin__", None)
    args = getattr(ann, "__args__", ())
    if origin is dict:
        return args[1]
    if origin in (list, tuple):
        return args[0]
    for a in args:  # unions: the first member that has this item
        c = _child(a, part)
        if c is not None:
            return c
    return None


def _inner_model(annotation: Any) -> Any:
    """Unwrap list[...], dict[..., M], Optional[M], Annotated[M, ...] down to a model class."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    if getattr(annotation, "__metadata__", None) is not None:
        return _inner_model(annotation.__origin__)
    for a in reversed(getattr(annotation, "__args__", ())):
        m = _inner_model(a)
        if m is not None:
            return m
    return None


def _format_errors(err: ValidationError, label: str, data: dict) -> str:
    lines = []
    for e in err.errors():
        loc = tuple(p for p in e["loc"] if p not in ("cantilever_mode", "uniform", "Shape",
                                                      "Polygon"))
        path = ".".join(str(p) if not isinstance(p, int) else f"[{p}]" for p in loc)
        path = path.replace(".[", "[")
        msg = e["msg"]
        if e["type"] == "extra_forbidden":
            allowed = _allowed_keys(loc)
            what = "table" if isinstance(e.get("input"), dict) else "key"
            msg = f"unknown {what}" + (f"; allowed: {', '.join(allowed)}" if allowed else "")
        elif e["type"] == "missing":
            msg = "required " + ("table" if loc and loc[-1] in ("case", "material") else "key")
            msg += " is missing"
        elif e["type"] == "value_error":
            msg = msg.removeprefix("Value error, ")
        else:
            got = e.get("input")
            if not isinstance(got, dict):
                msg += f" (got {json.dumps(got)})"
        lines.append(f"{label}: {path}: {msg}" if path else f"{label}: {msg}")
    return "\n".join(lines)


def load_config(path: str | Path | None, overrides: list[str] | None = None,
                text: str | None = None) -> Config:
    """Read, merge (``extends``), override and validate a case.

    Parameters
    ----------
    path : the case file; ``None`` with ``text`` to parse a string.
    overrides : ``["key.path=value", ...]`` applied after ``extends``.
    text : TOML source used instead of reading ``path``.

    Raises
    ------
    ConfigError : with a message naming the file, the key path and what is allowed.
    """
    if text is not None:
        label = str(path) if path else "<text>"
        data = _parse_toml(text, label)
        p = Path(path).resolve() if path else None
    else:
        p = Path(path).resolve()
        label = str(path)
        data = _read_toml(p, None)
    data = _resolve_extends(data, p, (p,) if p else ())
    data = apply_overrides(data, overrides or [], label)
    case = data.get("case")
    if isinstance(case, dict) and "name" not in case and p is not None:
        case["name"] = p.stem
    for k in ("t_end", "dx"):  # catch NaN/inf that TOML allows
        v = case.get(k) if isinstance(case, dict) else None
        if isinstance(v, float) and not math.isfinite(v):
            raise ConfigError(f"{label}: case.{k}: must be a finite number (got {v})")
    try:
        return Config.model_validate_json(json.dumps(data), strict=True)
    except ValidationError as e:
        raise ConfigError(_format_errors(e, label, data)) from None
    except ValueError as e:  # json cannot encode NaN/inf comparisons etc.
        raise ConfigError(f"{label}: {e}") from None


def load_config_from_run(run_file, overrides: list[str] | None = None) -> Config:
    """The config stored in a run file (``fsi-sph run --restart RUN.h5`` without a case),
    with ``overrides`` applied (e.g. a later ``case.t_end``)."""
    from fsi_sph.output import read_config

    label = f"{run_file} (stored config)"
    try:
        data = json.loads(read_config(run_file))
    except (OSError, KeyError, ValueError) as e:
        raise ConfigError(f"{run_file}: cannot read the config stored in the run file: {e}") \
            from None
    data = apply_overrides(data, overrides or [], label)
    try:
        return Config.model_validate_json(json.dumps(data), strict=True)
    except ValidationError as e:
        raise ConfigError(_format_errors(e, label, data)) from None
