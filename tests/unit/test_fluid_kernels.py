"""Every numba loop of fsi_sph.fluid._kernels against a dense numpy oracle (or an exact
answer) on a perturbed lattice."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from fsi_sph.fluid import _kernels as K
from fsi_sph.fluid.free_surface import blend, detect
from fsi_sph.fluid.ppe import assemble
from fsi_sph.neighbors import find_neighbors
from tests import fluid_reference as ref
from tests.conftest import lattice

H = 1.2
KIND = 0


def nbrs(x, nrows=None):
    nrows = len(x) if nrows is None else nrows
    return find_neighbors(x[:nrows], x, 2 * H, exclude_self=True)


def test_position_divergence_matches_oracle(perturbed):
    x = perturbed
    vol = np.full(len(x), 1.0)
    s, j = nbrs(x)
    divr, gc, sig = np.zeros(len(x)), np.zeros((len(x), 2)), np.zeros(len(x))
    K.position_divergence(x, vol, s, j, H, KIND, divr, gc, sig)
    d_ref, g_ref = ref.position_divergence(x, vol, H, len(x))
    assert_allclose(divr, d_ref, rtol=1e-12, atol=1e-14)
    assert_allclose(gc, g_ref, rtol=1e-12, atol=1e-14)


def test_velocity_divergence_and_gradients_match_oracle(perturbed):
    rng = np.random.default_rng(1)
    x = perturbed
    n = len(x)
    nf = 90  # the last rows act as walls (sources only)
    vol = rng.uniform(0.8, 1.2, n)
    v = rng.normal(size=(n, 2))
    p = rng.normal(size=n)
    s, j = nbrs(x, nf)
    out = np.zeros(nf)
    K.velocity_divergence(x, v, vol, s, j, nf, H, KIND, 1.01, out)
    assert_allclose(out, ref.velocity_divergence(x, v, vol, H, nf, 1.01), rtol=1e-12, atol=1e-13)
    g = np.zeros((nf, 2))
    K.pressure_gradient(x, p, vol, s, j, nf, H, KIND, 1.01, len(x), np.zeros(len(x), bool), np.ones(nf, bool), np.zeros((len(x), 2)), g)
    assert_allclose(g, ref.conservative_gradient(x, p, vol, H, nf, 1.01), rtol=1e-12, atol=1e-13)
    L = np.zeros((nf, 2, 2))
    K.correction_matrices(x, vol, s, j, H, KIND, L)
    assert_allclose(L, ref.correction(x, vol, H, nf), rtol=1e-12, atol=1e-13)
    K.corrected_pressure_gradient(x, p, vol, L, s, j, nf, H, KIND, len(x), np.zeros(len(x), bool), np.ones(nf, bool), np.zeros((len(x), 2)), g)
    assert_allclose(g, ref.corrected_gradient(x, p, vol, H, nf), rtol=1e-12, atol=1e-13)
    nu = rng.uniform(1e-3, 2e-3, n)
    vs = np.zeros((nf, 2))
    K.predict_velocity(x, v, vol, nu, s, j, nf, H, KIND, 0.0144, 0.1, -9.81, 0.01, vs)
    want = ref.predict_velocity(x, v, vol, nu, H, nf, 0.0144, np.array([0.1, -9.81]), 0.01)
    assert_allclose(vs, want, rtol=1e-12, atol=1e-13)


def test_corrected_gradients_exact_for_linear_fields(perturbed):
    x = perturbed
    n = len(x)
    vol = np.ones(n)
    s, j = nbrs(x)
    L = np.zeros((n, 2, 2))
    K.correction_matrices(x, vol, s, j, H, KIND, L)
    p = 3.0 * x[:, 0] - 2.0 * x[:, 1] + 1.0
    v = np.column_stack([x[:, 1], 2.0 * x[:, 0]])
    gp, gv = np.zeros((n, 2)), np.zeros((n, 2, 2))
    K.gradients(x, p, v, vol, L, s, j, n, H, KIND, gp, gv, -1)
    ok = np.abs(np.linalg.det(L)) > 0  # every row here has a full-rank moment
    assert_allclose(gp[ok], np.tile([3.0, -2.0], (ok.sum(), 1)), atol=1e-10)
    assert_allclose(gv[ok], np.tile([[0.0, 1.0], [2.0, 0.0]], (ok.sum(), 1, 1)), atol=1e-10)


def test_free_slip_velocity_gradient_ignores_boundary_velocity(perturbed):
    """``jv``: sources from ``jv`` on (walls) carry no velocity difference, whatever their
    velocity; the pressure gradient still uses them. Compared with a gradient where those
    sources are given each row's own velocity (the same thing, written out)."""
    x = perturbed
    n = len(x)
    nf = 90
    vol = np.ones(n)
    s, j = nbrs(x, nf)
    L = np.zeros((nf, 2, 2))
    K.correction_matrices(x, vol, s, j, H, KIND, L)
    p = 3.0 * x[:, 0] - 2.0 * x[:, 1]
    v = np.column_stack([np.full(n, 2.0), np.zeros(n)])
    v[nf:] = 0.0  # no-slip wall velocity: the sheared gradient we want to avoid
    gp, gv = np.zeros((nf, 2)), np.zeros((nf, 2, 2))
    K.gradients(x, p, v, vol, L, s, j, nf, H, KIND, gp, gv, nf)
    # uniform fluid velocity + free-slip walls: no velocity gradient at all
    assert np.abs(gv).max() < 1e-12
    gp_all, gv_all = np.zeros((nf, 2)), np.zeros((nf, 2, 2))
    K.gradients(x, p, v, vol, L, s, j, nf, H, KIND, gp_all, gv_all, -1)
    assert_allclose(gp, gp_all, rtol=1e-12, atol=1e-12)
    touched = np.array([np.any(j[s[i]:s[i + 1]] >= nf) for i in range(nf)])
    assert touched.any() and np.abs(gv_all[touched]).max() > 1.0  # the no-slip shear


