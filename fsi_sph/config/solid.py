"""``[solid.NAME]``: a TLSPH elastic (or rigid) body, its material, artificial viscosity,
hourglass control and initial velocity."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from fsi_sph.config.base import NonNegative, Positive, StrictModel, Vec2
from fsi_sph.config.scene import BlockShape


class Material(StrictModel):
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


class ArtificialViscosity(StrictModel):
    """Monaghan artificial viscosity mapped to the reference frame [F 41-43]."""

    alpha: NonNegative = Field(1.0, description="linear coefficient")
    beta: NonNegative = Field(0.0, description="quadratic coefficient")


class Hourglass(StrictModel):
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


class UniformVelocity(StrictModel):
    profile: Literal["uniform"]
    value: Vec2 = Field(description="initial velocity (m/s)")


class CantileverMode(StrictModel):
    """First bending mode of a cantilever clamped at ``root_x`` [F 49-50]: velocity along
    ``direction`` = tip_speed * f(x - root_x) / f(length); zero at x < root_x."""

    profile: Literal["cantilever_mode"]
    root_x: float = Field(description="x of the clamped root (m)")
    length: Positive = Field(description="free length L (m)")
    tip_speed: float = Field(description="initial tip speed (m/s)")
    kl: Positive = Field(1.875, description="mode wave number times L (1.875 for mode 1)")
    direction: Vec2 = Field((0.0, 1.0), description="unit direction of the velocity")


InitialVelocity = Annotated[UniformVelocity | CantileverMode, Field(discriminator="profile")]


class SolidBody(StrictModel):
    """One total-Lagrangian SPH elastic body [F 34-45]."""

    material: Material
    blocks: Annotated[list[BlockShape], Field(min_length=1)] = Field(
        description="shapes filled with particles")
    clamp: list[BlockShape] = Field([], description="particles inside these shapes are held fixed")
    initial_velocity: InitialVelocity | None = None
    artificial_viscosity: ArtificialViscosity = ArtificialViscosity()
    hourglass: Hourglass = Hourglass()
    damping: NonNegative = Field(
        0.0, description="Rayleigh mass-proportional damping xi (1/s) [F 45]")
    cfl: Annotated[float, Field(gt=0.0, le=1.0)] = Field(
        0.3, description="dt = cfl * h / (c_s + |v|max)")
