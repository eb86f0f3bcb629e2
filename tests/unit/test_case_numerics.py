"""A case file holds physics, geometry, resolution and output only: the numerics come from
the defaults and from the rules of :mod:`fsi_sph.config.numerics`, which follow the physics
the scene declares (issue 26: a new scene works on the defaults)."""

import tomllib
from pathlib import Path

import pytest

from fsi_sph.config import load_config
from fsi_sph.config.numerics import pick_numerics

REPO = Path(__file__).resolve().parents[2]
#: the shipped cases, the validation's own cases and the unseen slopes of the tests
CASES = sorted([*(REPO / "cases").glob("*.toml"), *(REPO / "validation" / "cases").glob("*.toml"),
                *(REPO / "tests" / "data" / "slopes").glob("*.toml")])

#: the keys a case may set, by table; ``*`` a whole sub-table, ``NAME`` any body name
PHYSICAL = {
    "case": "*",
    "fluid": {"material": "*", "blocks": "*", "initial_velocity": "*", "periodic_x": "*",
              "inflow": "*", "outflow": "*"},
    "walls": {"tanks": "*", "boxes": "*"},
    "solid": {"NAME": {"material": "*", "blocks": "*", "clamp": "*", "initial_velocity": "*"}},
    "soil": {"NAME": {"material": "*", "blocks": "*", "initial_stress": "*"}},
    "boundary": "*",
    "coupling": {"structures": "*"},
    "probes": "*",
    "extends": "*",
}


def numerical_keys(table: dict, allowed, prefix: str = "") -> list[str]:
    """Key paths of ``table`` that ``allowed`` does not list."""
    if allowed == "*":
        return []
    found = []
    for key, value in table.items():
        rule = allowed.get(key, allowed.get("NAME"))
        path = f"{prefix}{key}"
        if rule is None:
            found.append(path)
        elif isinstance(value, dict):
            found += numerical_keys(value, rule, path + ".")
    return found


def test_the_checker_finds_a_numerical_key():
    raw = {"case": {"dx": 0.1}, "fluid": {"blocks": [], "cfl": 0.3},
           "soil": {"clay": {"material": {}, "damping": 5.0}}}
    assert numerical_keys(raw, PHYSICAL) == ["fluid.cfl", "soil.clay.damping"]


@pytest.mark.parametrize("case", CASES, ids=[c.stem for c in CASES])
def test_case_sets_no_numerical_key(case):
    raw = tomllib.loads(case.read_text())
    assert numerical_keys(raw, PHYSICAL) == []


GRANULAR = """
[case]
t_end = 0.1
dx = 0.01
[fluid]
blocks = [{ origin = [0.0, 0.0], size = [0.1, 0.1] }]
[fluid.material]
rho0 = 1500.0
viscosity = "mu_i"
mu_i = { mu_s = 0.38, mu_2 = 0.64, I0 = 0.28, d = 0.0005, rho_s = 2500.0, eta_max = 1000.0 }
[walls]
tanks = [{ origin = [0.0, 0.0], size = [0.3, 0.2] }]
"""

WATER = """
[case]
t_end = 0.1
dx = 0.01
[fluid]
material = { rho0 = 1000.0 }
blocks = [{ origin = [0.0, 0.0], size = [0.1, 0.1] }]
[walls]
tanks = [{ origin = [0.0, 0.0], size = [0.3, 0.2] }]
"""

GATE = WATER + """
[solid.gate]
material = { model = "neo_hookean", rho0 = 1100.0, E = 1.0e6, nu = 0.4 }
blocks = [{ origin = [0.15, 0.0], size = [0.01, 0.1] }]
clamp = [{ origin = [0.15, 0.09], size = [0.01, 0.01] }]
[coupling]
structures = ["gate"]
"""


def test_a_granular_material_takes_the_granular_scheme():
    cfg = load_config(None, text=GRANULAR)
    f = cfg.fluid
    assert (f.viscous_step, f.viscous_operator, f.projection, f.position_update) == (
        "implicit", "stress", "incremental", "trapezoid")
    assert (f.density_relaxation, f.density_relaxation_sign, f.relaxation_gap_rows) == (
        0.05, "both", True)
    assert not f.wall_suction and not f.surface_scan and f.collision is not None
    assert f.shifting.model == "fickian_fixed" and not f.shifting.taylor_energy_cap
    picked = {p.key for p in cfg.numerics_picked()}
    assert "fluid.projection" in picked and "fluid.shifting.model" in picked


def test_water_alone_shifts_with_the_fixed_law_and_nothing_else():
    cfg = load_config(None, text=WATER)
    assert cfg.fluid.shifting.model == "fickian_fixed"
    assert cfg.fluid.shifting.coefficient == 0.1
    assert cfg.fluid.collision is None and cfg.fluid.pressure_gradient == "corrected"
    assert [p.key for p in cfg.numerics_picked()] == ["fluid.shifting.model"]


def test_a_coupled_structure_takes_the_coupled_scheme():
    cfg = load_config(None, text=GATE)
    f = cfg.fluid
    assert f.pressure_gradient == "interface_conservative" and f.collision is not None
    assert f.shifting.model == "fickian" and f.shifting.coefficient == 2.0
    assert f.dt_max == 1.0   # the advective step: no time bound for a clamped structure
    free = load_config(None, text=GATE.replace('clamp = [{ origin = [0.15, 0.09], size = [0.01, '
                                               '0.01] }]\n', ""))
    assert free.fluid.dt_max == 1.0
    assert free.fluid.pressure_gradient == "interface_conservative"


def test_the_case_overrides_a_pick_and_can_switch_a_model_off():
    cfg = load_config(None, text=GATE, overrides=["fluid.dt_max=1e-3", "fluid.collision=false",
                                                   "fluid.shifting.coefficient=1.5"])
    f = cfg.fluid
    assert f.dt_max == 1e-3 and f.collision is None
    assert f.shifting.model == "fickian" and f.shifting.coefficient == 1.5
    assert load_config(None, text=WATER, overrides=["fluid.shifting=false"]).fluid.shifting is None
    law = load_config(None, text=WATER, overrides=["fluid.shifting.model=fickian"])
    assert law.fluid.shifting.coefficient == 2.0   # the coefficient follows the law chosen


def test_a_cohesive_soil_takes_artificial_stress():
    raw = {"soil": {"clay": {"material": {"cohesion": 1e4}}, "sand": {"material": {}}}}
    out, picks = pick_numerics(raw)
    assert out["soil"]["clay"]["artificial_stress"] == {}
    assert "artificial_stress" not in out["soil"]["sand"]
    assert [p.key for p in picks] == ["soil.clay.artificial_stress"]
    assert "artificial_stress" not in raw["soil"]["clay"]   # the input is not changed


def test_the_stored_config_reloads_to_itself():
    """A run file stores the resolved config: loading it again picks nothing more."""
    import json
    cfg = load_config(None, text=GRANULAR)
    out, picks = pick_numerics(json.loads(cfg.model_dump_json()))
    assert picks == []


def test_a_clamped_structure_in_a_through_flow_takes_both_picks():
    inflow = ("[[fluid.inflow]]\nx = 0.0\ny_range = [0.0, 0.1]\n"
              "velocity = { profile = \"uniform\", mean = 0.1 }\n")
    text = GATE.replace("[walls]", inflow + "[walls]", 1)
    f = load_config(None, text=text).fluid
    assert f.density_relaxation == 0.05 and f.relaxation_gap_rows
    assert f.pressure_gradient == "interface_conservative" and f.dt_max == 1.0
    assert f.shifting.model == "fickian"
