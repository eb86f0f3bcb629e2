"""``[soil.NAME]``: a Drucker-Prager soil body and its options; ``[boundary]``: rigid plane
walls."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from fsi_sph.config.base import NonNegative, Positive, StrictModel
from fsi_sph.config.scene import SoilShape


class DruckerPragerMaterial(StrictModel):
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


class SoilViscosity(StrictModel):
    """Monaghan artificial viscosity of the soil [S 4-10]."""

    alpha: NonNegative = Field(0.1, description="linear coefficient")
    beta: NonNegative = Field(0.1, description="quadratic coefficient")


class ArtificialStress(StrictModel):
    """Artificial stress against the tensile instability (Gray, Monaghan & Swift 2001)."""

    epsilon: NonNegative = Field(0.3, description="coefficient on tensile principal stresses")
    exponent: Positive = Field(2.55, description="n in f = (W_ij / W(dx))^n")


class Xsph(StrictModel):
    """XSPH transport velocity [S 4-71]."""

    epsilon: Annotated[float, Field(ge=0.0, le=1.0)] = Field(0.5, description="coefficient")


class StressFilter(StrictModel):
    """Stress regularisation: a Shepard filter of the stress every ``every`` sub-steps
    (Nguyen et al. 2017, for granular flows)."""

    every: Annotated[int, Field(ge=1)] = Field(20, description="sub-steps between filterings")


class InitialStress(StrictModel):
    """Geostatic initial stress: ``sigma_yy = -rho0 |g| (y_surface - y)``,
    ``sigma_xx = sigma_zz = k0 sigma_yy`` (tension positive), with ``y_surface`` the top of
    the particle column above each particle (e.g. a column held by a gate before release)."""

    k0: Annotated[float, Field(gt=0.0, le=1.0)] | None = Field(
        None, description="lateral earth pressure coefficient; default Jaky's 1 - sin(phi)")


class SoilBody(StrictModel):
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


class Wall(StrictModel):
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


class Boundary(StrictModel):
    """Rigid walls of the scene (used by the soil bodies)."""

    walls: Annotated[list[Wall], Field(min_length=1)] = Field(description="plane walls")
