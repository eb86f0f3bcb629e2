"""Numerical choices that follow from the physics a scene declares.

A case file holds physics, geometry, resolution and output; the numerics come from the
defaults of the config models and, where a choice truly depends on the physics, from the
rules below. Each rule fills a key only where the case leaves it out, so a user can still
override any of them; :func:`pick_numerics` returns what it filled and why, which
``fsi-sph info`` and the run log print.

The rules, with the measurement behind each (docs/numerics/fluid.md, granular.md and
coupling.md hold the full record):

- **Every fluid** shifts its particles: without shifting the dam break's slow corner clumped
  (div r up to 2.6) and the Bagnold layer lost its lattice order within 0.5 s. A free-surface
  flow of a Newtonian fluid takes the fixed-coefficient Fickian law (the velocity-scaled Lind
  form does not act where the flow is slow, and the dam break diverged with it). (Every fluid
  also relaxes its density error both ways: not a pick but the default of
  ``FluidSection.density_relaxation``, since every scene measured needs it.)
- **A mu(I) granular material** (``fluid.material.viscosity = "mu_i"``): the implicit
  viscous step with the stress-divergence operator (the apparent viscosity reaches eta_max),
  the incremental projection, the trapezoidal move, walls without suction, grain collisions,
  div-r-only surface detection, and Taylor-corrected shifting without the energy cap: the set
  the Bagnold layer and the Lube collapses are validated with (docs/numerics/granular.md).
- **A structure coupled to the fluid** (``[coupling]``): the conservative pressure gradient
  on the rows beside the structure (the interface force balances only against the same pair
  form), the collision model (the shallow water draining past the gate and the obstacle threw
  particles out at 0.25-0.5 s without it) and velocity-scaled Fickian shifting. The fluid step
  stays the advective one: a 2e-4 s bound for clamped structures was dropped when the obstacle
  ladder at the advective step came out 37.0 / 42.2 / 39.8 / 39.1 mm over 3 / 4 / 6 / 8 across
  (inside the published 39-51 mm at the finest rung, 38.9 mm with the bound) and the gate's
  finest rungs 40.3 mm as with it, in a third of the wall time; free bodies gain energy with
  the number of steps (a pontoon: 7.6 % at 2e-4 s, 0.45 % at the advective step),
  docs/numerics/coupling.md.
- **Open boundaries** (``[[fluid.inflow]]``, ``[[fluid.outflow]]``): velocity-scaled Fickian
  shifting (without shifting the PPE diverged within 3 s); docs/validation/channel_poiseuille.md.
- **A cohesive soil** (``cohesion > 0``): artificial stress against the tensile instability
  (a cohesive soil carries tension, where the SPH particles clump without it).

``shifting = false`` or ``collision = false`` in a case switches that model off.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Pick:
    """One numerical choice filled in from the scene's physics."""

    key: str
    value: Any
    reason: str

    def __str__(self) -> str:
        value = "on, with its defaults" if self.value == {} else repr(self.value)
        return f"{self.key} = {value}  ({self.reason})"


GRANULAR = "mu(I) granular material"
COUPLED = "structure coupled to the fluid"
FREE_SURFACE = "Newtonian fluid"

_GRANULAR_FLUID = {
    "viscous_step": "implicit",
    "viscous_operator": "stress",
    "projection": "incremental",
    "position_update": "trapezoid",
    "wall_suction": False,
    "surface_scan": False,
    "surface_pocket_rows": 0,
    "collision": {},
}
_GRANULAR_SHIFTING = {"model": "fickian_fixed", "taylor_energy_cap": False}

_COUPLED_FLUID = {
    "pressure_gradient": "interface_conservative",
    "collision": {},
}
_COUPLED_SHIFTING = {"model": "fickian"}

_NEWTONIAN_SHIFTING = {"model": "fickian_fixed"}

_THROUGH_FLOW_SHIFTING = {"model": "fickian"}
THROUGH_FLOW = "open boundaries (inflow, outflow)"


def _fill(table: dict, defaults: dict, prefix: str, reason: str, picks: list[Pick]) -> None:
    """Set each key of ``defaults`` that ``table`` lacks; a sub-table the case gives is
    completed key by key."""
    for key, value in defaults.items():
        if key not in table:
            table[key] = copy.deepcopy(value)
            picks.append(Pick(f"{prefix}.{key}", value, reason))
        elif isinstance(value, dict) and isinstance(table[key], dict):
            _fill(table[key], value, f"{prefix}.{key}", reason, picks)


def _switch_off(table: dict, key: str) -> None:
    """``key = false`` in a case: the optional model is off (None)."""
    if table.get(key) is False:
        table[key] = None


def _fluid_picks(data: dict, picks: list[Pick]) -> None:
    fluid = data.get("fluid")
    if not isinstance(fluid, dict):
        return
    material = fluid.get("material")
    granular = isinstance(material, dict) and material.get("viscosity") == "mu_i"
    coupled = isinstance(data.get("coupling"), dict)
    through_flow = bool(fluid.get("inflow") or fluid.get("outflow"))
    for key in ("shifting", "collision"):
        _switch_off(fluid, key)
    if granular:
        _fill(fluid, _GRANULAR_FLUID, "fluid", GRANULAR, picks)
    if coupled and not granular:
        _fill(fluid, _COUPLED_FLUID, "fluid", COUPLED, picks)
    # the shifting law: the first of these the scene declares
    shifting, reason = next(
        (law, why) for declared, law, why in (
            (granular, _GRANULAR_SHIFTING, GRANULAR),
            (through_flow, _THROUGH_FLOW_SHIFTING, THROUGH_FLOW),
            (coupled, _COUPLED_SHIFTING, COUPLED),
            (True, _NEWTONIAN_SHIFTING, FREE_SURFACE)) if declared)
    if fluid.get("shifting", {}) is not None:
        fluid.setdefault("shifting", {})
        if isinstance(fluid["shifting"], dict):
            _fill(fluid["shifting"], shifting, "fluid.shifting", reason, picks)


def _soil_picks(data: dict, picks: list[Pick]) -> None:
    soils = data.get("soil")
    if not isinstance(soils, dict):
        return
    for name, body in soils.items():
        if not isinstance(body, dict):
            continue
        _switch_off(body, "artificial_stress")
        material = body.get("material")
        cohesive = isinstance(material, dict) and (material.get("cohesion") or 0.0) > 0.0
        if cohesive:
            _fill(body, {"artificial_stress": {}}, f"soil.{name}", "cohesive soil", picks)


def pick_numerics(data: dict) -> tuple[dict, list[Pick]]:
    """The raw (merged, overridden) case table with the physics-dependent numerics filled
    in where the case leaves them out, and the list of what was filled."""
    out = copy.deepcopy(data)
    picks: list[Pick] = []
    _fluid_picks(out, picks)
    _soil_picks(out, picks)
    return out, picks
