"""Coulomb wall friction of the soil against the sliding-block answer.

A strip of cohesionless soil one particle thick, and a single particle (the front of a
granular run-out and the particles thrown ahead of it), is launched along a floor with
friction angle delta. The soil's internal forces are pair-wise antisymmetric, so only the
floor changes the horizontal momentum: with the floor's normal impulse equal to the weight on
average, the centre of mass stops after ``v0^2 / (2 g tan delta)`` at ``t = v0 / (g tan
delta)`` (Coulomb's sliding block). On a free-slip floor it keeps its speed.
"""

import math

import numpy as np
import pytest

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation

DX = 0.005
V0 = 0.5
G = 9.81

CASE = """
[case]
t_end = {t_end}
dx = 0.005
gravity = [0.0, -9.81]
[soil.strip]
material = {{ model = "drucker_prager", rho0 = 2000.0, E = 5.0e6, nu = 0.3, friction_angle_deg = 20.0, cohesion = 0.0 }}
blocks = [{{ origin = [0.0, 0.0], size = [{length}, 0.005] }}]
[boundary]
walls = [{wall}]
[guard]
domain = {{ origin = [-1.0, -1.0], size = [3.0, 2.0] }}
"""


def run(wall, t_end, length=0.05):
    text = CASE.format(t_end=t_end, wall=wall, length=length)
    sim = Simulation(load_config(None, text=text))
    body = sim.structures["strip"]
    b = body.body
    b["v"][:, 0] = V0
    xc0 = float(b["x"][:, 0].mean())
    sim.run(out_dir=None, progress=False)
    return float(b["x"][:, 0].mean()) - xc0, b


@pytest.mark.parametrize("delta,length", [(15.0, 0.05), (30.0, 0.05), (20.0, DX)])
def test_strip_stops_at_the_sliding_block_distance(delta, length):
    mu = math.tan(math.radians(delta))
    t_stop = V0 / (mu * G)
    wall = (f'{{ side = "bottom", position = 0.0, friction = "coulomb", '
            f'friction_angle_deg = {delta} }}')
    dist, b = run(wall, 1.5 * t_stop, length)
    ref = V0**2 / (2.0 * mu * G)
    assert dist == pytest.approx(ref, rel=0.03)
    assert np.abs(b["v"]).max() < 1e-3 * V0  # at rest
    assert b["x"][:, 1].min() > 0.0  # never below the floor


def test_strip_keeps_sliding_on_a_free_slip_floor():
    t = 0.1
    dist, b = run('{ side = "bottom", position = 0.0, friction = "free_slip" }', t)
    assert dist == pytest.approx(V0 * t, rel=0.01)



def test_particle_lying_on_the_wall_line_keeps_its_friction():
    """A particle on the floor line (y = 1e-3 dx, where the wall guard puts a particle that
    crossed it): its own mirror ghost coincides with it (grad W(0) = 0), so the ghosts'
    contact force vanishes and only the guard's clamp holds it up; the clamp's normal impulse
    must bring Coulomb friction too. Before: it slid 0.15 m in 0.3 s at 0.49 m/s."""
    delta = 20.0
    mu = math.tan(math.radians(delta))
    wall = (f'{{ side = "bottom", position = 0.0, friction = "coulomb", '
            f'friction_angle_deg = {delta} }}')
    text = CASE.format(t_end=1.5 * V0 / (mu * G), wall=wall, length=DX)
    sim = Simulation(load_config(None, text=text))
    b = sim.structures["strip"].body
    b["x"][:, 1] = 1e-3 * DX
    b["v"][:, 0] = V0
    x0 = float(b["x"][0, 0])
    sim.run(out_dir=None, progress=False)
    assert float(b["x"][0, 0]) - x0 == pytest.approx(V0**2 / (2.0 * mu * G), rel=0.03)
    assert abs(b["v"][0, 0]) < 1e-3 * V0
    assert b["x"][0, 1] > 0.0
