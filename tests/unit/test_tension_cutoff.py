"""Tension cut-off of a cohesionless material (``fluid.tension_cutoff``,
fsi_sph/fluid/pressure_solve.py ``PressureSolve.cut_tension``): negative pressures are set
to 0 after the pressure solve and the correction uses the cut-off field, so a region in tension opens (grains
separate) instead of pulling its neighbours back.

A square block of fluid in zero gravity is given the velocity ``u = k (x - x_c)`` (div u =
2 k) and stepped once. Expanding (k > 0), the PPE of a fluid answers with a suction that
makes the flow divergence-free; with the cut-off there is no suction and the block keeps
expanding. Compressed (k < 0), the pressure is positive and the cut-off changes nothing."""

import numpy as np
import pytest

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation


def _block(projection, cutoff, k):
    text = f"""
[case]
t_end = 1.0
dx = 0.002
gravity = [0.0, 0.0]
[fluid]
blocks = [{{ origin = [0.0, 0.0], size = [0.04, 0.04] }}]
projection = "{projection}"
tension_cutoff = {str(cutoff).lower()}
dt_max = 1.0e-3
[fluid.material]
rho0 = 1000.0
nu = 0.0
"""
    sim = Simulation(load_config(None, text=text))
    b = sim.fluid.body
    b["v"][:] = k * (b["x"] - b["x"].mean(axis=0))
    return sim


def _interior_divergence(sim):
    f = sim.fluid
    div = f.velocity_divergence(f.body["v"])
    inner = np.all(np.abs(f.body["x"] - 0.02) < 0.012, axis=1)
    return div[inner]


@pytest.mark.parametrize("projection", ["standard", "incremental"])
def test_expanding_block_is_not_held_back(projection):
    k = 1.0
    held = _block(projection, False, k)
    held.step()
    free = _block(projection, True, k)
    free.step()
    assert held.fluid.body["p"].min() < -0.1  # the fluid's suction (Pa)
    assert free.fluid.body["p"].min() >= 0.0
    assert np.abs(_interior_divergence(held)).max() < 0.05 * 2.0 * k
    assert np.allclose(_interior_divergence(free), 2.0 * k, rtol=0.02)


@pytest.mark.parametrize("projection", ["standard", "incremental"])
def test_compressed_block_is_unchanged(projection):
    k = -1.0
    runs = []
    for cutoff in (False, True):
        sim = _block(projection, cutoff, k)
        sim.step()
        runs.append(sim.fluid.body)
    assert runs[0]["p"].max() > 0.1
    assert np.array_equal(runs[0]["p"], runs[1]["p"])
    assert np.array_equal(runs[0]["v"], runs[1]["v"])


@pytest.mark.parametrize("projection", ["standard", "incremental"])
def test_walls_without_suction_keep_a_tank_at_rest(projection):
    """``fluid.wall_suction = false`` (the walls' pressure floor, _kernels.wall_floor) in a
    tank at rest: the hydrostatic wall pressures are the floor itself, so nothing moves
    and the pressure is the one the walls with suction give (a wrong sign of the
    hydrostatic carry would push the bottom row up by ~2 rho g dx per particle)."""
    def run(suction):
        text = f"""
[case]
t_end = 1.0
dx = 0.002
gravity = [0.0, -9.81]
[fluid]
blocks = [{{ origin = [0.0, 0.0], size = [0.04, 0.03] }}]
projection = "{projection}"
wall_suction = {str(suction).lower()}
[fluid.material]
rho0 = 1000.0
nu = 1.0e-6
[walls]
tanks = [{{ origin = [0.0, 0.0], size = [0.04, 0.05] }}]
"""
        sim = Simulation(load_config(None, text=text))
        for _ in range(30):
            sim.step()
        return sim.fluid.body
    with_suction, without = run(True), run(False)
    assert np.abs(without["v"]).max() < 1e-3 * np.sqrt(9.81 * 0.03)
    assert np.allclose(without["p"], with_suction["p"], rtol=0.0, atol=1e-3 * 1000 * 9.81 * 0.03)


def test_row_roles_follow_periodic_images():
    """The collision model and the wall floor see a periodic image as its original: a
    fluid image as the fluid particle, a wall image as a wall (cases/bagnold.toml)."""
    from pathlib import Path

    case = Path(__file__).resolve().parents[2] / "cases" / "bagnold.toml"
    sim = Simulation(load_config(case, ["case.dx=0.001"]))
    f = sim.fluid
    f.update_neighbors()
    fluid_of, wall = f.rows.fluid_of, f.rows.wall_rows
    rows, src = f.periodic.rows, f.periodic.src
    assert (src < f.nf).sum() > 0 and (src >= f.nf).sum() > 0  # both kinds of images
    assert np.array_equal(fluid_of[rows], np.where(src < f.nf, src, -1))
    assert np.array_equal(wall[rows], src >= f.nf)
    assert np.array_equal(fluid_of[:f.nf], np.arange(f.nf))
    assert wall[f.nf:f.nf + f.n_walls].all() and not wall[:f.nf].any()


