"""The rigid-body rows of free structures (``coupling.structure_acceleration = "rigid"``):
the generalised force the PPE sees is the force the structure receives, the low-rank
operator is ``A + U G``, and the option refuses clamped bodies."""

import numpy as np
import pytest
import scipy.sparse as sp

from fsi_sph.config import load_config
from fsi_sph.errors import ConfigError
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
[solid.a]
material = { model = "stvk", rho0 = 2000.0, E = 1.0e7, nu = 0.3 }
blocks = [{ origin = [0.05, 0.1], size = [0.06, 0.03] }, { origin = [0.05, 0.1], size = [0.03, 0.08] }]
[solid.b]
material = { model = "stvk", rho0 = 800.0, E = 1.0e7, nu = 0.3 }
blocks = [{ origin = [0.18, 0.12], size = [0.05, 0.05] }]
[coupling]
structures = ["a", "b"]
structure_acceleration = "rigid"
"""


def _scene(tmp_path, text=CASE):
    p = tmp_path / "c.toml"
    p.write_text(text)
    return Simulation(load_config(p))


THROUGH_SURFACE = CASE.replace('pressure_gradient = "conservative"',
                               'pressure_gradient = "interface_conservative"').replace(
    "origin = [0.18, 0.12], size = [0.05, 0.05]", "origin = [0.18, 0.27], size = [0.05, 0.05]")


@pytest.mark.parametrize("text", [CASE, THROUGH_SURFACE], ids=["submerged", "waterline"])
def test_generalised_force_is_the_structure_force(tmp_path, rng, text):
    """For any pressure field, ``G p`` (the rows' x force, y force and torque about each
    body's centre of mass) equals the sum of the pair forces [F 46-47] that
    ``FsiCoupling.forces`` hands the bodies, and their moment: the solve and the structure
    see the same force (also with body b through the free surface, where the waterline
    rows weight their pair terms by L_f)."""
    sim = _scene(tmp_path, text)
    fl, c = sim.fluid, sim.coupling
    c.before_fluid()
    fl.update_neighbors()
    fl.detect_free_surface()
    assert fl.waterline_rows().any() == (text is THROUGH_SURFACE)
    fl.p_all[:] = rng.uniform(-1e3, 3e3, len(fl.p_all))
    terms = fl.boundary.rigid_terms()
    U, G = terms.U, terms.G()
    c.forces()
    gen = G @ fl.p_all
    _, body_of, mass, inertia, centre = fl.boundary.rigid
    for k, (body, sl) in enumerate(zip(c.bodies, c.slices, strict=True)):
        f = c.on_structure[sl]
        r = body.body["x"] - centre[k]
        torque = np.sum(r[:, 0] * f[:, 1] - r[:, 1] * f[:, 0])
        scale = np.abs(f).sum()
        assert scale > 0
        np.testing.assert_allclose(gen[3 * k:3 * k + 2], f.sum(axis=0), atol=1e-12 * scale)
        assert abs(gen[3 * k + 2] - torque) < 1e-12 * scale
        np.testing.assert_allclose(centre[k], body.body["m"] @ body.body["x"] / mass[k])
    # U only on structure rows, zero columns for the other body's modes
    nb0 = fl.nf + fl.n_walls
    assert not U[:nb0].any()
    sl_a = slice(nb0 + c.slices[0].start, nb0 + c.slices[0].stop)
    assert not U[sl_a, 3:].any() and U[sl_a, :3].any()


def test_rigid_part_of_the_mean_acceleration(tmp_path, rng):
    """``_rigid_split``: a mean acceleration that is a rigid motion (translation plus
    rotation about the centre of mass) is returned whole; a pure deformation with no net
    force or torque gives zero."""
    sim = _scene(tmp_path)
    c = sim.coupling
    body, sl = c.bodies[0], c.slices[0]
    x = body.body["x"]
    xc = body.body["m"] @ x / body.body["m"].sum()
    r = x - xc
    rigid = np.array([0.3, -1.2]) + 2.5 * np.column_stack([-r[:, 1], r[:, 0]])
    c.a_bar[:] = 0.0
    c.a_bar[sl] = rigid
    a_rigid = c._rigid_split()[0]
    np.testing.assert_allclose(a_rigid[sl], rigid, atol=1e-12)
    # a deformation: the rigid fit removed from random accelerations
    c.a_bar[sl] = rng.standard_normal((len(x), 2))
    deform = c.a_bar[sl] - c._rigid_split()[0][sl]
    c.a_bar[sl] = deform
    np.testing.assert_allclose(c._rigid_split()[0][sl], 0.0, atol=1e-12)


def test_low_rank_operator_matches_dense(rng):
    from fsi_sph.fluid import amg

    n, m = 40, 3
    A = sp.random(n, n, density=0.2, random_state=1, format="csr") + 5.0 * sp.eye(n)
    U = rng.standard_normal((n, m))
    G = rng.standard_normal((m, n))
    op = amg.LowRank(amg.as_csr(sp.csr_matrix(A)), U, G)
    x = rng.standard_normal(n)
    b = rng.standard_normal(n)
    dense = A.toarray() + U @ G
    np.testing.assert_allclose(op.matvec(x), dense @ x, rtol=1e-12)
    out = np.empty(n)
    np.testing.assert_allclose(op.residual(x, b, out), b - dense @ x, rtol=1e-12, atol=1e-12)


def test_rigid_refuses_a_clamped_body(tmp_path):
    text = CASE.replace('[solid.b]\n', '[solid.b]\nclamp = [{ origin = [0.18, 0.12], size = '
                        '[0.05, 0.01] }]\n')
    p = tmp_path / "c.toml"
    p.write_text(text)
    with pytest.raises(ConfigError, match="solid.b has a clamp"):
        load_config(p)


CLAMP_A = '[solid.a]\nclamp = [{ origin = [0.05, 0.1], size = [0.06, 0.01] }]\n'
CLAMP_B = '[solid.b]\nclamp = [{ origin = [0.18, 0.12], size = [0.05, 0.01] }]\n'


@pytest.mark.parametrize("clamps, expected", [((), "rigid"), ((CLAMP_A, CLAMP_B), "implicit")])
def test_auto_scheme_follows_the_clamps(tmp_path, clamps, expected):
    text = CASE.replace('structure_acceleration = "rigid"', 'structure_acceleration = "auto"')
    for c in clamps:
        text = text.replace(c.split("\n")[0] + "\n", c)
    p = tmp_path / "c.toml"
    p.write_text(text)
    cfg = load_config(p)
    assert cfg.structure_scheme() == expected
    assert f"fsi_coupling:a,b({expected})" in cfg.modules()


def test_auto_scheme_refuses_clamped_and_free_together(tmp_path):
    text = CASE.replace('structure_acceleration = "rigid"', 'structure_acceleration = "auto"')
    p = tmp_path / "c.toml"
    p.write_text(text.replace("[solid.b]\n", CLAMP_B))
    with pytest.raises(ConfigError, match=r"mixes clamped \(b\) and free \(a\)"):
        load_config(p)
