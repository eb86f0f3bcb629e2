"""``[coupling]``, ``[[probes]]`` and :class:`Config`, the whole scene with its
cross-references."""

from __future__ import annotations

import json
from typing import Annotated, Literal

from pydantic import Field, PrivateAttr, model_validator

from fsi_sph.config.base import Name, StrictModel, Vec2
from fsi_sph.config.fluid import FluidSection, WallsSection
from fsi_sph.config.open_boundary import check_open_boundaries
from fsi_sph.config.scene import BodyShape, CaseSection, GuardSection, SphSection
from fsi_sph.config.soil import Boundary, SoilBody
from fsi_sph.config.solid import SolidBody


class CouplingSection(StrictModel):
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


class ProbeReference(StrictModel):
    """A reference curve drawn over a probe column by ``fsi-sph plot``."""

    file: str = Field(description="text table (t in its first column), relative to the "
                      "reference-data folder (`fsi-sph plot --data`)")
    column: str = Field(description="probe column the curve is drawn over, e.g. `ux`")
    label: str = Field(description="legend entry, e.g. the source")
    value_column: Annotated[int, Field(ge=1)] = Field(1, description="column of the values")
    subtract_first: bool = Field(False, description="subtract the first value (a digitised "
                                 "displacement measured from its rest position)")


class Probe(StrictModel):
    """A time series recorded during the run."""

    name: Name
    kind: Literal["point_displacement", "energy", "pressure", "surge_front",
                  "fluid_stats", "force"] = Field(
        description="point_displacement: the material point at `at` in the reference "
        "configuration (the nearest particle, carried to the point by its deformation "
        "gradient on an elastic body); energy: kinetic and strain energy of a body; pressure: "
        "fluid pressure at `at` (Shepard interpolation over fluid and wall particles); "
        "surge_front: largest x of the fluid particles with at least 3 fluid neighbours; "
        "fluid_stats: max speed and kinetic energy of the fluid; force: the fluid's force "
        "(fx, fy; N/m) on `body` (the fixed `walls` or a coupled solid), on its particles "
        "inside `region` if given")
    body: Name
    at: Vec2 | None = Field(None, description="position (m), for point_displacement and pressure")
    reference: list[ProbeReference] = Field([], description="reference curves drawn over "
                                            "the probe's plot")
    region: list[BodyShape] = Field(
        [], description="force probes: the named part of the body, its particles inside these "
        "shapes (reference positions); empty = the whole body")

    @model_validator(mode="after")
    def _needs_at(self):
        if self.kind in ("point_displacement", "pressure") and self.at is None:
            raise ValueError(f"a {self.kind} probe needs `at = [x, y]`")
        return self


class Config(StrictModel):
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
    _numerics_picked: tuple = PrivateAttr(default=())

    def remember_picks(self, picks) -> None:
        """Keep what the loader picked (:func:`fsi_sph.config.numerics.pick_numerics`)."""
        self._numerics_picked = tuple(picks)

    def numerics_picked(self) -> tuple:
        """The numerical choices the loader filled in from the declared physics
        (:class:`fsi_sph.config.numerics.Pick`: key, value, reason)."""
        return self._numerics_picked

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
        if self.case.shaking is not None and self.fluid is not None \
                and self.fluid.periodic_x is not None:
            raise ValueError("case.shaking with fluid.periodic_x is not supported (the periodic "
                             "images' wall body force is set once, at the start)")
        check_open_boundaries(self)
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
            if p.kind == "force":
                self._check_force_probe(k, p)
            elif p.region:
                raise ValueError(f"probes[{k}].region: only force probes take a region")
            elif p.body not in bodies:
                raise ValueError(f"probes[{k}].body = {p.body!r} names no body; "
                                 f"bodies are: {', '.join(sorted(bodies))}")
            if (p.kind in fluid_kinds) != (p.body == "fluid"):
                raise ValueError(f"probes[{k}]: kind {p.kind!r} does not apply to body "
                                 f"{p.body!r}")
            if p.name in seen:
                raise ValueError(f"probes[{k}].name = {p.name!r} is used twice")
            seen.add(p.name)
        return self

    def _check_force_probe(self, k, p):
        """A force probe reads the fluid's force on boundary rows: the walls or a coupled
        solid."""
        allowed = (["walls"] if self.walls is not None else []) + (
            list(self.coupling.structures) if self.coupling is not None else [])
        if self.fluid is None or p.body not in allowed:
            raise ValueError(f"probes[{k}].body = {p.body!r}: a force probe needs a [fluid] "
                             f"and names the walls or a coupled solid; allowed: "
                             f"{', '.join(allowed) or 'none in this scene'}")

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
