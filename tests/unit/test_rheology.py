"""mu(I) rheology [G 31-37], the implicit viscous step and periodic boundaries (issue 6)."""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from fsi_sph.config import load_config
from fsi_sph.errors import ConfigError
from fsi_sph.fluid import _kernels as K
from fsi_sph.fluid import rheology as R
from fsi_sph.fluid import viscous_operators as VO
from fsi_sph.fluid import viscous_solvers as VS
from fsi_sph.neighbors import find_neighbors
from fsi_sph.simulation import Simulation
from fsi_sph.sph.kernels import KERNELS
from tests.conftest import lattice

GLASS = dict(mu_s=0.382, mu_2=0.643, i0=0.279, d=0.5e-3, rho_s=2500.0)


# ---------------------------------------------------------------------------- law


def _eta_reference(g, p, mu_s, mu_2, i0, d, rho_s, alpha_r):
    """[G 35] written out term by term in plain Python (the test's own transcription)."""
    xi = i0 / (d * math.sqrt(rho_s))
    first = mu_s * p * (1.0 - math.exp(-g / alpha_r)) / g if g > 0 else mu_s * p / alpha_r
    return first + (mu_2 - mu_s) * p / (xi * math.sqrt(p) + g + alpha_r)


def test_apparent_viscosity_matches_transcription_of_G35(rng):
    g = rng.uniform(0.0, 200.0, 50)
    g[:3] = [0.0, 1e-9, 5e-3]
    p = rng.uniform(0.0, 3000.0, 50)
    got = R.apparent_viscosity(g, p, **GLASS, eta_max=1e12, alpha_r=0.01)
    ref = [_eta_reference(gi, pi, GLASS["mu_s"], GLASS["mu_2"], GLASS["i0"], GLASS["d"],
                          GLASS["rho_s"], 0.01) for gi, pi in zip(g, p, strict=True)]
    assert_allclose(got, ref, rtol=1e-8)  # the plain 1 - exp(-x) of the reference loses ~1e-9


def test_apparent_viscosity_tends_to_mu_of_I_p_over_gammadot():
    """Away from the regularisation (|gammadot| >> alpha_r) eta |gammadot| = mu(I) p with
    mu(I) of [G 31] and I of [G 32]."""
    g = np.array([5.0, 50.0, 500.0])
    p = np.array([100.0, 1000.0, 10.0])
    eta = R.apparent_viscosity(g, p, **GLASS, eta_max=1e12, alpha_r=1e-6)
    inertial = R.inertial_number(g, p, GLASS["d"], GLASS["rho_s"])
    mu = R.friction(inertial, GLASS["mu_s"], GLASS["mu_2"], GLASS["i0"])
    assert_allclose(eta * g / p, mu, rtol=1e-6)
    assert np.all((mu > GLASS["mu_s"]) & (mu < GLASS["mu_2"]))


def test_apparent_viscosity_finite_at_rest_capped_and_zero_without_pressure():
    eta = R.apparent_viscosity(np.zeros(3), np.array([0.0, 100.0, -5.0]), **GLASS,
                               eta_max=1e12, alpha_r=0.01)
    xi = GLASS["i0"] / (GLASS["d"] * math.sqrt(GLASS["rho_s"]))
    lim = GLASS["mu_s"] * 100.0 / 0.01 + (GLASS["mu_2"] - GLASS["mu_s"]) * 100.0 / (
        xi * 10.0 + 0.01)
    assert_allclose(eta, [0.0, lim, 0.0])
    capped = R.apparent_viscosity(np.zeros(1), np.array([100.0]), **GLASS, eta_max=50.0)
    assert capped[0] == 50.0