def test_ppe_assembly_matches_dense_oracle(perturbed):
    rng = np.random.default_rng(3)
    x = perturbed
    n = len(x)
    nf = 90
    nw = n - nf
    vol = np.ones(n)
    fs, fj = nbrs(x, nf)
    ws, wj = find_neighbors(x[nf:], x[:nf], 2 * H)
    alpha = rng.uniform(0.0, 1.0, nf)
    alpha[:10] = 0.0
    alpha[10:40] = 1.0
    source = rng.normal(size=nf)
    consistent = rng.uniform(size=nf) < 0.5
    L = np.zeros((nf, 2, 2))
    K.correction_matrices(x, vol, fs, fj, H, KIND, L)
    g = np.array([0.0, -9.81])
    A, b = assemble(x, vol, alpha, source, L, consistent, fs, fj, ws, wj, nf, nw, H, KIND,
                    0.0144, 1.02, 7.0, 1000.0, np.tile(g, (nw, 1)))
    A_ref, b_ref = ref.ppe_dense(x, vol, alpha, source, consistent, nf, H, 0.0144, 1.02, 7.0,
                                 1000.0, g)
    assert A.has_sorted_indices
    assert np.all(np.diff(A.indices[A.indptr[5]:A.indptr[6]]) > 0)
    assert_allclose(A.toarray(), A_ref, rtol=1e-12, atol=1e-12)
    assert_allclose(b, b_ref, rtol=1e-12, atol=1e-9)


def test_consistent_laplacian_rows_are_exact_for_a_linear_field(perturbed):
    """``fluid.laplacian = "consistent"`` sets every fluid row consistent: on the perturbed
    lattice the rows' Laplacian of a linear field (a hydrostatic pressure) is 0 to round-off,
    while the plain Morris sum is not (the defect that let still water blow up: the
    hydrostatic pressure at displaced particles then drives them)."""
    x = perturbed
    n = len(x)
    nf = n
    vol = np.ones(n)
    fs, fj = nbrs(x, nf)
    L = np.zeros((nf, 2, 2))
    K.correction_matrices(x, vol, fs, fj, H, KIND, L)
    p = 3.0 - 2.0 * x[:, 0] + 5.0 * x[:, 1]
    interior = (np.diff(fs) >= 18)  # full supports on the perturbed lattice
    out = {}
    for flag in (True, False):
        A, _ = assemble(x, vol, np.ones(nf), np.zeros(nf), L, np.full(nf, flag), fs, fj,
                        np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64), nf, 0, H,
                        KIND, 0.0144, 1.02, 7.0, 1000.0, np.zeros((0, 2)))
        out[flag] = (A @ p)[interior]
    assert interior.sum() > 10
    assert np.abs(out[True]).max() < 1e-9 * np.abs(p).max()
    assert np.abs(out[False]).max() > 1e-3


def _above_a_floor(xf):
    """Fluid particles ``xf`` over a wall of three layers (top layer at y = -0.5): stacked
    positions, wall positions, wall normals and the fluid rows' neighbour lists."""
    xw = lattice(10, 3, origin=(0.0, -3.0))
    x = np.vstack([xf, xw])
    nf = len(xf)
    ws, wj = find_neighbors(xw, xw, 2 * H, exclude_self=True)
    wn = np.zeros((len(xw), 2))
    K.wall_normals(xw, np.ones(len(xw)), ws, wj, H, KIND, wn)
    s, j = nbrs(x, nf)
    return x, xw, wn, s, j


