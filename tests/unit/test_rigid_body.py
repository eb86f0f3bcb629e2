"""Rigid bodies (``[solid.NAME] material = { model = "rigid", rho0 }``): moved as a whole by
their weight and the held external force (the fluid's), never deformed; the config takes
them only free and coupled."""

import math

import numpy as np
import pytest

from fsi_sph.config import load_config
from fsi_sph.errors import ConfigError
from fsi_sph.solid.tlsph import ElasticBody

CASE = """
[case]
t_end = 0.1
dx = 0.01
gravity = [0.0, -9.81]
[fluid]
material = { rho0 = 1000.0 }
blocks = [{ origin = [0.0, 0.0], size = [0.3, 0.2] }]
pressure_gradient = "interface_conservative"
[walls]
tanks = [{ origin = [0.0, 0.0], size = [0.3, 0.4] }]
[solid.box]
material = { model = "rigid", rho0 = 500.0 }
blocks = [{ origin = [0.1, 0.15], size = [0.1, 0.06] }]
[coupling]
structures = ["box"]
"""


def _body(gravity=(0.0, 0.0)):
    cfg = load_config(None, text=CASE)
    return ElasticBody("box", cfg.solid["box"], cfg.case.dx, cfg.sph, gravity)


def _centre(b):
    m, x = b.body["m"], b.body["x"]
    return m @ x / m.sum(), x - m @ x / m.sum()


def test_config_of_a_rigid_body():
    cfg = load_config(None, text=CASE)
    assert cfg.structure_scheme() == "rigid"
    assert "rigid_body:box" in cfg.modules()
    for text, match in (
            (CASE.replace('rho0 = 500.0 }', 'rho0 = 500.0, E = 1.0e7 }'), "takes no E"),
            (CASE.replace('model = "rigid", ', 'model = "stvk", '), "needs E and nu"),
            (CASE.replace("[coupling]", 'clamp = [{ origin = [0.1, 0.15], size = [0.1, 0.01] }]'
                          "\n[coupling]"), "cannot be clamped"),
            (CASE.replace('[coupling]\nstructures = ["box"]\n', ""), "list it in coupling")):
        with pytest.raises(ConfigError, match=match):
            load_config(None, text=text)


def test_rigid_step_under_a_couple_rotates_without_deforming():
    b = _body()
    xc, r = _centre(b)
    m = b.body["m"]
    inertia = float(m @ np.einsum("ij,ij->i", r, r))
    f = np.column_stack([-r[:, 1], r[:, 0]]) * m[:, None]  # no net force
    torque = float(np.sum(r[:, 0] * f[:, 1] - r[:, 1] * f[:, 0]))
    b.body["f_ext"][:] = f
    d0 = np.linalg.norm(b.body["x"][:, None] - b.body["x"][None], axis=2)
    dt = 1e-3
    b.substep(dt)
    xc1, r1 = _centre(b)
    v = b.body["v"]
    omega = float(m @ (r1[:, 0] * v[:, 1] - r1[:, 1] * v[:, 0])) / inertia
    assert math.isclose(omega, dt * torque / inertia, rel_tol=1e-12)
    np.testing.assert_allclose(xc1, xc, atol=1e-15)
    d1 = np.linalg.norm(b.body["x"][:, None] - b.body["x"][None], axis=2)
    np.testing.assert_allclose(d1, d0, atol=1e-14)
    # the rotation by dt omega about the centre: the body's rotation angle, from every
    # particle at once (sum m r x r1 against sum m r . r1). The angle is 1e-6 rad; read from
    # one particle as a difference of two atan2 it carried the positions' rounding, about
    # 1e-9 of it, and passed or failed with the summation order
    cross = float(m @ (r[:, 0] * r1[:, 1] - r[:, 1] * r1[:, 0]))
    dot = float(m @ np.einsum("ij,ij->i", r, r1))
    assert math.isclose(math.atan2(cross, dot), dt * omega, rel_tol=1e-9)
    assert b.stable_dt() == math.inf and b.strain_energy() == 0.0


def test_rigid_step_under_its_weight_and_a_force_translates():
    g = np.array([0.0, -9.81])
    b = _body(gravity=g)
    xc, _ = _centre(b)
    force = np.array([3.0, 40.0])  # N/m in total, spread evenly
    b.body["f_ext"][:] = force / b.body.n
    mass = b.body["m"].sum()
    dt, n = 1e-3, 10
    for _ in range(n):
        b.substep(dt)
    acc = force / mass + g
    np.testing.assert_allclose(b.body["v"], np.tile(n * dt * acc, (b.body.n, 1)), atol=1e-13)
    # semi-implicit Euler: x_n = x_0 + dt^2 a n (n + 1) / 2
    np.testing.assert_allclose(_centre(b)[0], xc + dt * dt * acc * n * (n + 1) / 2, atol=1e-13)
