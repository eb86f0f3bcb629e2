"""The elastic body's sub-steps in one numba call (``ElasticBody.substeps``) are its
``substep`` loop bit for bit, with a held external force, damping and gravity."""

import numpy as np
import pytest

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation

CASE = """
[case]
t_end = 0.01
dx = 0.01
gravity = [0.0, -9.81]
[solid.bar]
material = { rho0 = 1000.0, E = 1e6, nu = 0.3 }
blocks = [{ origin = [0.0, 0.0], size = [0.2, 0.04] }]
clamp = [{ origin = [0.0, 0.0], size = [0.03, 0.04] }]
damping = 2.0
initial_velocity = { profile = "cantilever_mode", root_x = 0.03, length = 0.17, tip_speed = 0.5 }
"""


@pytest.mark.parametrize("hourglass", ["ganzenmueller", "conservative"])
def test_substeps_in_one_call_are_the_substep_loop(tmp_path, hourglass):
    case = tmp_path / "bar.toml"
    case.write_text(CASE)
    over = [f'solid.bar.hourglass={{model="{hourglass}",coefficient=0.1}}']
    bodies = [Simulation(load_config(case, over)).structures["bar"] for _ in range(2)]
    rng = np.random.default_rng(1)
    f_ext = rng.normal(size=(bodies[0].body.n, 2)) * 1e-3
    for b in bodies:
        b.body["f_ext"][:] = f_ext
    dt = 0.5 * bodies[0].stable_dt()
    for _ in range(40):
        bodies[0].substep(dt)
    bodies[1].substeps(dt, 40)
    for name in ("x", "v", "a", "F", "P"):
        np.testing.assert_array_equal(bodies[0].body[name], bodies[1].body[name], err_msg=name)
    assert np.abs(bodies[0].body["v"]).max() > 0.1  # it moved