def test_guard_sweep_follows_the_damped_position_update():
    """With ``w_new = 1.5`` (``fluid.position_update = "damped"``) the guard predicts the
    step ``dt (1.5 v - 0.5 v_old)`` and scales it to end on the band's edge."""
    x, xw, wn, s, j = _above_a_floor([[5.0, 0.7]])  # 1.2 above the wall layer
    nf = 1
    dt = 0.5
    v_old = np.array([[1.0, -0.5]])
    v = np.array([[1.0, -2.0]])  # damped step 0.5 (1.5 * -2 + 0.25) = -1.375, trapezoid -0.625
    dv, row = np.zeros((nf, 2)), np.zeros(nf, dtype=np.int64)
    K.boundary_guard(x, s, j, nf, nf, len(x), wn, np.zeros((len(xw), 2)), 0.5, dt, v_old, v,
                     dv, row, False, 1.5)
    end = x[0, 1] + dt * (1.5 * v[0, 1] - 0.5 * v_old[0, 1])
    assert_allclose(end, -0.5 + 0.5, atol=1e-12)  # on the band's edge
    assert row[0] >= 0
    v_old = np.array([[1.0, -0.5]])
    v = np.array([[1.0, -2.0]])
    K.boundary_guard(x, s, j, nf, nf, len(x), wn, np.zeros((len(xw), 2)), 0.5, dt, v_old, v,
                     dv, row)  # the trapezoid's step (-0.625) ends outside the band
    assert row[0] == -1
    assert_allclose(v, [[1.0, -2.0]])


def test_blend_is_continuous_and_bounded():
    d = np.linspace(1.0, 2.0, 1001)
    a = blend(d)
    assert a[0] == 0.0 and a[-1] == 1.0
    assert np.all(np.diff(a) >= 0)
    assert np.max(np.abs(np.diff(a))) < 0.01
    assert blend(np.array([1.5]))[0] == pytest.approx(0.5)


def test_free_surface_flags_exactly_the_outer_layer_of_a_square_block():
    x = lattice(20, 20)
    n = len(x)
    vol = np.ones(n)
    s, j = nbrs(x)
    divr, gc, sig, alpha = np.zeros(n), np.zeros((n, 2)), np.zeros(n), np.zeros(n)
    cls, nrm = np.zeros(n, dtype=np.int8), np.zeros((n, 2))
    detect(x, vol, s, j, n, H, KIND, divr, gc, sig, alpha, cls, nrm)
    outer = (x[:, 0] < 1) | (x[:, 0] > 19) | (x[:, 1] < 1) | (x[:, 1] > 19)
    assert np.array_equal(cls == K.SURFACE, outer)
    assert np.all(alpha[outer] == 0.0)
    assert np.all(alpha[~outer] == 1.0)
    # normals of the middle of the left side point to -x
    left = (x[:, 0] < 1) & (x[:, 1] > 3) & (x[:, 1] < 17)
    assert_allclose(nrm[left], np.tile([-1.0, 0.0], (left.sum(), 1)), atol=1e-12)
    # the second layer is near-surface, with its nearest surface neighbour's normal
    second = (x[:, 0] > 1) & (x[:, 0] < 2) & (x[:, 1] > 3) & (x[:, 1] < 17)
    assert np.all(cls[second] == K.NEAR_SURFACE)
    assert_allclose(nrm[second], np.tile([-1.0, 0.0], (second.sum(), 1)), atol=1e-12)


@pytest.mark.parametrize("model", [0, 1, 2])
def test_surface_particles_never_shift_along_their_normal(model):
    rng = np.random.default_rng(11)
    x = lattice(16, 16) + rng.uniform(-0.15, 0.15, (256, 2))
    n = len(x)
    vol = np.ones(n)
    v = rng.normal(size=(n, 2))
    s, j = nbrs(x)
    divr, gc, sig, alpha = np.zeros(n), np.zeros((n, 2)), np.zeros(n), np.zeros(n)
    cls, nrm = np.zeros(n, dtype=np.int8), np.zeros((n, 2))
    detect(x, vol, s, j, n, H, KIND, divr, gc, sig, alpha, cls, nrm)
    dr = np.zeros((n, 2))
    K.shift_vectors(x, v, vol, s, j, n, H, KIND, model, 0.5, 0.1, 0.2 * H, cls, nrm, dr)
    surf = (cls == K.SURFACE) | (cls == K.NEAR_SURFACE)
    assert surf.sum() > 40
    assert np.max(np.abs(np.einsum("ij,ij->i", dr[surf], nrm[surf]))) < 1e-15
    inner = cls == K.INTERIOR
    assert np.max(np.hypot(*dr[inner].T)) > 1e-4  # interior particles do shift
    assert np.max(np.hypot(*dr.T)) <= 0.2 * H * (1 + 1e-12)