def test_friction_limits_and_strain_rate_of_simple_shear():
    assert_allclose(R.friction([1e-12, 1e12], 0.4, 0.6, 0.3), [0.4, 0.6], atol=1e-10)
    assert_allclose(R.friction(0.3, 0.4, 0.6, 0.3), 0.5)
    gv = np.zeros((2, 2, 2))
    gv[0, 0, 1] = 3.0          # u = 3 y
    gv[1, 0, 0], gv[1, 1, 1] = 2.0, -2.0  # pure strain u = (2x, -2y): sqrt(2 S:S) = 4
    assert_allclose(R.strain_rate(gv), [3.0, 4.0])


def test_i0_of_glass_beads_and_bagnold_inertial_number():
    # [G 41] with beta 0.136, L/d 1.65, phi 0.6 gives the Jop et al. I0 = 0.279 near 24.6 deg
    assert R.i0_from_beta(0.136, 1.65, 0.6, math.radians(24.6)) == pytest.approx(0.279, rel=2e-3)
    th = math.radians(24.0)
    inertial = R.bagnold_inertial_number(th, 0.382, 0.643, 0.279)
    assert R.friction(inertial, 0.382, 0.643, 0.279) == pytest.approx(math.tan(th), rel=1e-12)
    with pytest.raises(ValueError, match="no steady flow"):
        R.bagnold_inertial_number(math.radians(15.0), 0.382, 0.643, 0.279)


def test_bagnold_profile_satisfies_the_mu_of_I_law():
    """dU/dy of [G 36] gives, with p = rho g cos(theta) (H - y), I = the uniform I [G 32]."""
    th, depth, d, phi, rho_s, g = math.radians(24.0), 0.01, 0.5e-3, 0.6, 2500.0, 9.81
    inertial = R.bagnold_inertial_number(th, 0.382, 0.643, 0.279)
    y = np.linspace(0.0, 0.009, 10)
    e = 1e-7
    dudy = (R.bagnold_profile(y + e, depth, th, d, phi, inertial, g)
            - R.bagnold_profile(y - e, depth, th, d, phi, inertial, g)) / (2 * e)
    dudy[0] = (R.bagnold_profile(e, depth, th, d, phi, inertial, g)
               - R.bagnold_profile(0.0, depth, th, d, phi, inertial, g)) / e
    p = phi * rho_s * g * math.cos(th) * (depth - y)
    assert_allclose(R.inertial_number(dudy, p, d, rho_s), inertial, rtol=1e-5)
    assert R.bagnold_profile(0.0, depth, th, d, phi, inertial, g) == 0.0


# ---------------------------------------------------------------------------- config

MUI = """
[case]
t_end = 0.002
dx = 0.001
gravity = [3.99, -8.96]
[fluid]
blocks = [{{ origin = [0.0, 0.0], size = [0.012, 0.006] }}]
viscous_step = "implicit"
{extra}
[fluid.material]
rho0 = 1500.0
viscosity = "{law}"
{params}
[walls]
boxes = [{{ origin = [0.0, -0.003], size = [0.012, 0.003] }}]
"""
PARAMS = ("mu_i = { mu_s = 0.382, mu_2 = 0.643, I0 = 0.279, d = 0.0005, rho_s = 2500.0, "
          "eta_max = 100.0 }")


def mui_config(law="mu_i", params=PARAMS, extra="periodic_x = [0.0, 0.012]"):
    return load_config(None, text=MUI.format(law=law, params=params, extra=extra))


@pytest.mark.parametrize("kw, message", [
    (dict(law="bingham"), "fluid.material.viscosity: Input should be 'newtonian', "
     "'smagorinsky' or 'mu_i'"),
    (dict(params=""), "the `mu_i` parameter table is required"),
    (dict(law="newtonian"), "allowed only then"),
    (dict(params=PARAMS.replace("mu_2 = 0.643", "mu_2 = 0.3")), "mu_2 = 0.3 must exceed"),
    (dict(params=PARAMS.replace("d = 0.0005", "d = -1.0")), r"fluid.material.mu_i.d: "
     "Input should be greater than 0"),
    (dict(params=PARAMS.replace("eta_max", "etamax")), "fluid.material.mu_i.etamax: unknown"),
    (dict(extra="periodic_x = [0.0, 0.003]"), "shorter than two kernel supports"),
    (dict(extra="periodic_x = [0.0, -1.0]"), "need x_max > x_min"),
    (dict(extra="viscous_rtol = 2.0"), "fluid.viscous_rtol"),
])
def test_config_errors_name_key_and_value(kw, message):
    with pytest.raises(ConfigError, match=message) as e:
        mui_config(**kw)
    assert str(e.value).startswith("<text>: ")


