"""The free surface half a spacing outside the surface particles (``fluid.surface_offset``,
fsi_sph/fluid/pressure_solve.py ``PressureSolve.surface_pressure``): the surface rows'
pressure is the last pressure extrapolated along the outward normal to the surface
``delta = offset dx`` away, ``p_s = delta max(0, -n . grad p)``.

A tank at rest: with the offset 0.5 every particle row carries the weight of the rows above
it and of its own upper half, ``p = rho g (H - y)`` (H the block's top, a half spacing above
the top row); with the surface on the particles (offset 0) every row is short by
``rho g dx / 2``. A block in free fall (no walls) has no pressure gradient and its surface
rows stay at ``p = 0``.

Measured without shifting (``shifting = false``): with the default shifting the offset tank
moved at up to 1.3e-4 m/s by 0.3 s (under the 1e-4 bound without)."""

import numpy as np
import pytest

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation

RHO, G, H, DX = 1000.0, 9.81, 0.2, 0.02


def _tank(offset, projection, walls=True, t_end=0.3):
    text = f"""
[case]
t_end = {t_end}
dx = {DX}
gravity = [0.0, -{G}]
[fluid]
blocks = [{{ origin = [0.0, 0.0], size = [0.2, {H}] }}]
projection = "{projection}"
surface_offset = {offset}
surface_scan = false
shifting = false
density_relaxation = 0.0  # the offset alone (the relaxation stirs still water slightly)
[fluid.material]
rho0 = {RHO}
nu = 1.0e-6
"""
    if walls:
        text += "[walls]\nlayers = 3\ntanks = [{ origin = [0.0, 0.0], size = [0.2, 0.3] }]\n"
    sim = Simulation(load_config(None, text=text))
    sim.run(out_dir=None)
    return sim


@pytest.mark.parametrize("projection", ["standard", "incremental"])
def test_tank_rows_carry_the_weight_above_them(projection):
    sim = _tank(0.5, projection)
    b = sim.fluid.body
    y, p = b["x"][:, 1], b["p"]
    hydro = RHO * G * (H - y)
    inner = (b["x"][:, 0] > 2 * DX) & (b["x"][:, 0] < 0.2 - 2 * DX)
    assert np.abs(p - hydro)[inner].max() < 0.01 * RHO * G * DX  # 1 % of a row's weight
    top = y > H - DX
    assert np.allclose(p[top & inner], 0.5 * RHO * G * DX, rtol=0.01)
    assert np.abs(b["v"]).max() < 1e-4


def test_without_offset_every_row_is_short_by_half_a_row():
    sim = _tank(0.0, "standard")
    b = sim.fluid.body
    y, p = b["x"][:, 1], b["p"]
    inner = (b["x"][:, 0] > 2 * DX) & (b["x"][:, 0] < 0.2 - 2 * DX)
    short = (RHO * G * (H - y) - p)[inner]
    assert np.allclose(short, 0.5 * RHO * G * DX, rtol=0.05)


def test_free_fall_keeps_the_surface_at_zero_pressure():
    sim = _tank(0.5, "standard", walls=False, t_end=0.05)
    b = sim.fluid.body
    assert np.abs(b["p"]).max() < 1e-3 * RHO * G * DX
    assert np.allclose(b["v"][:, 1], -G * sim.t, rtol=1e-3)


def test_mu_i_half_spacing_is_not_counted_twice():
    from fsi_sph.errors import ConfigError

    text = """
[case]
t_end = 0.1
dx = 0.01
[fluid]
blocks = [{ origin = [0.0, 0.0], size = [0.1, 0.1] }]
surface_offset = 0.5
surface_scan = false
shifting = false
density_relaxation = 0.0  # the offset alone (the relaxation stirs still water slightly)
[fluid.material]
rho0 = 1500.0
viscosity = "mu_i"
mu_i = { mu_s = 0.38, mu_2 = 0.64, I0 = 0.28, d = 0.0005, rho_s = 2500.0, eta_max = 1000.0 }
"""
    with pytest.raises(ConfigError, match="pressure_offset"):
        load_config(None, text=text)
    load_config(None, text=text.replace("eta_max = 1000.0", "eta_max = 1000.0, "
                                        "pressure_offset = \"none\""))


@pytest.mark.parametrize("factor, expected", [(0.5, 0.5), (10.0, 1.0), (-1.0, 0.0)])
def test_surface_pressure_is_the_bounded_extrapolation(factor, expected):
    """A linear field ``p = factor rho g (H - y)`` extrapolated half a spacing up to the
    surface gives ``factor rho g dx / 2`` at the top row, bounded by the hydrostatic head
    (factor 10: a one-sided gradient at an impact) and never negative (a field rising
    towards the surface)."""
    sim = _tank(0.5, "standard", t_end=1e-3)
    f = sim.fluid
    y = f.x_all[:, 1]
    f.p_all[:] = factor * RHO * G * (H - y)
    f.correction_matrices()
    ps = f.pressure.surface_pressure()
    b = f.body
    top = (b["x"][:, 1] > H - DX) & (b["x"][:, 0] > 2 * DX) & (b["x"][:, 0] < 0.2 - 2 * DX)
    assert np.allclose(ps[top], expected * 0.5 * RHO * G * DX, rtol=1e-6, atol=1e-9)
    deep = b["x"][:, 1] < H - 4 * DX  # interior rows: no normal, no target
    assert np.all(ps[deep] == 0.0)


def test_offset_with_the_scan_is_a_config_error():
    from fsi_sph.errors import ConfigError

    text = f"""
[case]
t_end = 0.1
dx = {DX}
[fluid]
blocks = [{{ origin = [0.0, 0.0], size = [0.2, {H}] }}]
surface_offset = 0.5
[fluid.material]
rho0 = {RHO}
nu = 1.0e-6
"""
    with pytest.raises(ConfigError, match="surface_scan = false"):
        load_config(None, text=text)