def test_apply_shift_taylor_corrects_linear_fields():
    x = np.array([[0.0, 0.0], [1.0, 1.0]])
    dr = np.array([[0.1, -0.2], [0.0, 0.05]])
    gp = np.array([[2.0, 3.0], [1.0, 1.0]])
    gv = np.zeros((2, 2, 2))
    gv[:, 0, 1] = 1.0
    p = np.array([1.0, 2.0])
    v = np.zeros((2, 2))
    lo, hi = np.full((2, 3), -np.inf), np.full((2, 3), np.inf)
    K.apply_shift(dr, gp, gv, True, lo, hi, x, p, v)
    assert_allclose(x, [[0.1, -0.2], [1.0, 1.05]])
    assert_allclose(p, [1.0 + 0.2 - 0.6, 2.05])
    assert_allclose(v, [[-0.2, 0.0], [0.05, 0.0]])


def test_taylor_energy_cap_makes_no_kinetic_energy():
    """``energy_cap``: a correction that would make a particle faster is scaled back to its
    speed before the shift (direction kept); one that slows it is left as it is."""
    x = np.zeros((2, 2))
    dr = np.array([[0.5, 0.0], [-0.5, 0.0]])
    gv = np.zeros((2, 2, 2))
    gv[:, 0, 0] = 1.0  # du/dx = 1: the shift +0.5 speeds particle 0 up, -0.5 slows 1 down
    gv[:, 1, 0] = 1.0  # dv/dx = 1
    lo, hi = np.full((2, 3), -np.inf), np.full((2, 3), np.inf)
    for cap in (False, True):
        v = np.array([[1.0, 0.0], [1.0, 0.0]])
        K.apply_shift(dr, np.zeros((2, 2)), gv, True, lo, hi, x.copy(), np.zeros(2), v, cap)
        if cap:
            assert_allclose(v[0], np.array([1.5, 0.5]) / np.hypot(1.5, 0.5), atol=1e-14)
        else:
            assert_allclose(v[0], [1.5, 0.5])
        assert_allclose(v[1], [0.5, -0.5])  # slower than before: untouched either way


def test_taylor_correction_stays_within_the_neighbourhood_range(perturbed):
    """Linear fields are corrected exactly (the limiter does not act inside their range); an
    outlier (one particle far faster than its neighbours, shifted away from them) is not
    extrapolated beyond the neighbourhood's range."""
    x = perturbed.copy()
    n = len(x)
    vol = np.ones(n)
    s, j = nbrs(x)
    L = np.zeros((n, 2, 2))
    K.correction_matrices(x, vol, s, j, H, KIND, L)
    p = 3.0 * x[:, 0] - 2.0 * x[:, 1]
    v = np.column_stack([x[:, 1], 2.0 * x[:, 0]])
    i = int(np.argmin(np.hypot(x[:, 0] - 6.0, x[:, 1] - 5.0)))  # an interior particle
    for outlier in (False, True):
        pp, vv, xx = p.copy(), v.copy(), x.copy()
        if outlier:  # a fast jet below and at i, slow fluid above
            vv[x[:, 1] < x[i, 1] + 0.3, 1] = 50.0
        gp, gv = np.zeros((n, 2)), np.zeros((n, 2, 2))
        K.gradients(xx, pp, vv, vol, L, s, j, n, H, KIND, gp, gv, -1)
        lo, hi = np.zeros((n, 3)), np.zeros((n, 3))
        K.neighbour_bounds(pp, vv, s, j, n, -1, lo, hi)
        dr = np.zeros((n, 2))
        dr[i] = [0.0, -0.1] if not outlier else [0.0, -0.5]
        unlimited = vv[i, 1] + gv[i, 1, 1] * dr[i, 1]
        K.apply_shift(dr, gp, gv, True, lo, hi, xx, pp, vv)
        if not outlier:
            assert_allclose(vv[i], [x[i, 1] - 0.1, 2.0 * x[i, 0]], atol=1e-10)
            assert_allclose(pp[i], 3.0 * x[i, 0] - 2.0 * (x[i, 1] - 0.1), atol=1e-10)
        else:
            assert unlimited > 55.0  # the extrapolation overshoots the jet's own speed
            assert vv[i, 1] == 50.0  # clamped to the neighbourhood's largest