def test_wall_floor_acts_on_non_interior_rows_only():
    """``fluid.wall_suction = false``: the floor (_kernels.wall_floor) changes the pressure
    gradient of the free-surface and near-surface rows, never that of an interior row
    (rows.py ``RowRoles.floor_rows``: beside interior rows a pairwise floor only rectified the
    pressure's particle-scale noise into a push off the wall). A noisy pressure on a layer
    at rest on a floor: interior rows get the gradient without the floor, the others the
    floored one, and the floor does change some of those."""
    text = """
[case]
t_end = 1.0
dx = 0.002
gravity = [0.0, -9.81]
[fluid]
blocks = [{ origin = [0.0, 0.0], size = [0.04, 0.012] }]
wall_suction = false
[fluid.material]
rho0 = 1000.0
nu = 1.0e-6
[walls]
tanks = [{ origin = [0.0, 0.0], size = [0.04, 0.03] }]
"""
    sim = Simulation(load_config(None, text=text))
    f = sim.fluid
    f.update_neighbors()
    f.detect_free_surface()
    f.correction_matrices()
    nf = f.nf
    rng = np.random.default_rng(5)
    p = 1000.0 * 9.81 * (0.012 - f.x_all[:, 1]) + rng.normal(scale=20.0, size=len(f.x_all))
    got = f.gradient.apply(p, np.empty((nf, 2)), floor="increment")
    jmax, every_row = f.nf + f.nw - f.ns, np.ones(nf, dtype=bool)
    plain = f.gradient.with_rows(p, jmax, f.rows.no_rows, every_row, f.rows.no_rg, np.empty((nf, 2)))
    floored = f.gradient.with_rows(p, jmax, f.rows.wall_rows, every_row, f.rows.no_rg, np.empty((nf, 2)))
    interior = f.body["class"] == 0
    beside_walls = f.rows.beside_walls()
    assert (interior & beside_walls).sum() > 10 and (~interior & beside_walls).sum() > 4
    assert np.array_equal(got[interior], plain[interior])
    assert np.array_equal(got[~interior], floored[~interior])
    assert not np.allclose(floored[interior & beside_walls], plain[interior & beside_walls])
    assert not np.allclose(floored[~interior & beside_walls], plain[~interior & beside_walls])


@pytest.mark.parametrize("gap_rows", [False, True])
def test_relaxation_gap_rows_pull_back_a_lifted_bed_row(gap_rows):
    """``fluid.relaxation_gap_rows`` (rows.py ``RowRoles.truncated_for_relaxation``): a layer whose
    rows stand 0.2 dx too high above the floor (its bed row lifted, div r below DIVR_FULL):
    off, the expansion of those rows is not relaxed (their support counts as truncated);
    on, the interior rows with div r >= DIVR_GAP and at least half a support of fluid
    neighbours are relaxed; a lone particle on the floor (few fluid neighbours) never."""
    from fsi_sph.fluid import lattice, rows

    text = f"""
[case]
t_end = 1.0
dx = 0.002
gravity = [0.0, -9.81]
[fluid]
blocks = [{{ origin = [0.0, 0.0004], size = [0.04, 0.012] }}, {{ origin = [0.07, 0.0], size = [0.002, 0.002] }}]
density_relaxation = 0.05
density_relaxation_sign = "both"
relaxation_gap_rows = {str(gap_rows).lower()}
[fluid.material]
rho0 = 1000.0
nu = 1.0e-6
[walls]
boxes = [{{ origin = [-0.01, -0.006], size = [0.1, 0.006] }}]
"""
    sim = Simulation(load_config(None, text=text))
    f = sim.fluid
    f.update_neighbors()
    f.detect_free_surface()
    b = f.body
    x = b["x"]
    bed = (x[:, 1] < 0.002) & (x[:, 0] > 0.008) & (x[:, 0] < 0.032)  # away from the ends
    lone = x[:, 0] > 0.06
    assert bed.sum() >= 10 and lone.sum() == 1
    assert np.all((b["divr"][bed] < lattice.DIVR_FULL) & (b["divr"][bed] >= rows.DIVR_GAP))
    assert np.all(b["class"][bed] == 0)
    truncated = f.rows.truncated_for_relaxation()
    assert truncated[lone].all()
    assert truncated[bed].all() != gap_rows
    # the relaxation source of a uniformly dilated packing: the bed rows pull back only with
    # the option, the lone particle never (not interior: a surface particle)
    b["sigma"][:] = 0.97 * f.sigma0
    src = f.pressure.relaxation_source(1e-3)
    assert np.all(src[bed] < 0.0) == gap_rows and np.all(src[bed] == 0.0) != gap_rows
    assert src[lone].max() == 0.0