def test_config_modules():
    assert mui_config().modules() == ["isph_fluid", "walls", "shifting:fickian_fixed", "mu_i",
                                      "implicit_viscosity", "periodic_x"]


# ---------------------------------------------------------------------------- implicit step


def _morris_setup(rng, nf=80):
    x = lattice(10, 10, 0.1) + rng.uniform(-0.02, 0.02, (100, 2))
    start, j = find_neighbors(x[:nf], x, 0.24, exclude_self=True)
    vol = np.full(len(x), 0.01)
    nu = rng.uniform(0.1, 2.0, len(x))
    v = rng.normal(size=(len(x), 2))
    return x, start, j, vol, nu, v


def test_implicit_matrix_is_the_explicit_morris_operator(rng):
    """A u = u - dt lap_nu u: the matrix applied to a field gives back the explicit
    [F 16] update of the same Morris operator (predict_velocity, g = 0):
    A u + (wall part) = 2 u - u*_explicit."""
    nf = 80
    x, start, j, vol, nu, v = _morris_setup(rng, nf)
    kind, h, eta2, dt = KERNELS["cubic_spline"], 0.12, (0.012) ** 2, 1e-3
    col_of = np.full(len(x), -1)
    col_of[:nf] = np.arange(nf)
    A, b_wall = VO.assemble(x, vol, nu, v, start, j, nf, h, kind, eta2, dt, col_of)
    out = np.zeros((nf, 2))
    K.predict_velocity(x, v, vol, nu, start, j, nf, h, kind, eta2, 0.0, 0.0, dt, out)
    assert_allclose(A @ v[:nf] - b_wall, 2 * v[:nf] - out, rtol=1e-10, atol=1e-12)
    assert abs(A - A.T).max() < 1e-12 * abs(A).max()  # equal volumes: symmetric


def test_implicit_solve_converges_and_is_stable_far_beyond_the_explicit_limit(rng):
    nf = 80
    x, start, j, vol, nu, v = _morris_setup(rng, nf)
    kind, h, eta2 = KERNELS["cubic_spline"], 0.12, (0.012) ** 2
    dt = 1e4 * 0.125 * h * h / nu.max()
    col_of = np.full(len(x), -1)
    col_of[:nf] = np.arange(nf)
    v[nf:] = 0.0  # still walls
    A, b_wall = VO.assemble(x, vol, nu, v, start, j, nf, h, kind, eta2, dt, col_of)
    u, stats = VS.solve(A, v[:nf] + b_wall, v[:nf], 1e-10)
    assert stats.residual < 1e-9
    assert np.abs(u).max() < np.abs(v[:nf]).max()  # diffusion toward the wall: no growth


# ---------------------------------------------------------------------------- periodic