def test_wall_guard_removes_only_inward_velocity():
    # a floor of wall particles at y = -0.5, -1.5, -2.5 and fluid particles above
    xw = lattice(10, 3, origin=(0.0, -3.0))
    xf = np.array([[5.0, 0.2], [5.0, 0.2], [5.0, 1.0]])
    x = np.vstack([xf, xw])
    nf = 3
    vol = np.ones(len(x))
    ws, wj = find_neighbors(xw, xw, 2 * H, exclude_self=True)
    wn = np.zeros((len(xw), 2))
    K.wall_normals(xw, vol[nf:], ws, wj, H, KIND, wn)
    mid = (xw[:, 1] > -1) & (xw[:, 0] > 2) & (xw[:, 0] < 8)
    assert_allclose(wn[mid], np.tile([0.0, 1.0], (mid.sum(), 1)), atol=1e-12)
    s, j = nbrs(x, nf)
    v = np.array([[1.0, -2.0], [1.0, 2.0], [1.0, -2.0]])
    v_old = v.copy()
    vb = np.zeros((len(xw), 2))
    dv = np.zeros((nf, 2))
    row = np.zeros(nf, dtype=np.int64)
    K.boundary_guard(x, s, j, nf, nf, len(x), wn, vb, 0.5, 0.0, v_old, v, dv, row)
    # 0.7 above the top wall layer: inside the 0.5 gap? no (0.7 > 0.5) -> untouched
    assert_allclose(v, [[1.0, -2.0], [1.0, 2.0], [1.0, -2.0]])
    x[0, 1] = -0.1  # 0.4 above the wall layer, moving down: loses the normal part
    K.boundary_guard(x, s, j, nf, nf, len(x), wn, vb, 0.5, 0.0, v_old, v, dv, row)
    assert_allclose(v[0], [1.0, 0.0], atol=1e-12)
    assert_allclose(dv[0], [0.0, 2.0], atol=1e-12)
    assert row[0] >= 0
    assert_allclose(v_old[0], [1.0, 0.0], atol=1e-12)


def test_guard_sweeps_a_long_step_to_the_gap():
    """A particle outside the guard's band whose step would end inside it (or past the wall)
    has its normal velocities scaled so that the step ends on the band's edge; its
    tangential velocity and a step that ends outside the band are untouched."""
    x, xw, wn, s, j = _above_a_floor([[5.0, 0.7], [3.0, 0.7]])  # 1.2 above the wall layer
    nf = 2
    dt = 0.5
    v_old = np.array([[1.0, -3.0], [1.0, -0.8]])  # step -1.25: through the band; -0.35: not
    v = np.array([[1.0, -2.0], [1.0, -0.6]])
    dv, row = np.zeros((nf, 2)), np.zeros(nf, dtype=np.int64)
    K.boundary_guard(x, s, j, nf, nf, len(x), wn, np.zeros((len(xw), 2)), 0.5, dt, v_old, v,
                     dv, row)
    end = x[:nf, 1] + 0.5 * dt * (v_old[:, 1] + v[:, 1])
    assert_allclose(end[0], -0.5 + 0.5, atol=1e-12)  # on the band's edge
    assert_allclose(v[0], [1.0, -2.0 * 0.7 / 1.25], atol=1e-12)  # both scaled alike
    assert_allclose(v_old[0], [1.0, -3.0 * 0.7 / 1.25], atol=1e-12)
    assert_allclose(dv[0], [0.0, 2.0 - 2.0 * 0.7 / 1.25], atol=1e-12)
    assert row[0] >= 0
    assert_allclose(v[1], [1.0, -0.6])
    assert row[1] == -1
    # a displacement (the shift) swept with dt = 1: v_old a copy of v
    dr = np.array([[0.3, -2.0], [0.0, 0.1]])
    K.boundary_guard(x, s, j, nf, nf, len(x), wn, np.zeros((len(xw), 2)), 0.5, 1.0, dr.copy(),
                     dr, dv, row)
    assert_allclose(x[0, 1] + dr[0, 1], 0.0, atol=1e-12)
    assert_allclose(dr[0, 0], 0.3)
    assert_allclose(dr[1], [0.0, 0.1])


