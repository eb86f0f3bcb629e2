"""``[fluid]``: the ISPH fluid (material and viscosity law, PPE, shifting, turbulence,
collisions and the scheme's choices); ``[walls]``: its wall particles."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from fsi_sph.config.base import NonNegative, Positive, StrictModel, Vec2
from fsi_sph.config.open_boundary import Inflow, Outflow
from fsi_sph.config.scene import BlockShape, BodyShape, Shape


class MuIParameters(StrictModel):
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


class FluidMaterial(StrictModel):
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


class PPESection(StrictModel):
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


class ShiftingSection(StrictModel):
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
        "docs/numerics/fluid.md § Energy cap)")

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


class SmagorinskySection(StrictModel):
    """Sub-particle-scale eddy viscosity nu_T = (C_s dx)^2 sqrt(2 S:S) [F 3]."""

    cs: Annotated[float, Field(gt=0.0, le=0.5)] = Field(0.12, description="Smagorinsky constant")


class CollisionSection(StrictModel):
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


class FluidSection(StrictModel):
    """Incompressible SPH fluid (projection method) [F 15-21]."""

    material: FluidMaterial
    blocks: Annotated[list[BlockShape], Field(min_length=1)] = Field(
        description="rectangles {origin, size} or polygons {shape = \"polygon\", vertices} "
        "filled with fluid particles")
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
        0.05, description="coefficient of the density-error term added to the PPE source "
        "(Asai et al. 2012); 0 = the pure divergence-free projection [F 17]. A projection "
        "that keeps div u = 0 does not see a volume error: without this term the water of "
        "a sloshing tank dilated (interior kernel sum 0.973 by 2 s) and the scene gained "
        "2.6 % of its energy; with 0.05 (both signs, gap rows) 0.83 %, and the scene zoo "
        "passes 7 of 12 scenes against 6. Left out on rows beside a coupled structure "
        "(docs/numerics/fluid.md § Density relaxation)")
    density_relaxation_sign: Literal["compression", "both"] = Field(
        "both", description="which interior density errors the relaxation term acts "
        "on: `compression` (sigma > sigma0 only, Asai et al.) or `both` (also an expansion, "
        "sigma < sigma0, so that the water does not dilate)")
    relaxation_gap_rows: bool = Field(
        True, description="with density_relaxation_sign = `both`: the expansion is also "
        "pulled back on interior particles whose support is nearly full (div r >= 1.8, "
        "not only >= 1.95) and that have at least half a full support of fluid neighbours: "
        "a bed row lifted off the floor, which a layer otherwise lets dilate (thin "
        "granular layers 4-5 particles thick hold their profile: 39 -> 8 %; the Poiseuille "
        "channel keeps its particles), but at a granular front one of 19 draws threw a "
        "particle (4.7 m/s, above the inviscid front); docs/numerics/granular.md "
        "§ Density relaxation")
    laplacian: Literal["consistent", "morris"] = Field(
        "consistent", description="PPE Laplacian of the fluid rows [F 11-12, F 20]: "
        "`consistent`: the Morris sum made exact for linear pressure fields on every row "
        "(its first-moment error taken out with the corrected gradient [F 13-14], "
        "_kernels.ppe_fill); `morris`: that correction only on rows with a truncated "
        "support, the plain Morris sum (an M-matrix) in the interior. With `morris` the "
        "hydrostatic pressure seen at displaced particles is not linear, which drives a "
        "growing oscillation of rows against each other: still water blew up after 2.5-3.5 s "
        "(docs/numerics/fluid.md § PPE Laplacian)")
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
        "the a = 0.5 glass-bead collapse at 0.38 s (docs/numerics/fluid.md § Projection: "
        "standard and incremental)")
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
    surface_pocket_rows: Annotated[int, Field(ge=0, le=50)] = Field(
        5, description="free-surface detection: the Poisson rows of a connected set of fewer "
        "than this many Poisson rows beside surface rows are free-surface (p = 0) rows; such "
        "a pocket inside a thin sheet built up 50 kPa in six steps in a dam break onto a "
        "wedge and threw a particle out of the tank (fsi_sph/fluid/free_surface.py); 0 = off "
        "(the mu(I) material's pick: under its incremental projection the rule traded one "
        "thrown particle for another)")
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
    inflow: list[Inflow] = Field(
        [], description="open inflow lines with a prescribed velocity profile, each a buffer "
        "of particles that become fluid as they cross it (fsi_sph/fluid/open_boundary.py)")
    outflow: list[Outflow] = Field(
        [], description="open outflow lines at a given pressure, each a buffer that takes "
        "the fluid particles crossing it and deletes them one kernel support further")

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
        if (self.inflow or self.outflow) and (self.projection != "standard"
                                              or self.periodic_x is not None):
            raise ValueError("fluid.inflow / fluid.outflow need projection = \"standard\" and "
                             "no periodic_x (the incremental projection's carried pressure "
                             "and the periodic images are not worked out for a changing "
                             "particle count)")
        mu_i = self.material.mu_i
        if (self.surface_offset > 0.0 and mu_i is not None
                and mu_i.pressure_offset == "half_spacing"):
            raise ValueError(
                f"surface_offset = {self.surface_offset} puts the head between the surface "
                "particles and the free surface into the pressure itself; "
                "material.mu_i.pressure_offset = \"half_spacing\" would add it a second "
                "time: set pressure_offset = \"none\" (or surface_offset = 0)")
        return self


class WallsSection(StrictModel):
    """Fixed wall particles in several layers; their pressure comes from the PPE solve.

    ``tanks`` are open-top containers given by their inner (fluid-side) rectangle: wall layers
    are laid outside its left, right and bottom sides. ``boxes`` are filled with wall
    particles as they are.
    """

    layers: Annotated[int, Field(ge=1, le=8)] = Field(
        3, description="wall particle layers of a tank; need layers * dx >= 2 h")
    tanks: list[Shape] = Field([], description="open-top tanks, inner rectangle (m)")
    boxes: list[BodyShape] = Field(
        [], description="fixed bodies filled with wall particles (m): rectangles, polygons "
        "and circles (concentric rings); a list is their union, circles carving the shapes "
        "before them")

    @model_validator(mode="after")
    def _not_empty(self):
        if not self.tanks and not self.boxes:
            raise ValueError("[walls] needs at least one of `tanks` or `boxes`")
        return self