def test_periodic_pair_distance_equals_interior_pair():
    """A pair across the periodic edge sees its neighbour at the same distance as the
    same pair in the interior, and the lattice neighbour counts are uniform in x."""
    cfg = mui_config(law="newtonian", params="", extra="periodic_x = [0.0, 0.012]")
    sim = Simulation(cfg)
    f = sim.fluid
    x = f.body["x"]
    # the particle at the left edge and the one at the right edge of the same row
    row = np.isclose(x[:, 1], 0.0025)
    left = np.flatnonzero(row & np.isclose(x[:, 0], 0.0005))[0]
    right = np.flatnonzero(row & np.isclose(x[:, 0], 0.0115))[0]
    nb = f.ff_j[f.ff_start[left]:f.ff_start[left + 1]]
    d = np.hypot(*(f.x_all[nb] - x[left]).T)
    img = nb[(nb >= f.nf + f.n_walls)]
    src = dict(zip(f.periodic.rows, f.periodic.src, strict=True))
    right_img = [k for k in img if src[k] == right][0]
    assert np.hypot(*(f.x_all[right_img] - x[left])) == pytest.approx(0.001, rel=1e-12)
    # neighbour distances of the edge particle = those of an interior particle
    mid = np.flatnonzero(row & np.isclose(x[:, 0], 0.0065))[0]
    nm = f.ff_j[f.ff_start[mid]:f.ff_start[mid + 1]]
    dm = np.hypot(*(f.x_all[nm] - x[mid]).T)
    assert_allclose(np.sort(d), np.sort(dm), atol=1e-12)
    assert np.all(np.diff(f.ff_start)[row] == len(nm))


def test_periodic_uniform_shear_stays_uniform():
    """Couette-like shear u = k y above a bed at rest is periodic in x: after some steps
    every column of the layer has the same velocity profile (no seam), and wrapped
    positions stay in the period."""
    text = MUI.format(law="newtonian", params="nu = 1.0e-3",
                      extra="periodic_x = [0.0, 0.012]").replace(
        "gravity = [3.99, -8.96]", "gravity = [0.0, -9.81]")
    cfg = load_config(None, text=text)
    sim = Simulation(cfg)
    f = sim.fluid
    f.body["v"][:, 0] = 50.0 * (f.body["x"][:, 1] + 0.0005)
    for _ in range(20):
        sim.step()
    f.update_neighbors()  # the wrap comes with each step's neighbour update, before the move
    x, v = f.body["x"], f.body["v"]
    assert x[:, 0].min() >= 0.0 and x[:, 0].max() < 0.012
    # (a small settling, O(dt) and the same without periodicity, is the scheme's)
    assert np.abs(v[:, 1]).max() < 0.05 * np.abs(v[:, 0]).max()
    # velocity per layer: spread across x small compared with the layer's mean
    ybin = np.round(x[:, 1] / 0.001).astype(int)
    for b in np.unique(ybin)[1:-1]:
        u = v[ybin == b, 0]
        assert u.std() < 0.02 * abs(u.mean()), (b, u.std(), u.mean())


def test_mu_i_scene_records_both_time_step_limits(tmp_path):
    import json

    import h5py

    sim = Simulation(mui_config())
    sim.run(out_dir=tmp_path, max_steps=5, progress=False)
    with h5py.File(tmp_path / "run.h5", "r") as fh:
        cols = json.loads(fh["steps"].attrs["columns"])
        s = fh["steps"][()]
    adv = s[:, cols.index("dt_advective")]
    visc = s[:, cols.index("dt_viscous_explicit")]
    dt = s[:, cols.index("dt")]
    assert np.all(dt <= np.minimum(adv, s[:, cols.index("dt_force")]) * (1 + 1e-12))
    assert np.all(dt[1:] > visc[1:])  # implicit: the explicit viscous limit is not applied
    assert np.all(s[1:, cols.index("viscous_residual")] < 1e-7)


