"""Rigid body against fixed walls (fsi_sph/solid/contact.py): after the contact impulses no
contact point approaches its wall, a sliding body keeps its tangential velocity
(frictionless), momentum goes only into the walls' normal direction, and a body landing on
one corner starts to turn the way the impulse's lever arm says."""

import numpy as np
import pytest

from fsi_sph.geometry import fill_rectangle
from fsi_sph.solid.contact import WallContact

DX = 0.01
FLOOR = fill_rectangle((-0.5, -0.03), (1.0, 0.03), DX)   # wall particles below y = 0


def body(origin, size):
    x = fill_rectangle(origin, size, DX)
    m = np.full(len(x), 1.0)
    xc = x.mean(axis=0)
    r = x - xc
    return x, xc, float(m.sum()), float(np.einsum("ij,ij->", r, r))


def point_velocities(x, xc, vc, omega):
    r = x - xc
    return vc + omega * np.column_stack([-r[:, 1], r[:, 0]])


def test_a_falling_sliding_block_stops_falling_and_keeps_sliding():
    x, xc, mass, inertia = body((0.0, 0.0), (0.1, 0.05))
    walls = WallContact(FLOOR, DX)
    vc, omega = walls.resolve(x, xc, np.array([0.3, -1.0]), 0.0, mass, inertia)
    touching, normals = walls.contacts(x)
    assert len(touching) > 0
    vn = np.einsum("ij,ij->i", point_velocities(x, xc, vc, omega)[touching], normals)
    assert vn.min() > -1e-9
    assert vc[0] == pytest.approx(0.3, abs=1e-9)   # no friction
    assert abs(omega) < 1e-9 and abs(vc[1]) < 1e-9


def test_a_block_away_from_the_walls_is_untouched():
    x, xc, mass, inertia = body((0.0, 0.05), (0.1, 0.05))
    vc, omega = WallContact(FLOOR, DX).resolve(x, xc, np.array([0.0, -1.0]), 0.5, mass,
                                               inertia)
    assert np.array_equal(vc, [0.0, -1.0]) and omega == 0.5


def test_landing_on_a_corner_turns_the_body():
    # tilted block: only its lowest corner touches; falling, it must rotate so that the
    # centre keeps falling while the corner stops
    x, xc, mass, inertia = body((0.0, 0.0), (0.1, 0.05))
    a = np.radians(20.0)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    x = (x - xc) @ rot.T + xc
    x[:, 1] -= x[:, 1].min() - 0.5 * DX    # lowest particle half a spacing above the floor
    xc = x.mean(axis=0)
    walls = WallContact(FLOOR, DX)
    vc, omega = walls.resolve(x, xc, np.array([0.0, -1.0]), 0.0, mass, inertia)
    touching, normals = walls.contacts(x)
    assert 0 < len(touching) < 5
    corner_x = x[touching, 0].mean()
    assert vc[1] < 0.0                            # the centre still falls ...
    # the upward impulse at a corner left of the centre turns the body clockwise
    assert abs(omega) > 0.1 and np.sign(omega) == np.sign(corner_x - xc[0])
    vn = np.einsum("ij,ij->i", point_velocities(x, xc, vc, omega)[touching], normals)
    assert vn.min() > -1e-9                       # ... while the corner does not
