"""The point_displacement probe (fsi_sph/probes.py): a material point between particles is
carried by the nearest particles' deformation gradient [F 36], exact for an affine motion of
a TLSPH body; a point on a particle is that particle; a body without a deformation gradient
(soil) gives its nearest particle as before."""

import numpy as np

from fsi_sph.config import load_config
from fsi_sph.particles import Body
from fsi_sph.probes import PointDisplacement
from fsi_sph.simulation import Simulation

A = np.array([[0.96, -0.28], [0.31, 1.02]])   # a rotation by about 0.3 rad with a stretch
B = np.array([0.013, -0.021])


class Holder:
    def __init__(self, body):
        self.body = body


def flag(dx=0.01):
    """The Turek-Hron flag as the case builds it (clamped root, TLSPH)."""
    sim = Simulation(load_config("cases/turek_hron_fsi2.toml", [f"case.dx={dx}"]))
    return sim.structures["flag"]


def move_affinely(body):
    b = body.body
    b["x"] = b["x0"] @ A.T + B
    body.update_stress()   # F from the corrected kernel gradients [F 36]


def test_point_a_between_particles_follows_an_affine_motion_exactly():
    body = flag()
    move_affinely(body)
    probe = PointDisplacement("tip", body, (0.6, 0.2))
    assert len(probe.indices) == 2          # (0.595, 0.195) and (0.595, 0.205), half a spacing off
    ux, uy, x, y = probe.sample()
    want = A @ np.array([0.6, 0.2]) + B
    np.testing.assert_allclose([x, y], want, atol=1e-12)
    np.testing.assert_allclose([ux, uy], want - [0.6, 0.2], atol=1e-12)
    # the nearest particle alone (the probe before) is off by its offset turned with the body
    p = body.body["x"][probe.indices[0]]
    assert np.hypot(*(p - want)) > 0.005


def test_a_point_on_a_particle_is_that_particle():
    body = flag()
    move_affinely(body)
    x0 = body.body["x0"]
    k = int(np.argmin(np.hypot(x0[:, 0] - 0.455, x0[:, 1] - 0.195)))
    probe = PointDisplacement("p", body, tuple(x0[k]))
    assert not probe.carried and list(probe.indices) == [k]
    ux, uy, x, y = probe.sample()
    np.testing.assert_array_equal([x, y], body.body["x"][k])
    np.testing.assert_array_equal([ux, uy], body.body["x"][k] - x0[k])


def test_a_body_without_deformation_gradient_gives_its_nearest_particle():
    body = Body("soil", "soil", 3)
    body["x0"] = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    body["x"] = body["x0"] + [[0.1, 0.2], [0.3, 0.4], [0.5, 0.6]]
    probe = PointDisplacement("toe", Holder(body), (0.9, 0.1))
    assert not probe.carried
    np.testing.assert_allclose(probe.sample(), [0.3, 0.4, 1.3, 0.4])


def test_a_point_of_a_rigid_body_turns_with_it():
    """A rigid body keeps F = I: the point is carried by the body's rotation instead."""
    body = Body("box", "solid", 4)
    body["x0"] = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    body["F"] = np.tile(np.eye(2), (4, 1, 1))
    t = 0.4
    R = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    body["x"] = body["x0"] @ R.T + [2.0, 3.0]
    holder = Holder(body)
    holder.rigid = True
    probe = PointDisplacement("corner", holder, (1.2, 1.1))
    ux, uy, x, y = probe.sample()
    np.testing.assert_allclose([x, y], R @ [1.2, 1.1] + [2.0, 3.0], atol=1e-12)
