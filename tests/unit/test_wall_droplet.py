"""A droplet beside a vertical wall falls (``fluid.wall_pressure``, fsi_sph/fluid/boundary.py
``BoundaryRows.wall_body_force``).

A single water particle half a spacing from a vertical tank wall, far above the floor,
falls freely (the water's viscosity is negligible over 0.05 s). With Adami's wall pressure
``p_w = <p_f> + rho g . (x_w - <x_f>)`` (``wall_pressure = "adami"``) it does not: the
hydrostatic term gives the walls beside and below it a pressure growing downwards, which
the corrected pressure gradient reproduces exactly, and the droplet is held as if it stood
in a column of water (speed 0 after 0.05 s). ``"mirror"`` keeps the term along the wall
only as far as the fluid's own pressure gradient carries it (none for a droplet), and a
tank at rest stays at rest to round-off as with Adami's. (``"mirror"`` is the default; docs/numerics/fluid.md, "Wall pressure".)"""

import math

import numpy as np
import pytest

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation

DX = 0.005


def _run(block, tank, t_end, wall_pressure, suction=True, dx=DX):
    """A water block ``(origin, size)`` in an open tank of inner size ``tank``, run to
    ``t_end``."""
    (ox, oy), (sx, sy) = block
    text = f"""
[case]
t_end = {t_end}
dx = {dx}
gravity = [0.0, -9.81]
[fluid]
blocks = [{{ origin = [{ox}, {oy}], size = [{sx}, {sy}] }}]
dt_max = 1.0e-3
density_relaxation = 0.0  # the wall rows alone (the relaxation stirs still water slightly)
wall_pressure = "{wall_pressure}"
wall_suction = {str(suction).lower()}
[fluid.material]
rho0 = 1000.0
nu = 1.0e-6
[walls]
layers = 3
tanks = [{{ origin = [0.0, 0.0], size = [{tank[0]}, {tank[1]}] }}]
"""
    sim = Simulation(load_config(None, text=text))
    sim.run(out_dir=None)
    return sim


def _droplet(x0, wall_pressure, suction=True):
    return _run(((x0 - 0.5 * DX, 0.3), (DX, DX)), (0.2, 0.5), 0.05, wall_pressure, suction)


def test_droplet_away_from_the_wall_falls_freely():
    sim = _droplet(3.5 * DX, "mirror")
    assert np.isclose(sim.fluid.body["v"][0, 1], -9.81 * sim.t, rtol=1e-3)


@pytest.mark.parametrize("suction", [True, False])
def test_droplet_on_a_vertical_wall_falls(suction):
    # (the first step, before any pressure is known, still uses Adami's term: 0.96 g t)
    sim = _droplet(0.5 * DX, "mirror", suction)
    assert sim.fluid.body["v"][0, 1] < -0.9 * 9.81 * sim.t


def test_adami_walls_hold_the_droplet():
    sim = _droplet(0.5 * DX, "adami")
    assert abs(sim.fluid.body["v"][0, 1]) < 0.01 * 9.81 * sim.t


@pytest.mark.parametrize("wall_pressure", ["adami", "mirror"])
def test_tank_at_rest_stays_at_rest(wall_pressure):
    sim = _run(((0.0, 0.0), (1.0, 1.0)), (1.0, 1.2), 0.5, wall_pressure, dx=0.04)
    assert sim.fluid.max_speed() < 1e-6 * math.sqrt(9.81 * 1.0)