def test_guard_uses_nearest_surface_particle_past_the_surface_layer():
    """A fluid particle that has got between the surface layer and an interior boundary
    particle (zero normal) is still guarded, by the surface layer's normal."""
    xw = lattice(10, 3, origin=(0.0, -3.0))  # layers at y = -0.5, -1.5, -2.5
    xf = np.array([[5.0, -1.2]])  # nearer the second layer (-1.5) than the surface (-0.5)
    x = np.vstack([xf, xw])
    vol = np.ones(len(x))
    ws, wj = find_neighbors(xw, xw, 2 * H, exclude_self=True)
    wn = np.zeros((len(xw), 2))
    K.wall_normals(xw, vol[1:], ws, wj, H, KIND, wn)
    wn[np.abs(xw[:, 1] + 1.5) < 1e-9] = 0.0  # the middle layer: interior, no normal
    s, j = nbrs(x, 1)
    v, v_old = np.array([[0.5, -1.0]]), np.array([[0.5, -1.0]])
    dv, row = np.zeros((1, 2)), np.zeros(1, dtype=np.int64)
    K.boundary_guard(x, s, j, 1, 1, len(x), wn, np.zeros((len(xw), 2)), 0.5, 0.0, v_old, v,
                     dv, row)
    assert_allclose(v[0], [0.5, 0.0], atol=1e-12)
    assert np.abs(xw[row[0], 1] + 0.5) < 1e-9  # the surface layer took the reaction


def test_shift_never_moves_a_particle_into_a_structure(tmp_path):
    """The shift's inward part is removed within the guard distance (2h/3) of a coupled
    structure's surface, and within dx/2 of a wall."""
    from fsi_sph.config import load_config
    from fsi_sph.simulation import Simulation

    text = """
[case]
t_end = 0.01
dx = 0.01
[fluid]
material = { rho0 = 1000.0 }
blocks = [{ origin = [0.0, 0.0], size = [0.2, 0.1] }]
pressure_gradient = "conservative"
[fluid.shifting]
model = "fickian_fixed"
coefficient = 0.5
[walls]
tanks = [{ origin = [0.0, 0.0], size = [0.3, 0.2] }]
[solid.post]
material = { rho0 = 1000.0, E = 1.0e6, nu = 0.3 }
blocks = [{ origin = [0.2, 0.0], size = [0.03, 0.1] }]
clamp = [{ origin = [0.2, 0.0], size = [0.03, 0.1] }]
[coupling]
structures = ["post"]
"""
    sim = Simulation(load_config(None, text=text))
    fl = sim.fluid
    fl.body["x"][:, 0] += 0.003 * (fl.body["x"][:, 0] > 0.185)  # last column 0.7 dx off
    fl.sync()
    dr = np.tile([0.002, -0.001], (fl.nf, 1))  # a shift into the post (and the floor)
    fl.kinematic_guard.shift(dr)
    x = fl.body["x"]
    near_post = (x[:, 0] > 0.185) & (x[:, 1] > 0.02) & (x[:, 1] < 0.08)
    assert near_post.sum() >= 5
    assert_allclose(dr[near_post], np.tile([0.0, -0.001], (near_post.sum(), 1)), atol=1e-12)
    on_floor = (x[:, 1] < 0.01) & (x[:, 0] > 0.05) & (x[:, 0] < 0.15)
    # the floor row sits 1 dx above the wall layer, beyond the walls' dx/2: it keeps its shift
    assert_allclose(dr[on_floor], np.tile([0.002, -0.001], (on_floor.sum(), 1)))
    far = (np.abs(x[:, 0] - 0.1) < 0.03) & (np.abs(x[:, 1] - 0.05) < 0.02)
    assert_allclose(dr[far], np.tile([0.002, -0.001], (far.sum(), 1)))


def test_shepard_interpolation_of_a_constant():
    x = lattice(6, 6)
    p = np.full(len(x), 5.0)
    pts = np.array([[3.0, 3.0], [100.0, 100.0]])
    s, j = find_neighbors(pts, x, 2 * H)
    out = np.zeros(2)
    K.shepard_at(pts, x, p, s, j, H, KIND, out)
    assert out[0] == pytest.approx(5.0)
    assert np.isnan(out[1])


def test_smagorinsky_viscosity_of_simple_shear():
    gv = np.zeros((1, 2, 2))
    gv[0, 0, 1] = 2.0  # du/dy = 2: S01 = 1, sqrt(2 S:S) = 2
    nu = np.zeros(1)
    K.smagorinsky(gv, 0.01, 1e-6, nu)
    assert nu[0] == pytest.approx(1e-6 + 0.02)


def _floored(x, p, i, lo, hi, rg):
    """p as fluid row i sees it with the wall floor: walls lo..hi at least p_i carried
    hydrostatically (rho g . (x_w - x_i))."""
    q = p.copy()
    q[lo:hi] = np.maximum(p[lo:hi], p[i] + (x[lo:hi] - x[i]) @ rg)
    return q


