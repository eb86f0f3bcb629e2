"""A thin sheet of water sliding along the floor keeps its speed (no particle thrown).

Three particle rows at 2 m/s on a free-slip floor: gravity spreading can speed the front up
by at most about 2 sqrt(g h0) (shallow-water dam-break front), 0.27 m/s here. Before the
shifting's Taylor correction took the walls as free-slip, the zero wall velocity put a shear
of U / dx into the velocity gradient and every shift off the floor added speed: particles
left at 3.7 m/s after 0.06 s and at 9 m/s after 0.13 s (measured).
"""

import math

import numpy as np

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation

SHEET = """
[case]
t_end = 0.08
dx = 0.0025
gravity = [0.0, -9.81]
[fluid]
material = { rho0 = 1000.0, nu = 1.0e-6 }
blocks = [{ origin = [0.01, 0.0], size = [0.1, 0.0075] }]
cfl = 0.2
dt_max = 2.0e-4
initial_velocity = [2.0, 0.0]
[fluid.shifting]
model = "fickian"
[walls]
layers = 3
tanks = [{ origin = [0.0, 0.0], size = [0.4, 0.1] }]
"""


def test_thin_sheet_on_floor_throws_no_particle():
    sim = Simulation(load_config(None, text=SHEET))
    bound = 2.0 + 2.0 * math.sqrt(9.81 * 0.0075)
    top = 0.0
    while sim.t < 0.08 - 1e-12:
        sim.step()
        top = max(top, float(np.hypot(*sim.fluid.body["v"].T).max()))
    sim.check()
    assert top < bound, f"fastest particle {top:.2f} m/s, bound {bound:.2f} m/s"
    # and nobody climbed off the sheet
    assert sim.fluid.body["x"][:, 1].max() < 0.0075 + 0.005
