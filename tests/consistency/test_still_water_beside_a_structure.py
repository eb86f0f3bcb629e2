"""Still water beside a clamped structure stays still (the gradient a coupled scene uses).

A tank 0.36 x 0.18 m at rest, dx 6 mm, a clamped 6 cm square either fully submerged or
through the free surface. Measured 2026-12-01 (1 thread, to 0.6-0.8 s):

- ``pressure_gradient = "conservative"`` (the pair form [F 10] on every row): blows up at
  0.54 s with the square submerged, 0.46 s through the surface, 0.48 s with no structure at
  all. Its free-surface rows see half the hydrostatic gradient; the surface sags and the
  near-surface rows build a runaway tension.
- ``"interface_conservative"`` (the pair form only on rows beside the structure, the
  corrected form [F 7, F 13] elsewhere): submerged square, at rest to 0.8 s (max speed
  < 1e-3 m/s; measured 5e-6). Through the surface it failed (0.52 s) while the pair form
  was also on the free-surface rows beside the structure: over a support cut by the surface
  it gives half the hydrostatic gradient, and the surface particles slid down the
  structure's face from the first steps (0.05-0.18 m/s). Those waterline rows now take the
  corrected form over the fluid and walls and the same correction ``L_i`` on their pair terms
  with the structure (``IncompressibleFluid.waterline_rows``): at rest to 1 s (measured
  max speed 1e-7 m/s, 2026-12-01e).
"""

import numpy as np
import pytest

from fsi_sph.config import load_config
from fsi_sph.errors import SimulationError
from fsi_sph.simulation import Simulation

CASE = """
[case]
t_end = {t_end}
dx = 0.006
gravity = [0.0, -9.81]
output_every = 10.0
[fluid]
material = {{ rho0 = 1000.0, nu = 1.0e-6 }}
blocks = [{{ origin = [0.0, 0.0], size = [0.36, 0.18] }}]
pressure_gradient = "{gradient}"
dt_max = 1.0e-3
[walls]
layers = 3
tanks = [{{ origin = [0.0, 0.0], size = [0.36, 0.28] }}]
[solid.box]
material = {{ model = "stvk", rho0 = 500.0, E = 2.0e7, nu = 0.3 }}
blocks = [{{ origin = [0.15, {y0}], size = [0.06, 0.06] }}]
clamp = [{{ origin = [0.15, {y0}], size = [0.06, 0.06] }}]
[coupling]
structures = ["box"]
"""


def _still_water(tmp_path, gradient, y0, t_end, overrides=()):
    """Run to ``t_end`` (the guard raises if the run goes bad); the largest fluid speed."""
    p = tmp_path / "still.toml"
    p.write_text(CASE.format(gradient=gradient, y0=y0, t_end=t_end))
    sim = Simulation(load_config(p, list(overrides)))
    while sim.t < t_end - 1e-9:
        sim.step()
        sim.check()
    return sim.fluid.max_speed()


def test_still_water_around_a_submerged_structure_stays_still(tmp_path):
    assert _still_water(tmp_path, "interface_conservative", 0.06, 0.8) < 1e-3


@pytest.mark.xfail(strict=True, raises=SimulationError,
                   reason="the pair form on every row: the free surface sags and blows up "
                   "(measured at 0.54 s)")
def test_still_water_with_the_pair_form_everywhere(tmp_path):
    # measured without shifting, collisions and density relaxation (what a coupled scene
    # now has: with shifting and collisions the pair form held to 0.8 s, and with the
    # default relaxation alone too (2026-12-06); how long beyond is not measured)
    _still_water(tmp_path, "conservative", 0.06, 0.8, ["fluid.shifting=false",
                                                       "fluid.collision=false",
                                                       "fluid.density_relaxation=0"])


def test_still_water_against_a_structure_through_the_surface(tmp_path):
    assert _still_water(tmp_path, "interface_conservative", 0.15, 0.8) < 1e-3