@pytest.mark.parametrize("rg", [(0.0, 0.0), (0.0, -9810.0)])
def test_wall_floor_matches_oracle(perturbed, rg):
    """The walls that cannot pull (tension cut-off): each fluid row's gradient equals the
    oracle's with the walls' pressures floored at the row's own (hydrostatically carried)."""
    rng = np.random.default_rng(2)
    x = perturbed
    n, nf = len(x), 90  # rows nf.. are walls
    vol = rng.uniform(0.8, 1.2, n)
    p = rng.normal(size=n) * 1e3
    s, j = nbrs(x, nf)
    L = np.zeros((nf, 2, 2))
    K.correction_matrices(x, vol, s, j, H, KIND, L)
    rgv = np.array(rg)
    for corrected in (True, False):
        g = np.zeros((nf, 2))
        if corrected:
            K.corrected_pressure_gradient(x, p, vol, L, s, j, nf, H, KIND, n, np.arange(n) >= nf, np.ones(nf, bool), np.tile(rg, (n, 1)), g)
        else:
            K.pressure_gradient(x, p, vol, s, j, nf, H, KIND, 1.01, n, np.arange(n) >= nf, np.ones(nf, bool), np.tile(rg, (n, 1)), g)
        changed = 0
        for i in range(nf):
            q = _floored(x, p, i, nf, n, rgv)
            changed += not np.array_equal(q, p)
            want = (ref.corrected_gradient(x, q, vol, H, nf) if corrected
                    else ref.conservative_gradient(x, q, vol, H, nf, 1.01))[i]
            assert_allclose(g[i], want, rtol=1e-10, atol=1e-9)
        assert changed > 10


def test_wall_floor_row_mask_leaves_the_other_rows_unfloored(perturbed):
    """``floor_row``: the rows it marks see the floored walls, the others the walls as they
    are (the same oracle as above on the marked rows, the plain one elsewhere)."""
    rng = np.random.default_rng(4)
    x = perturbed
    n, nf = len(x), 90
    vol = rng.uniform(0.8, 1.2, n)
    p = rng.normal(size=n) * 1e3
    s, j = nbrs(x, nf)
    L = np.zeros((nf, 2, 2))
    K.correction_matrices(x, vol, s, j, H, KIND, L)
    rg = np.array([0.0, -9810.0])
    mask = rng.random(nf) < 0.5
    g = np.zeros((nf, 2))
    K.corrected_pressure_gradient(x, p, vol, L, s, j, nf, H, KIND, n, np.arange(n) >= nf, mask, np.tile(rg, (n, 1)), g)
    floored_rows = 0
    for i in range(nf):
        q = _floored(x, p, i, nf, n, rg) if mask[i] else p
        floored_rows += mask[i] and not np.array_equal(q, p)
        assert_allclose(g[i], ref.corrected_gradient(x, q, vol, H, nf)[i], rtol=1e-10, atol=1e-9)
    assert floored_rows > 5


def test_wall_floor_pushes_a_particle_off_the_wall_and_keeps_hydrostatics():
    """A fluid particle at dx/2 above a floor of wall particles, its pressure far above the
    walls' (the tip of a granular front): without the floor its gradient pushes it into
    the floor, with it away. A hydrostatic field is left exactly as it is."""
    wall = lattice(8, 3, 1.0, origin=(-4.0, -3.0))  # rows at y = -0.5, -1.5, -2.5
    fluid = lattice(8, 2, 1.0, origin=(-4.0, 0.0))  # rows at y = 0.5, 1.5
    x = np.vstack([fluid, wall])
    nf, n = len(fluid), len(x)
    vol = np.ones(n)
    s, j = nbrs(x, nf)
    L = np.zeros((nf, 2, 2))
    K.correction_matrices(x, vol, s, j, H, KIND, L)
    i = int(np.argmin(np.abs(fluid[:, 0]) + np.abs(fluid[:, 1] - 0.5)))
    p = np.zeros(n)
    p[i] = 100.0
    g = np.zeros((nf, 2))
    K.corrected_pressure_gradient(x, p, vol, L, s, j, nf, H, KIND, n, np.zeros(n, bool), np.ones(nf, bool), np.zeros((len(x), 2)), g)
    assert g[i, 1] > 0.0  # -grad p points down: into the floor
    K.corrected_pressure_gradient(x, p, vol, L, s, j, nf, H, KIND, n, np.arange(n) >= nf, np.ones(nf, bool), np.zeros((len(x), 2)), g)
    assert g[i, 1] < 0.0
    rg = np.array([0.0, -9.81])
    ph = 50.0 + x @ rg  # hydrostatic p0 + rho g . x (rho = 1), surface above
    g0, g1 = np.zeros((nf, 2)), np.zeros((nf, 2))
    K.corrected_pressure_gradient(x, ph, vol, L, s, j, nf, H, KIND, n, np.zeros(n, bool), np.ones(nf, bool), np.zeros((len(x), 2)), g0)
    K.corrected_pressure_gradient(x, ph, vol, L, s, j, nf, H, KIND, n, np.arange(n) >= nf, np.ones(nf, bool), np.tile(rg, (n, 1)), g1)
    assert_allclose(g1, g0, rtol=1e-12, atol=1e-9)


