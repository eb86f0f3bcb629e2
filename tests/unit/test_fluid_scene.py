"""Only what a scene needs is built: a fluid scene builds nothing solid, a solid scene never
builds or solves a PPE; config strictness of the new tables; output of PPE statistics."""

import json
import sys

import h5py
import pytest

from fsi_sph.config import load_config
from fsi_sph.errors import ConfigError
from fsi_sph.simulation import Simulation

FLUID = """
[case]
t_end = 0.02
dx = 0.05
[fluid]
material = { rho0 = 1000.0 }
blocks = [{ origin = [0.0, 0.0], size = [0.5, 0.5] }]
[walls]
tanks = [{ origin = [0.0, 0.0], size = [0.5, 0.6] }]
[[probes]]
name = "bottom"
kind = "pressure"
body = "fluid"
at = [0.25, 0.0]
"""

SOLID = """
[case]
t_end = 1e-4
dx = 0.01
[solid.bar]
material = { rho0 = 1000.0, E = 1e6, nu = 0.3 }
blocks = [{ origin = [0.0, 0.0], size = [0.1, 0.02] }]
"""


def test_fluid_scene_builds_nothing_solid(tmp_path):
    sim = Simulation(load_config(None, text=FLUID))
    assert sim.structures == {}
    assert sim.fluid is not None and sim.fluid.walls is not None
    s = sim.run(out_dir=tmp_path, progress=False)
    assert s["status"] == "completed"
    assert sim.timings["ppe"] > 0.0
    assert "solid" not in sim.timings
    with h5py.File(tmp_path / "run.h5", "r") as f:
        assert set(f["bodies"]) == {"fluid", "walls"}
        cols = json.loads(f["steps"].attrs["columns"])
        assert cols[:5] == ["t", "dt", "n_sub", "ppe_iterations", "ppe_residual"]
        steps = f["steps"][()]
        assert steps.shape[0] == s["steps"]
        assert (steps[:, cols.index("ppe_iterations")] >= 0).all()
        assert (steps[:, cols.index("ppe_residual")] <= 1e-6).all()
        assert f["timing"].attrs["ppe_s"] > 0
        assert "probes/bottom" in f


def test_solid_scene_never_builds_a_ppe(tmp_path):
    sys.modules.pop("fsi_sph.fluid.isph", None)
    sys.modules.pop("fsi_sph.fluid.ppe", None)
    sim = Simulation(load_config(None, text=SOLID))
    assert sim.fluid is None
    sim.run(out_dir=tmp_path, progress=False)
    assert "ppe" not in sim.timings and "neighbours" not in sim.timings
    assert "fsi_sph.fluid.ppe" not in sys.modules  # the PPE code is never even imported
    with h5py.File(tmp_path / "run.h5", "r") as f:
        assert json.loads(f["steps"].attrs["columns"]) == ["t", "dt", "n_sub"]
        assert set(f["bodies"]) == {"bar"}


@pytest.mark.parametrize("text, message", [
    (FLUID.replace("rho0 = 1000.0", "rho0 = 1000.0, mu = 1.0"), "fluid.material.mu: unknown"),
    (FLUID + "[fluid.ppe]\nrtol = 2.0\n", "fluid.ppe.rtol"),
    (FLUID + "[fluid.shifting]\nmodel = \"magic\"\n", "fluid.shifting.model"),
    (FLUID.replace('tanks = [{ origin = [0.0, 0.0], size = [0.5, 0.6] }]', ''),
     "needs at least one of"),
    (SOLID + "[walls]\nboxes = [{ origin = [0.0, 0.0], size = [0.1, 0.1] }]\n",
     "[walls] without [fluid]"),
    (SOLID + '[[probes]]\nname = "f"\nkind = "surge_front"\nbody = "bar"\n',
     "does not apply"),
])
def test_fluid_config_errors_name_the_key(text, message):
    with pytest.raises(ConfigError, match=message.replace("[", r"\[").replace("]", r"\]")):
        load_config(None, text=text)


def test_modules_listed():
    cfg = load_config(None, text=FLUID + "[fluid.shifting]\n[fluid.smagorinsky]\n")
    assert cfg.modules() == ["isph_fluid", "walls", "shifting:fickian_fixed", "smagorinsky"]


def test_smagorinsky_and_shifting_run():
    cfg = load_config(None, text=FLUID + "[fluid.shifting]\n[fluid.smagorinsky]\n")
    sim = Simulation(cfg)
    for _ in range(3):
        sim.step()
    sim.check()
    assert sim.timings["shift"] > 0


def test_last_step_is_not_a_sliver(tmp_path):
    """A run whose end is 0.1 dt past a whole number of steps ends with two half steps
    (1.05 dt in all), not with a step of 0.1 dt (fsi_sph/simulation.py, ``to_end``)."""
    text = FLUID.replace("t_end = 0.02", "t_end = 0.0041") + "\n[fluid.ppe]\n"
    text = text.replace("[walls]", "dt_max = 1.0e-3\n[walls]")
    sim = Simulation(load_config(None, text=text))
    sim.run(out_dir=tmp_path, progress=False)
    with h5py.File(tmp_path / "run.h5", "r") as f:
        dt = f["steps"][()][:, 1]
    assert dt[:3] == pytest.approx([1e-3] * 3, rel=1e-12)
    assert dt[3:] == pytest.approx([0.55e-3, 0.55e-3], rel=1e-9)
    assert sim.t == pytest.approx(0.0041, rel=1e-12)


def _initial_positions(tmp_path, extra):
    path = tmp_path / "jit.toml"
    path.write_text(FLUID.replace("[fluid]\n", "[fluid]\n" + extra))
    return Simulation(load_config(path)).fluid.body["x"].copy()


def test_jitter_moves_each_particle_within_its_bound_and_is_seeded(tmp_path):
    """``fluid.jitter``: every initial particle within jitter * dx of its lattice site per
    component, the same field for the same seed, another for another seed."""
    lattice = _initial_positions(tmp_path, "")
    a = _initial_positions(tmp_path, "jitter = 0.05\njitter_seed = 3\n")
    b = _initial_positions(tmp_path, "jitter = 0.05\njitter_seed = 3\n")
    c = _initial_positions(tmp_path, "jitter = 0.05\njitter_seed = 4\n")
    d = a - lattice
    assert a.shape == lattice.shape
    assert abs(d).max() <= 0.05 * 0.05 and abs(d).max() > 0.04 * 0.05
    assert (a == b).all() and not (a == c).all()
