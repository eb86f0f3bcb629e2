"""Particle collision model (``fluid.collision``; fsi_sph/fluid/_kernels/motion.py
``collision_dv``): approaching fluid pairs closer than the contact distance lose the
approach velocity as in an inelastic collision, with equal and opposite momentum changes."""

import numpy as np
import pytest

from fsi_sph.config import load_config
from fsi_sph.fluid import _kernels as K
from fsi_sph.neighbors import find_neighbors


def _reference(x, v, m, r_c, e):
    """Slow numpy double loop of the same pair rule."""
    dv = np.zeros_like(v)
    for i in range(len(x)):
        for j in range(len(x)):
            d = x[i] - x[j]
            r = np.linalg.norm(d)
            if i == j or r >= r_c:
                continue
            n = d / r
            w = (v[i] - v[j]) @ n
            if w < 0.0:
                dv[i] -= (1.0 + e) * m[j] / (m[i] + m[j]) * w * n
    return dv


def _kernel(x, v, m, r_c, e, n_fluid=None):
    nf = len(x) if n_fluid is None else n_fluid
    start, j = find_neighbors(x[:nf], x, 1.5 * r_c, exclude_self=True)
    fluid_of = np.where(np.arange(len(x)) < nf, np.arange(len(x)), -1)
    dv = np.empty((nf, 2))
    K.collision_dv(x, v, m, start, j, nf, fluid_of, r_c, e, dv)
    return dv


@pytest.mark.parametrize("e", [0.0, 0.3])
def test_matches_reference_and_conserves_momentum(e):
    rng = np.random.default_rng(3)
    x = rng.uniform(0.0, 0.01, (60, 2))
    v = rng.normal(0.0, 1.0, (60, 2))
    m = rng.uniform(0.5, 2.0, 60)
    dv = _kernel(x, v, m, 0.002, e)
    assert np.allclose(dv, _reference(x, v, m, 0.002, e), rtol=1e-12, atol=1e-14)
    assert np.abs(dv).max() > 0.1  # some pairs collided
    assert np.allclose((m[:, None] * dv).sum(axis=0), 0.0, atol=1e-12)


def test_one_pair_head_on():
    x = np.array([[0.0, 0.0], [0.0004, 0.0003]])  # 0.5 mm apart
    n = (x[0] - x[1]) / 0.0005
    v = np.array([-1.0 * n, 0.5 * n]) + np.array([0.2, -0.7])  # closing at 1.5 m/s + drift
    m = np.array([1.0, 3.0])
    for e in (0.0, 0.5):
        u = v + _kernel(x, v, m, 0.001, e)
        assert (u[0] - u[1]) @ n == pytest.approx(e * 1.5, abs=1e-12)  # approach reversed by e
        assert np.allclose(m @ u, m @ v, atol=1e-12)
        t = np.array([-n[1], n[0]])
        assert np.allclose(u @ t, v @ t, atol=1e-12)  # tangential velocities untouched


def test_separating_distant_and_boundary_pairs_untouched():
    x = np.array([[0.0, 0.0], [0.0005, 0.0], [0.003, 0.0], [0.0, 0.0004]])
    v = np.array([[-1.0, 0.0], [1.0, 0.0], [-5.0, 0.0], [0.0, -3.0]])
    m = np.ones(4)
    # 0-1 separate; 2 is beyond the contact distance; 3 is a boundary row (j >= nf)
    dv = _kernel(x, v, m, 0.001, 0.0, n_fluid=3)
    assert np.array_equal(dv, np.zeros((3, 2)))


def test_case_section():
    text = """
[case]
t_end = 0.1
dx = 0.01
[fluid]
blocks = [{ origin = [0.0, 0.0], size = [0.1, 0.1] }]
collision = { restitution = 0.2 }
[fluid.material]
rho0 = 1000.0
"""
    c = load_config(None, text=text).fluid.collision
    assert (c.distance, c.restitution) == (0.5, 0.2)
    with pytest.raises(Exception, match="distance"):
        load_config(None, text=text.replace("restitution = 0.2", "distance = 1.5"))


def test_periodic_images_collide_with_their_originals_velocities():
    """A row that is the periodic image of fluid particle k (``fluid_of[row] = k``) collides
    with k's velocity and mass at the image's position; the pair seen from k (through the
    image of i) gives the opposite momentum change."""
    period = 0.01
    x = np.array([[0.0002, 0.0], [0.0097, 0.0]])  # 0.5 mm apart across the seam
    v = np.array([[-1.0, 0.0], [1.0, 0.0]])       # approaching across the seam
    m = np.array([1.0, 2.0])
    xs = np.vstack([x, x[1] - [period, 0.0], x[0] + [period, 0.0]])  # images of 1, 0
    fluid_of = np.array([0, 1, 1, 0])
    start, j = find_neighbors(xs[:2], xs, 0.0015, exclude_self=True)
    dv = np.empty((2, 2))
    K.collision_dv(xs, v, m, start, j, 2, fluid_of, 0.001, 0.0, dv)
    u = v + dv
    assert u[0, 0] == pytest.approx(u[1, 0], abs=1e-12)  # approach removed (e = 0)
    assert np.allclose(m @ u, m @ v, atol=1e-12)