def test_mirrored_walls_in_the_implicit_matrix_equal_the_explicit_operator(rng):
    """With the no-slip mirror u_w = target - S u (Adami et al. 2012) folded into A, the
    matrix still reproduces the explicit Morris update with the mirrored wall velocities."""
    import scipy.sparse as sp

    nf = 80
    x, start, j, vol, nu, v = _morris_setup(rng, nf)
    kind, h, eta2, dt = KERNELS["cubic_spline"], 0.12, (0.012) ** 2, 1e-3
    nb = len(x) - nf
    col_of = np.full(len(x), -1)
    col_of[:nf] = np.arange(nf)
    S = sp.csr_array(rng.uniform(0, 1, (nb, nf)) * (rng.uniform(0, 1, (nb, nf)) < 0.1))
    target = rng.normal(size=(nb, 2))
    A, b_wall = VO.assemble(x, vol, nu, v, start, j, nf, h, kind, eta2, dt, col_of, (S, target))
    vm = v.copy()
    vm[nf:] = target - S @ v[:nf]
    out = np.zeros((nf, 2))
    K.predict_velocity(x, vm, vol, nu, start, j, nf, h, kind, eta2, 0.0, 0.0, dt, out)
    assert_allclose(A @ v[:nf] - b_wall, 2 * v[:nf] - out, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("sign", ["compression", "both"])
def test_density_relaxation_sign_acts_on_interior_expansion_only_when_asked(sign):
    """An interior particle (full support) whose kernel sum is below sigma0 changes the
    PPE right-hand side with sign = "both", not with the default "compression"; one with
    a truncated support (div r < 1.95) never does."""
    text = MUI.format(law="newtonian", params="nu = 1.0e-3",
                      extra=f"density_relaxation = 0.1\ndensity_relaxation_sign = \"{sign}\"\n"
                      # Adami's walls: the mirror rule (the default) switches from Adami's
                      # term to its own once a pressure is known, which would change the
                      # walls' rows between the two solves compared here
                      "wall_pressure = \"adami\"")
    text = text.replace("boxes = [{ origin = [0.0, -0.003], size = [0.012, 0.003] }]",
                        "tanks = [{ origin = [0.0, 0.0], size = [0.012, 0.008] }]")
    sim = Simulation(load_config(None, text=text))
    f = sim.fluid
    f.update_neighbors()
    f.detect_free_surface()
    f.predict(1e-4)
    b = f.body
    full = np.flatnonzero((b["class"] == 0) & (b["divr"] >= 1.95))[0]
    f.solve_pressure(1e-4)
    rhs0 = f.pressure.rhs.copy()
    b["sigma"][full] *= 0.99
    f.solve_pressure(1e-4)
    changed = np.flatnonzero(np.abs(f.pressure.rhs - rhs0) > 1e-9 * np.abs(rhs0).max())
    assert list(changed) == ([full] if sign == "both" else [])


def test_mu_i_layer_sliding_on_a_rough_bed_stops_on_the_friction_time_scale():
    """A mu(I) layer launched at 1 m/s over a level no-slip bed (periodic in x) is
    stopped by basal friction mu(I) p between mu_s and mu_2: its momentum vanishes between
    1/(mu_2 g) and 1.2/(mu_s g) (a block sliding at mu_s would stop at 1/(mu_s g))."""
    from pathlib import Path

    case = Path(__file__).resolve().parents[2] / "cases" / "bagnold.toml"
    sim = Simulation(load_config(case, ["case.gravity=[0.0, -9.81]", "case.dx=0.001"]))
    f = sim.fluid
    f.body["v"][:, 0] = 1.0
    t_fast, t_slow = 1.0 / (0.643 * 9.81), 1.2 / (0.382 * 9.81)
    while sim.t < t_fast:
        sim.step()
    assert f.body["v"][:, 0].mean() > 0.05
    while sim.t < t_slow:
        sim.step()
    assert abs(f.body["v"][:, 0].mean()) < 0.01


def test_periodic_bed_normals_have_no_ends():
    """A bed cut by the period's edges has no ends there: the normals of its top layer all
    point up, the end columns included (the kinematic guard acts along them)."""
    sim = Simulation(mui_config(law="newtonian", params=""))
    f = sim.fluid
    xw = f.walls.body["x"]
    top = np.isclose(xw[:, 1], xw[:, 1].max())
    assert top.sum() == 12
    assert_allclose(f.wall_n[:f.n_walls][top], np.tile([0.0, 1.0], (12, 1)), atol=1e-9)
