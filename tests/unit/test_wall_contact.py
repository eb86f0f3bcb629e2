"""``fluid.wall_contact = "inelastic"`` (fsi_sph/fluid/kinematic_guard.py
``KinematicGuard.inelastic_contact``): a particle in the guard's band (dx/2 from a wall) or reaching it within the step loses its
velocity into the wall before the pressure solve.

A water block at rest on the floor, one particle of its bottom row driven down at 4 m/s
(its step reaches the band). With the contact left to the projection (``"projection"``,
the default) the solve has to take its motion out of the divergence: a suction of
-8.5 kPa (hydrostatic +0.15 kPa) that pulls its neighbours after it (0.22 m/s; the guard
then stops it at the band's edge). With the inelastic contact its approach is removed
before the solve: no kick, the pressure stays about hydrostatic. Such impulsive pressures
(5-10 kPa at a granular front, hydrostatic 0.1-0.2 kPa) threw front particles of the
granular collapse ahead (docs/numerics/fluid.md, "Wall contact").
"""

import numpy as np
import pytest

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation

DX, RHO, G = 0.005, 1000.0, 9.81


def _scene(contact, t_end):
    return f"""
[case]
t_end = {t_end}
dx = {DX}
gravity = [0.0, -{G}]
[fluid]
blocks = [{{ origin = [0.0, 0.0], size = [{10 * DX}, {4 * DX}] }}]
dt_max = 1.0e-3
density_relaxation = 0.0  # the contact rule alone (the relaxation stirs still water slightly)
wall_contact = "{contact}"
[fluid.material]
rho0 = {RHO}
nu = 1.0e-6
[walls]
layers = 3
tanks = [{{ origin = [0.0, 0.0], size = [{10 * DX}, {8 * DX}] }}]
"""


def _driven_step(contact):
    """Three steps at rest, then one bottom-row particle put 0.2 dx over the floor's band
    edge (0.7 dx over the walls' top row) moving down at 4 m/s, and one step."""
    sim = Simulation(load_config(None, text=_scene(contact, 1.0)))
    for _ in range(3):
        sim.step(1.0)
    b = sim.fluid.body
    x = b["x"]
    k = int(np.argmin(np.abs(x[:, 0] - 5.5 * DX) + np.abs(x[:, 1] - 0.5 * DX)))
    x[k, 1] = 0.2 * DX
    b["v"][k] = (0.0, -4.0)
    sim.step(1.0)
    others = np.arange(len(x)) != k
    return b["p"].max(), np.abs(b["v"][others]).max(), b["v"][k].copy(), x[k].copy()


def test_projection_lets_the_driven_particle_kick_its_neighbours():
    _, kick, v_k, x_k = _driven_step("projection")
    assert kick > 0.05  # m/s, its neighbours pushed aside (measured 0.22)
    assert x_k[1] >= -1e-12  # the guard still keeps it out of the band


def test_inelastic_contact_stops_it_before_the_solve():
    p_max, kick, v_k, x_k = _driven_step("inelastic")
    assert kick < 0.01  # (measured 3e-4)
    assert np.abs(v_k).max() < 0.05  # stopped (it moved 0.12 dx at its old velocity)
    assert x_k[1] >= -1e-12
    assert p_max < 1.5 * RHO * G * 4 * DX  # no impulsive pressure: about hydrostatic


@pytest.mark.parametrize("contact", ["projection", "inelastic"])
def test_block_at_rest_is_unchanged_by_the_contact_rule(contact):
    """Nothing approaches the wall: the block stays at rest with either rule."""
    sim = Simulation(load_config(None, text=_scene(contact, 0.05)))
    sim.run(out_dir=None)
    assert sim.fluid.max_speed() < 1e-6
