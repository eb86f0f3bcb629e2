"""A shaken frame (case.shaking, fsi_sph/frame.py): the body force g - X''(t), and a free
block in the shaken frame without gravity, which stays in uniform motion in the inertial
frame: in the frame's coordinates x(t) = x0 + A omega t d - X(t)."""

import math

import numpy as np
import pytest

from fsi_sph.config import load_config
from fsi_sph.errors import ConfigError
from fsi_sph.frame import ShakenFrame
from fsi_sph.simulation import Simulation

SCENE = """
[case]
t_end = 0.2
dx = 0.01
gravity = [0.0, 0.0]
shaking = { amplitude = 0.01, frequency = 2.0 }
[solid.block]
material = { model = "neo_hookean", rho0 = 1000.0, E = 1.0e6, nu = 0.3 }
blocks = [{ origin = [0.0, 0.0], size = [0.1, 0.05] }]
"""


def test_body_force_is_gravity_minus_the_frame_acceleration():
    cfg = load_config(None, text=SCENE, overrides=["case.shaking.direction=[0.0, 2.0]"])
    frame = ShakenFrame(cfg.case.shaking, (0.0, -9.81))
    t, h = 0.1, 1e-4
    accel = (frame.displacement(t + h) - 2 * frame.displacement(t)
             + frame.displacement(t - h)) / h ** 2
    np.testing.assert_allclose(frame.body_force(t), np.array([0.0, -9.81]) - accel,
                               rtol=1e-5)
    assert frame.displacement(0.125)[1] == pytest.approx(0.01)   # a quarter period, along d


def test_a_free_block_moves_as_the_frame_says():
    sim = Simulation(load_config(None, text=SCENE))
    b = sim.structures["block"].body
    x0 = b["x"][:, 0].mean()
    while sim.t < 0.2 - 1e-12:
        sim.step(dt_max=0.2 - sim.t, to_end=True)
    a, w, t = 0.01, 2 * math.pi * 2.0, sim.t
    expected = a * w * t - a * math.sin(w * t)
    assert b["x"][:, 0].mean() - x0 == pytest.approx(expected, rel=1e-3)


def test_shaking_a_periodic_fluid_is_refused():
    text = SCENE + """
[fluid]
material = { rho0 = 1000.0 }
blocks = [{ origin = [0.2, 0.0], size = [0.1, 0.1] }]
periodic_x = [0.2, 0.3]
[walls]
boxes = [{ origin = [0.2, -0.03], size = [0.1, 0.03] }]
"""
    with pytest.raises(ConfigError, match="case.shaking with fluid.periodic_x"):
        load_config(None, text=text)
