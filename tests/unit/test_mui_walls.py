"""No-slip walls of the implicit viscous step for the mu(I) law (fsi_sph/fluid/viscous.py):
the walls are mirrored about their predicted intermediate velocity u_w + dt grad p^n / rho
(Kim & Moin 1985; the fluid's corrected pressure gradient over fluid neighbours, averaged
at the wall), so a granular column at rest beside a vertical wall stays at rest with a
hydrostatic pressure. Mirrored about the normal part of gravity only (the former choice),
the side wall dragged the gravity increment of the fluid beside it every step and the
projection pushed that fluid up the wall (measured: 0.012 m/s after 0.1 s, pressure 0.90
of hydrostatic)."""

import numpy as np
import pytest

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation

COLUMN = """
[case]
t_end = 1.0
dx = 0.001
gravity = [0.0, -9.81]
[fluid]
blocks = [{ origin = [0.0, 0.0], size = [0.016, 0.012] }]
viscous_step = "implicit"
viscous_operator = "OPERATOR"
[fluid.material]
rho0 = 1500.0
viscosity = "mu_i"
mu_i = { mu_s = 0.382, mu_2 = 0.643, I0 = 0.279, d = 0.0005, rho_s = 2500.0, eta_max = 1000.0 }
[walls]
tanks = [{ origin = [0.0, 0.0], size = [0.016, 0.02] }]
"""


def _column(operator="morris", steps=40):
    sim = Simulation(load_config(None, text=COLUMN.replace("OPERATOR", operator)))
    for _ in range(steps):
        sim.step()
    return sim


@pytest.mark.parametrize("operator", ["morris", "stress"])
def test_granular_column_beside_a_side_wall_stays_at_rest_with_hydrostatic_pressure(operator):
    sim = _column(operator)
    f = sim.fluid
    x, v, p = f.body["x"], f.body["v"], f.body["p"]
    assert sim.t > 0.1
    assert np.sqrt((v ** 2).sum(axis=1).mean()) < 5e-4
    side = x[:, 0] < 0.001  # the column of particles beside the left wall
    assert abs(v[side, 1].mean()) < 1e-3
    # the surface particles' centres carry p = 0 (half a spacing below the real surface)
    ph = 1500.0 * 9.81 * (0.012 - 0.0005 - x[:, 1])
    deep = x[:, 1] < 0.008
    assert np.mean(p[side & deep] / ph[side & deep]) == pytest.approx(1.0, abs=0.03)


def test_wall_pressure_acceleration_of_a_column_at_rest_is_gravity():
    """At rest grad p / rho = g in the fluid, and its Shepard average at the walls with
    fluid neighbours too (floor and side walls alike)."""
    sim = _column(steps=10)
    f = sim.fluid
    col_of = np.full(len(f.x_all), -1)
    col_of[:f.nf] = np.arange(f.nf)
    aw = f.viscous.wall_pressure_acceleration(col_of)
    has = np.diff(f.wf_start) > 0
    assert has.sum() > 20
    assert np.abs(aw[has] - [0.0, -9.81]).max() < 0.1 * 9.81
    assert np.all(aw[~has] == 0.0)


def test_periodic_bed_wall_normals_have_no_seam():
    """A bed periodic in x has the same outward normals at the seams as in the middle:
    (0, 1) on its top layer (none with an x component)."""
    from pathlib import Path

    case = Path(__file__).resolve().parents[2] / "cases" / "bagnold.toml"
    f = Simulation(load_config(case, [])).fluid
    n = f.wall_n[:f.n_walls]
    y = f.x_all[f.nf:f.nf + f.n_walls, 1]
    top = y > y.max() - 0.25 * f.dx
    assert top.sum() == 16
    np.testing.assert_allclose(n[top], np.tile([0.0, 1.0], (top.sum(), 1)), atol=1e-9)
    assert np.abs(n[:, 0]).max() < 1e-9