def test_interface_conservative_rows(tmp_path, rng):
    """The gradient is the pair form [F 10] exactly on the fluid rows with a structure
    particle among their neighbours and the corrected form [F 7, F 13] on the others."""
    _, f = _prepared(tmp_path, 0.06)
    field = rng.uniform(0.0, 2e3, len(f.p_all))
    mixed = f.gradient.apply(field, np.empty((f.nf, 2)))
    rows = f.rows.structure_rows(f.nf + f.nw - f.ns)
    assert 0 < rows.sum() < f.nf
    assert not f.waterline_rows().any()  # submerged: no free-surface row beside it
    for form in ("conservative", "corrected"):
        f.cfg = f.cfg.model_copy(update={"pressure_gradient": form})
        ref = f.gradient.apply(field, np.empty((f.nf, 2)))
        sel = rows if form == "conservative" else ~rows
        np.testing.assert_array_equal(mixed[sel], ref[sel])
        assert not np.allclose(mixed[~sel], ref[~sel])


def _prepared(tmp_path, y0):
    """The scene with the square at ``y0`` (0.06 submerged, 0.15 through the surface), its
    neighbours, free surface and correction matrices at the start."""
    p = tmp_path / "c.toml"
    p.write_text(CASE.format(gradient="interface_conservative", y0=y0, t_end=0.01))
    sim = Simulation(load_config(p))
    f = sim.fluid
    f.update_neighbors()
    f.detect_free_surface()
    f.correction_matrices()
    return sim, f


def test_waterline_rows_take_the_corrected_gradient_over_the_whole_support(tmp_path, rng):
    """On the free-surface rows beside the structure (p = 0) the fluid's gradient plus the
    interface pair terms weighted by L_i is the corrected gradient [F 7, F 13] over every
    neighbour, structure particles included: exact for a linear pressure field."""
    sim, f = _prepared(tmp_path, 0.15)
    rows = f.waterline_rows()
    assert 0 < rows.sum() < f.rows.structure_rows(f.nf + f.nw - f.ns).sum()
    grad = np.array([120.0, -9810.0])
    f.p_all[:] = 5000.0 + f.x_all @ grad
    f.p_all[:f.nf][rows] = 0.0  # their Dirichlet value (a linear field through it)
    total = f.gradient.apply(f.p_all, np.empty((f.nf, 2)))
    on_fluid = sim.coupling.forces()  # the pair force the fluid gets from the structure
    total -= on_fluid / (f.body["m"] / f.rho)[:, None]  # as a gradient: -F / V
    # reference: L_i sum_j V_j (p_j - p_i) grad W_ij over every neighbour, p_i = 0
    x, vol, L = f.x_all, f.vol_all, f.L
    for i in np.flatnonzero(rows):
        s = np.zeros(2)
        for j in f.ff_j[f.ff_start[i]:f.ff_start[i + 1]]:
            d = x[i] - x[j]
            r = np.hypot(*d)
            if r > 1e-12:
                s += vol[j] * (f.p_all[j] - f.p_all[i]) * _dw(f, r) / r * d
        np.testing.assert_allclose(total[i], L[i] @ s, rtol=1e-9, atol=1e-9 * 9810)


def _dw(f, r):
    from fsi_sph.sph.kernels import kernel_dw

    return kernel_dw(f.kernel, r, f.h)


def test_waterline_pair_terms_keep_action_equal_to_reaction(tmp_path, rng):
    sim, f = _prepared(tmp_path, 0.15)
    assert f.waterline_rows().any()
    f.p_all[:] = rng.uniform(0.0, 2e3, len(f.p_all))
    f.p_all[:f.nf][f.waterline_rows()] = 0.0
    c = sim.coupling
    c.forces()
    total = c.on_structure.sum(axis=0) + c.on_fluid.sum(axis=0)
    assert np.abs(c.on_structure).sum() > 0
    np.testing.assert_allclose(total, 0.0, atol=1e-12 * np.abs(c.on_structure).sum())