def test_fluid_sublists_keep_the_chosen_rows_fluid_neighbours_in_order(perturbed):
    x = perturbed
    s, j = nbrs(x)
    rng = np.random.default_rng(3)
    fluid_of = np.where(rng.random(len(x)) < 0.7, np.arange(len(x)), -1)
    rows = rng.random(len(x)) < 0.4
    start = np.empty(len(x) + 1, dtype=np.int64)
    out = K.fluid_sublists(s, j, fluid_of, rows, start)
    for i in range(len(x)):
        seg = j[s[i]:s[i + 1]]
        want = seg[fluid_of[seg] >= 0] if rows[i] else seg[:0]
        assert np.array_equal(out[start[i]:start[i + 1]], want)
    assert start[-1] == len(out)


def test_fluid_neighbour_counts_match_a_numpy_count(rng):
    """``K.fluid_neighbour_counts`` (the gap rows of the density relaxation,
    ``RowRoles.fluid_neighbour_counts``) against a count in numpy."""
    start = np.array([0, 3, 3, 7, 8])
    j = rng.integers(0, 10, size=8)
    fluid_of = np.where(rng.random(10) < 0.6, 0, -1)
    got = np.empty(4, dtype=np.int64)
    K.fluid_neighbour_counts(start, j, fluid_of, got)
    want = [int(np.sum(fluid_of[j[start[i]:start[i + 1]]] >= 0)) for i in range(4)]
    assert got.tolist() == want
    assert got[1] == 0  # a row without neighbours


def test_structure_rows_take_the_difference_form_with_the_coupling_pair_terms(perturbed):
    """Rows beside a structure (the last rows, j >= jmax, are its particles): the kernel plus
    the coupling's pair terms V_s (p_i + p_s) grad W_is [F 46-47] is the difference form
    sum_j V_j (p_j - p_i) grad W_ij over the whole support (oracle); a uniform pressure then
    pushes no row, where the pair form [F 10] pushed the rows of an irregular support; the
    other rows are left as they were."""
    rng = np.random.default_rng(3)
    x = perturbed
    n = len(x)
    nf, jmax = 90, 100  # rows 90-99 walls, 100-119 a structure
    vol = rng.uniform(0.8, 1.2, n)
    s, j = nbrs(x, nf)
    rows = np.zeros(nf, bool)
    rows[::2] = True
    none, floor = np.zeros(n, bool), np.ones(nf, bool)

    def with_pairs(p):
        g = np.full((nf, 2), 7.0)
        K.structure_row_pressure_gradient(x, p, vol, s, j, nf, H, KIND, 1.01, jmax, none,
                                          floor, np.zeros((n, 2)), True, rows, g)
        pairs = np.zeros((nf, 2))
        for i, jj, d, r in ref.pairs(x, H, nf):
            if jj >= jmax:
                pairs[i] += 1.01 * vol[jj] * (p[i] + p[jj]) * ref.grad_w(d, r, H)
        return g, g + pairs

    p = rng.normal(size=n)
    g, total = with_pairs(p)
    want = np.zeros((nf, 2))
    for i, jj, d, r in ref.pairs(x, H, nf):
        want[i] += 1.01 * vol[jj] * (p[jj] - p[i]) * ref.grad_w(d, r, H)
    assert_allclose(total[rows], want[rows], rtol=1e-12, atol=1e-13)
    assert (g[~rows] == 7.0).all()
    near = np.array([any(jj >= jmax for i2, jj, _, _ in ref.pairs(x, H, nf) if i2 == i)
                     for i in range(nf)])
    assert (rows & near).any()
    _, level = with_pairs(np.full(n, 5e3))
    assert np.abs(level[rows]).max() < 1e-9
    pair_form = ref.conservative_gradient(x, np.full(n, 5e3), vol, H, nf, 1.01)
    assert np.abs(pair_form[rows & near]).max() > 1.0
    # level_free False (a flow with a free surface): the pair form on the rows, bit for bit
    # the conservative kernel's
    g = np.zeros((nf, 2))
    K.structure_row_pressure_gradient(x, p, vol, s, j, nf, H, KIND, 1.01, jmax, none, floor,
                                      np.zeros((n, 2)), False, rows, g)
    cons = np.zeros((nf, 2))
    K.pressure_gradient(x, p, vol, s, j, nf, H, KIND, 1.01, jmax, none, floor,
                        np.zeros((n, 2)), cons)
    assert np.array_equal(g[rows], cons[rows])
