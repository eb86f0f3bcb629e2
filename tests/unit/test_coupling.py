"""Fluid-structure interface [F 46-48]: pairwise forces cancel, sub-cycle count, averaging."""

import numpy as np
import pytest

from fsi_sph.coupling.fsi import advance_structure, interface_forces, interface_power, substep_count
from fsi_sph.errors import SimulationError
from fsi_sph.neighbors import find_neighbors
from tests.reference_impl import cubic_dw


@pytest.fixture
def interface(rng):
    """A block of 'fluid' beside a plate of 'structure' particles, perturbed, random p."""
    dx = 0.01
    g = np.mgrid[0:20, 0:15].reshape(2, -1).T * dx
    xf = g + 0.002 * rng.standard_normal(g.shape)
    xs = np.mgrid[0:3, 0:15].reshape(2, -1).T * dx + [0.2, 0.0]
    xs = xs + 0.001 * rng.standard_normal(xs.shape)
    return dict(xf=xf, pf=rng.uniform(0, 1e3, len(xf)), vf=np.full(len(xf), dx * dx),
                xs=xs, ps=rng.uniform(0, 1e3, len(xs)), vs=np.full(len(xs), 1.1 * dx * dx),
                h=1.2 * dx)


def _forces(d, scale=1.0, weights=None):
    r = 2 * d["h"]
    sf = find_neighbors(d["xs"], d["xf"], r)
    fs = find_neighbors(d["xf"], d["xs"], r)
    on_s = np.zeros_like(d["xs"])
    on_f = np.zeros_like(d["xf"])
    interface_forces(d["xs"], d["ps"], d["vs"], d["xf"], d["pf"], d["vf"], *sf, *fs, d["h"], 0,
                     scale, on_s, on_f, weights)
    return on_s, on_f


def test_action_equals_reaction(interface):
    on_s, on_f = _forces(interface, scale=1.07)
    assert np.abs(on_s).max() > 0
    total = on_s.sum(axis=0) + on_f.sum(axis=0)
    assert np.all(np.abs(total) < 1e-12 * np.abs(on_s).sum())


@pytest.mark.parametrize("weighted", [False, True])
def test_matches_dense_formula(interface, rng, weighted):
    """F_s = -sum_f V_s V_f (p_s + p_f) M_f grad_s W_sf over all pairs within 2h (M_f the
    identity, or any matrix per fluid particle: the waterline rows' L_f / c); the fluid's
    share is its opposite, pair by pair."""
    d = interface
    nf = len(d["xf"])
    m = np.tile(np.eye(2), (nf, 1, 1))
    if weighted:
        m += 0.3 * rng.standard_normal((nf, 2, 2))
    on_s, on_f = _forces(d, weights=m if weighted else None)
    diff = d["xs"][:, None] - d["xf"][None]
    r = np.linalg.norm(diff, axis=2)
    gw = np.where((r < 2 * d["h"])[..., None],
                  cubic_dw(r, d["h"])[..., None] * diff / r[..., None], 0.0)
    gw = np.einsum("fab,sfb->sfa", m, gw)
    pair = -np.einsum("s,f,sf,sfa->sfa", d["vs"], d["vf"], d["ps"][:, None] + d["pf"][None], gw)
    tol = 1e-12 * np.abs(pair).sum(axis=1).max()
    np.testing.assert_allclose(on_s, pair.sum(axis=1), rtol=1e-12, atol=tol)
    np.testing.assert_allclose(on_f, -pair.sum(axis=0), rtol=1e-12, atol=tol)


def test_uniform_pressure_pushes_normal_to_interface(interface):
    """A uniform fluid pressure on the plate's left face pushes it in +x, no net shear."""
    d = dict(interface, pf=np.full(len(interface["pf"]), 100.0),
             ps=np.full(len(interface["ps"]), 100.0))
    on_s, _ = _forces(d)
    total = on_s.sum(axis=0)
    assert total[0] > 0 and abs(total[1]) < 0.1 * total[0]


def test_substep_count():
    assert substep_count(1e-3, 3e-5) == 34
    assert substep_count(1e-3, 1e-3) == 1
    assert substep_count(1e-3, 5e-3) == 1
    assert substep_count(1e-3, 3e-5, fixed=100) == 100


def test_a_fixed_substep_count_above_the_stability_limit_is_refused_with_the_numbers():
    with pytest.raises(SimulationError, match=r"coupling.substeps = 10 gives gate a solid step "
                       r"of 0.0001 s .* above its stability limit 3e-05 s.*automatic: 34"):
        substep_count(1e-3, 3e-5, fixed=10, name="gate")


def test_advance_structure_averages_velocity(make_body):
    b = make_body(dx=0.05, w=0.5, hgt=0.2, E=1e5)
    b.body["v"][:] = [0.2, 0.1]
    b.body["f_ext"][:] = b.body["m"][:, None] * np.array([1.0, 0.0])  # uniform 1 m/s^2
    vbar = advance_structure(b, 0.01, 7)
    # rigid motion under uniform acceleration: mean velocity over the step = v0 + a dt / 2
    np.testing.assert_allclose(vbar, np.broadcast_to([0.205, 0.1], vbar.shape), rtol=1e-9)
    assert interface_power(b.body["f_ext"], vbar) == pytest.approx(
        float(np.sum(b.body["m"])) * 0.205)
