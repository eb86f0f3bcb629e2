"""A coupled fluid-structure step: momentum exchanged at the interface sums to zero to
round-off with the real pressure field; structure pressures come from the same solve."""

import numpy as np
from numpy.testing import assert_allclose

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation

CASE = """
[case]
t_end = 0.01
dx = 0.01
gravity = [0.0, -9.81]
[fluid]
material = { rho0 = 1000.0, nu = 1.0e-6 }
blocks = [{ origin = [0.0, 0.0], size = [0.3, 0.3] }]
pressure_gradient = "conservative"
dt_max = 1.0e-3
[walls]
layers = 3
tanks = [{ origin = [0.0, 0.0], size = [0.3, 0.4] }]
[solid.block]
material = { model = "stvk", rho0 = 10000.0, E = 1.0e7, nu = 0.3 }
blocks = [{ origin = [0.1, 0.1], size = [0.1, 0.1] }]
[coupling]
structures = ["block"]
"""


def _scene(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text(CASE)
    return Simulation(load_config(p))


def test_momentum_exchange_sums_to_zero(tmp_path):
    sim = _scene(tmp_path)
    fluid = sim.fluid
    # the fluid block is filled around the structure (particles on its sites dropped)
    assert fluid.nf == 30 * 30 - 10 * 10
    for _ in range(3):
        sim.step()
    c = sim.coupling
    total = c.on_structure.sum(axis=0) + c.on_fluid.sum(axis=0)
    scale = np.abs(c.on_structure).sum()
    assert scale > 0
    assert np.all(np.abs(total) < 1e-12 * scale)
    # structure pressures come from the PPE (Adami rows), positive under water
    assert fluid.structure_pressure().max() > 0


def test_coupling_needs_conservative_gradient(tmp_path):
    import pytest

    from fsi_sph.errors import ConfigError

    p = tmp_path / "c.toml"
    p.write_text(CASE.replace('pressure_gradient = "conservative"\n',
                              'pressure_gradient = "corrected"\n'))
    with pytest.raises(ConfigError, match="conservative"):
        load_config(p)
    p.write_text(CASE.replace('pressure_gradient = "conservative"\n', ""))  # left out: picked
    assert load_config(p).fluid.pressure_gradient == "interface_conservative"


def test_implicit_structure_rows_match_formula(rng):
    """Structure row w of the PPE with the implicit acceleration (fsi_sph/fluid/_kernels/pressure.py,
    ppe_fill): (1 + sum k) p_w + sum (k - w_wf) p_f = rho (g - a~) . rbar, scaled by diag_ref,
    k_wf = -imp V_f grad W_wf . rbar; with imp = 0 it is Adami's row."""
    from fsi_sph.fluid.ppe import assemble
    from fsi_sph.neighbors import find_neighbors
    from tests.reference_impl import cubic_dw, cubic_w

    dx, h = 0.01, 0.012
    xf = np.mgrid[0:6, 0:6].reshape(2, -1).T * dx + 0.003 * rng.standard_normal((36, 2))
    xb = np.array([[0.065, 0.02], [0.065, 0.03], [0.075, 0.025]])
    x = np.vstack([xf, xb])
    nf, nw = len(xf), len(xb)
    vol = np.full(nf + nw, dx * dx)
    ff = find_neighbors(xf, x, 2 * h, exclude_self=True)
    wf = find_neighbors(xb, xf, 2 * h)
    gb = np.array([[0.3, -9.81], [0.0, -9.81], [-1.0, -5.0]])
    imp = np.array([0.0, 0.9, 0.5])
    diag_ref = 7.0
    A, b = assemble(x, vol, np.ones(nf), np.zeros(nf), np.tile(np.eye(2), (nf, 1, 1)),
                    np.zeros(nf, dtype=bool), *ff, *wf, nf, nw, h, 0, (0.1 * h) ** 2, 1.0,
                    diag_ref, 1000.0, gb, imp)
    A = A.toarray()
    for w in range(nw):
        d = xb[w] - xf
        r = np.linalg.norm(d, axis=1)
        inside = r < 2 * h
        wt = np.where(inside, cubic_w(r, h), 0.0)
        wt /= wt.sum()
        rbar = (wt[:, None] * d).sum(axis=0)
        gw = np.where(inside, cubic_dw(r, h) / r, 0.0)[:, None] * d
        k = -imp[w] * vol[:nf] * (gw @ rbar)
        np.testing.assert_allclose(A[nf + w, :nf], diag_ref * (k - wt), atol=1e-12)
        np.testing.assert_allclose(A[nf + w, nf + w], diag_ref * (1 + k.sum()), rtol=1e-12)
        np.testing.assert_allclose(b[nf + w], diag_ref * 1000.0 * gb[w] @ rbar, rtol=1e-12)


POST = """
[case]
t_end = 0.1
dx = 0.01
gravity = [0.0, -9.81]
[fluid]
material = { rho0 = 1000.0, nu = 1.0e-6 }
blocks = [{ origin = [0.0, 0.0], size = [0.3, 0.2] }]
pressure_gradient = "conservative"
[walls]
layers = 3
tanks = [{ origin = [0.0, 0.0], size = [0.3, 0.3] }]
[solid.post]
material = { model = "neo_hookean", rho0 = 1100.0, E = 1.0e6, nu = 0.3 }
blocks = [{ origin = [0.14, 0.0], size = [0.02, 0.12] }]
clamp = [{ origin = [0.14, 0.0], size = [0.02, 0.02] }]
[coupling]
structures = ["post"]
[[probes]]
name = "tip"
kind = "point_displacement"
body = "post"
at = [0.15, 0.12]
"""


def test_elastic_post_in_still_water_stays_at_rest(tmp_path):
    """A clamped elastic post (rho_s = 1.1 rho_f, added mass several times its own) under
    water, hydrostatic on both sides: its tip stays within 1 % of its width and it does not
    sway. (It starts unstressed, so it rings axially under its weight: vertical speeds of
    ~2 cm/s, tip displacement < 0.2 mm.)"""
    p = tmp_path / "post.toml"
    p.write_text(POST)
    sim = Simulation(load_config(p))
    sim.run(out_dir=None, progress=False)
    sim.check()
    ux, uy = sim.probes[0].sample()[:2]
    assert np.hypot(ux, uy) < 2e-4
    v = sim.structures["post"].body["v"]
    assert np.abs(v[:, 0]).max() < 2e-3


def test_coupled_restart_is_bit_identical(tmp_path):
    """Fluid + walls + coupled post: a run stopped at a snapshot and restarted from its file
    ends exactly where an uninterrupted run ends (every array of every body, the fluid's
    stacked pressures, the probe series), bit for bit."""
    import h5py

    from fsi_sph.__main__ import main
    from fsi_sph.output import read_probe, read_restart

    p = tmp_path / "post.toml"
    p.write_text(POST.replace("t_end = 0.1", "t_end = 0.04\noutput_every = 0.01"))
    assert main(["run", str(p), "--out", str(tmp_path / "full"), "--no-progress"]) == 0
    with h5py.File(tmp_path / "full" / "run.h5", "r") as f:
        steps = sorted(int(g.attrs["step"]) for g in f["snapshots"].values())
    stop = steps[len(steps) // 2]  # a regular snapshot in the middle
    assert 0 < stop < steps[-1]
    assert main(["run", str(p), "--out", str(tmp_path / "part"), "--no-progress",
                 "--max-steps", str(stop)]) == 0
    part = tmp_path / "part" / "run.h5"
    assert main(["run", "--restart", str(part), "--no-progress"]) == 0
    c_full, s_full = read_restart(tmp_path / "full" / "run.h5")
    c_part, s_part = read_restart(part)
    assert c_part["step"] == c_full["step"] and c_part["t"] == c_full["t"]
    assert set(s_part) == set(s_full) and "fluid.extra" in s_full
    for body, arrays in s_full.items():
        for k, v in arrays.items():
            np.testing.assert_array_equal(s_part[body][k], v, err_msg=f"{body}.{k}")
    t1, a1 = read_probe(tmp_path / "full" / "run.h5", "tip")
    t2, a2 = read_probe(part, "tip")
    np.testing.assert_array_equal(t1, t2)
    np.testing.assert_array_equal(a1["ux"], a2["ux"])


def test_structure_root_replaces_the_floor_walls(tmp_path):
    """A coupled structure whose clamped root is set into the floor takes the place of the
    wall particles on its sites; the floor elsewhere keeps its layers."""
    text = CASE.replace('blocks = [{ origin = [0.1, 0.1], size = [0.1, 0.1] }]',
                        'blocks = [{ origin = [0.1, -0.03], size = [0.02, 0.13] }]\n'
                        'clamp = [{ origin = [0.1, -0.03], size = [0.02, 0.03] }]')
    p = tmp_path / "root.toml"
    p.write_text(text)
    sim = Simulation(load_config(p))
    xw = sim.fluid.walls.body["x"]
    xs = sim.structures["block"].body["x"]
    d = np.min(np.hypot(xw[:, None, 0] - xs[None, :, 0], xw[:, None, 1] - xs[None, :, 1]),
               axis=1)
    assert d.min() > 0.5 * 0.01
    floor_under_root = (xw[:, 1] < 0) & (xw[:, 0] > 0.1) & (xw[:, 0] < 0.12)
    assert not floor_under_root.any()
    assert np.sum((xw[:, 1] < 0) & (xw[:, 0] > 0.2) & (xw[:, 0] < 0.22)) == 2 * 3
    # the clamped root closes the floor: the top floor particles right beside it keep an
    # upward normal (over the walls alone it would tilt towards the gap the root fills)
    beside = (np.abs(xw[:, 1] + 0.005) < 1e-9) & (np.abs(xw[:, 0] - 0.095) < 1e-9)
    assert beside.sum() == 1
    n = sim.fluid.wall_n[:len(xw)][beside][0]
    assert np.allclose(n, [0.0, 1.0], atol=1e-9)


def test_fluid_initial_velocity(tmp_path):
    p = tmp_path / "v.toml"
    p.write_text(CASE.replace('dt_max = 1.0e-3', 'dt_max = 1.0e-3\ninitial_velocity = [1.5, -0.5]'))
    sim = Simulation(load_config(p))
    assert np.all(sim.fluid.body["v"] == [1.5, -0.5])


def test_structure_guard_removes_relative_inflow_kernel():
    """One fluid particle 0.3 dx above a flat structure surface (normal +y) moving into it:
    its velocity relative to the surface loses the inward normal part; the change and the
    structure row are reported for the reaction."""
    from fsi_sph.fluid import _kernels as K
    from fsi_sph.neighbors import find_neighbors

    dx = 0.01
    xs = np.array([[k * dx, 0.0] for k in range(-2, 3)])
    x = np.vstack([[[0.001, 0.3 * dx]], xs])
    start, j = find_neighbors(x[:1], x, 2.4 * dx)
    normals = np.tile([0.0, 1.0], (5, 1))
    v_b = np.tile([0.0, -0.5], (5, 1))
    v = np.array([[1.0, -2.0]])
    v_old = v.copy()
    dv = np.zeros((1, 2))
    row = np.zeros(1, dtype=np.int64)
    K.boundary_guard(x, start, j, 1, 1, len(x), normals, v_b, 0.5 * dx, 0.0, v_old, v, dv, row)
    assert np.allclose(v, [[1.0, -0.5]]) and np.allclose(v_old, [[1.0, -0.5]])
    assert np.allclose(dv, [[0.0, 1.5]]) and row[0] == 2  # the particle right below
    # moving away from the surface (relative): untouched
    v = np.array([[0.0, -0.4]])
    K.boundary_guard(x, start, j, 1, 1, len(x), normals, v_b, 0.5 * dx, 0.0, v.copy(), v, dv,
                     row)
    assert np.allclose(v, [[0.0, -0.4]]) and row[0] == -1


def test_structure_guard_gives_the_structure_the_opposite_impulse(tmp_path):
    sim = _scene(tmp_path)
    fluid = sim.fluid
    sim.step()
    dt = 1e-3
    x = fluid.body["x"]
    # fluid right above the block's top face, pushed down into it
    near = (np.abs(x[:, 1] - 0.205) < 0.006) & (x[:, 0] > 0.1) & (x[:, 0] < 0.2)
    assert near.sum() >= 5
    x[near, 1] = 0.1985  # 0.35 dx from the block's surface particles: inside the guard gap
    fluid.sync()
    v = np.zeros((fluid.nf, 2))
    v[near] = [0.3, -1.0]
    fluid.v_old[:] = v
    before = v.copy()
    fluid.kinematic_guard.velocities(dt, v)
    m = fluid.body["m"][:, None]
    assert np.all(v[near, 1] > -1.0)  # the inflow was cut
    fluid_impulse = np.sum(m * (v - before), axis=0)
    structure_impulse = dt * fluid.guard_force.sum(axis=0)
    assert np.abs(fluid_impulse).max() > 0
    assert np.allclose(fluid_impulse + structure_impulse, 0.0, atol=1e-14)


def test_automatic_and_fixed_subcycling_agree():
    """The gate case for its first 0.02 s at dx = 2.5 mm: sub-cycling from the stability
    limits (about 20-30 solid sub-steps per fluid step here) and the source's fixed ratio 100
    give the same tip displacement within 1 %, at a fluid step bounded to 2e-4 s (where the
    fixed ratio is inside the gate's stability limit)."""
    from pathlib import Path

    case = Path(__file__).resolve().parents[2] / "cases" / "dam_break_elastic_gate.toml"
    tips, subs = [], []
    for extra in ([], ["coupling.substeps=100"]):
        cfg = load_config(case, ["case.dx=0.0025", "case.t_end=0.02", "fluid.dt_max=2e-4",
                                 *extra])
        sim = Simulation(cfg)
        n_sub = []
        while sim.t < 0.02 - 1e-12:
            n_sub.append(sim.step(dt_max=0.02 - sim.t)[1]["gate"])
        sim.check()
        ux, uy = sim.probes[0].sample()[:2]
        tips.append(np.hypot(ux, uy))
        subs.append(max(n_sub))
    assert subs[0] < 50 and subs[1] == 100
    assert tips[0] > 2e-3  # the gate has opened by a few millimetres
    assert abs(tips[0] - tips[1]) < 0.01 * tips[1]


def test_a_particle_squeezed_by_a_structure_does_not_leave_through_the_wall(tmp_path):
    """A fluid particle between the floor and a structure coming down on it (the zoo's sinking
    block as it lands): the structure's guard makes it move with the structure, and the
    walls' guard, applied again on the rows the structure moved, stops that step at the
    walls' band (fsi_sph/fluid/kinematic_guard.py, ``walls_again``). Without it the step
    ended 0.8 dx below the floor's surface, past its first wall row."""
    p = tmp_path / "c.toml"
    block = "origin = [0.1, 0.005], size = [0.1, 0.1]"
    p.write_text(CASE.replace("origin = [0.1, 0.1], size = [0.1, 0.1] }]",
                              block + " }]\nclamp = [{ " + block + " }]"))
    sim = Simulation(load_config(p))
    fluid = sim.fluid
    x = fluid.body["x"]
    # the floor row's particles left of the block moved under it (the lattice leaves no
    # room there): 0.7 dx above the top wall row, 0.8 dx below the block's row
    under = np.flatnonzero((x[:, 1] < 0.01) & (x[:, 0] > 0.02) & (x[:, 0] < 0.08))
    assert len(under) >= 4
    x[under] += [0.1, 0.002 - 0.005]
    fluid.sync()
    fluid.update_neighbors()
    ps = fluid
    nf, nwall = ps.nf, ps.nw - ps.ns
    ps.v_b[nwall:] = [0.0, -1.0]  # the block comes down at 1 m/s
    dt = 1e-2
    v = np.zeros((nf, 2))
    ps.v_old[:] = v
    fluid.kinematic_guard.velocities(dt, v)
    end = x[under, 1] + dt * (ps.w_new * v[under, 1] + (1.0 - ps.w_new) * ps.v_old[under, 1])
    floor = -0.005  # the floor's top wall row, y = -dx/2
    assert np.all(v[under, 1] < 0.0)  # pushed down by the block ...
    assert_allclose(end, floor + 0.5 * 0.01, atol=1e-12)  # ... to the walls' band, no further
