"""The full viscous stress divergence div(2 eta D) of viscous_operator = "stress"
(fsi_sph/fluid/viscous.py): the Morris form div(eta grad u) [F 11-12] plus the divergence of
the transposed stress eta (grad u)^T by nested corrected gradients [F 7, F 13-14].

Analytic field: nu = 1 + x/2, u = (x y, -y^2/2) (div u = 0). Then
div(nu grad u) = (y/2, -nu), div(nu (grad u)^T) = (y/2, x/2), div(2 nu D) = (y, -1)."""

import numpy as np
import pytest
import scipy.sparse as sp
from numpy.testing import assert_allclose

from fsi_sph.fluid import _kernels as K
from fsi_sph.fluid import viscous as V
from fsi_sph.fluid import viscous_operators as VO
from fsi_sph.fluid import viscous_solvers as VS
from fsi_sph.fluid.lattice import lattice_scales
from fsi_sph.neighbors import find_neighbors
from fsi_sph.sph.kernels import KERNELS, kernel_dw
from tests.conftest import lattice

KIND = KERNELS["cubic_spline"]
DX = 0.1
H = 1.2 * DX


def _field(x):
    nu = 1.0 + 0.5 * x[:, 0]
    u = np.column_stack([x[:, 0] * x[:, 1], -0.5 * x[:, 1] ** 2])
    return nu, u


def _setup(x, nf):
    start, j = find_neighbors(x[:nf], x, 2 * H, exclude_self=True)
    vol = np.full(len(x), DX * DX)
    L = np.empty((nf, 2, 2))
    K.correction_matrices(x, vol, start, j, H, KIND, L)
    col_of = np.full(len(x), -1)
    col_of[:nf] = np.arange(nf)
    return start, j, vol, L, col_of


def _kernel_term(x, v, vol, nu, L, start, j, nf, col_of):
    gp = np.zeros((nf, 2))
    gv = np.zeros((nf, 2, 2))
    K.gradients(x, np.zeros(len(x)), v, vol, L, start, j, nf, H, KIND, gp, gv)
    tau = nu[:nf, None, None] * np.transpose(gv, (0, 2, 1))
    fs, fj = VO.fluid_lists(start, j, col_of)
    Lf = np.empty((nf, 2, 2))
    K.correction_matrices(x, vol, fs, fj, H, KIND, Lf)
    out = np.empty((nf, 2))
    VO.transpose_stress_divergence(x, vol, np.ascontiguousarray(tau), fs, fj, col_of, Lf, nf,
                                  H, KIND, out)
    return out


def _numpy_reference(x, v, vol, nu, nf):
    """Slow dense transcription: corrected gradient of u over all particles, tau = nu
    (grad u)^T, corrected divergence over the fluid particles."""
    n = len(x)

    def corrected(rows_src):
        Ls, gw = [], []
        for i in range(nf):
            m = np.zeros((2, 2))
            ws = []
            for jj in rows_src:
                d = x[i] - x[jj]
                r = np.hypot(*d)
                if jj == i or r >= 2 * H:
                    ws.append(np.zeros(2))
                    continue
                g = kernel_dw(KIND, r, H) * d / r
                m -= vol[jj] * np.outer(d, g)
                ws.append(g)
            Li = np.linalg.inv(m).T
            Ls.append(Li)
            gw.append([vol[jj] * Li @ w for jj, w in zip(rows_src, ws, strict=True)])
        return np.array(gw)

    ga = corrected(range(n))  # (nf, n, 2)
    grad = np.einsum("ijl,ijk->ikl", ga, v[None, :, :] - v[:nf, None, :])  # d v_k/d x_l
    tau = nu[:nf, None, None] * np.transpose(grad, (0, 2, 1))
    gf = corrected(range(nf))  # (nf, nf, 2)
    return np.einsum("ijl,ijkl->ik", gf, tau[None, :, :, :] - tau[:, None, :, :])


def test_transpose_term_kernel_matches_numpy_reference():
    rng = np.random.default_rng(3)
    x = lattice(9, 9, DX) + rng.uniform(-0.2, 0.2, (81, 2)) * DX
    nf = 60
    v = rng.normal(size=(81, 2))
    nu = rng.uniform(0.5, 2.0, 81)
    start, j, vol, L, col_of = _setup(x, nf)
    out = _kernel_term(x, v, vol, nu, L, start, j, nf, col_of)
    assert_allclose(out, _numpy_reference(x, v, vol, nu, nf), rtol=1e-9, atol=1e-9)


def test_full_stress_divergence_of_an_analytic_field():
    """Interior particles of a regular lattice: Morris (with the lattice normalisation) +
    transposed term = div(2 nu D) = (y, -1) to round-off; the Morris form alone misses
    div(nu (grad u)^T) = (y/2, x/2)."""
    x = lattice(16, 16, DX)
    nf = len(x)
    nu, u = _field(x)
    start, j, vol, L, col_of = _setup(x, nf)
    lap_scale = lattice_scales(DX, H, KIND)[1]
    morris = np.zeros((nf, 2))
    K.predict_velocity(x, u, vol, nu * lap_scale, start, j, nf, H, KIND, (0.1 * H) ** 2,
                       0.0, 0.0, 1.0, morris)
    morris -= u
    trans = _kernel_term(x, u, vol, nu, L, start, j, nf, col_of)
    exact = np.column_stack([x[:, 1], -np.ones(nf)])
    inner = np.all((x > 4.5 * DX) & (x < 11.5 * DX), axis=1)
    assert_allclose((morris + trans)[inner], exact[inner], rtol=1e-9, atol=1e-9)
    assert_allclose(trans[inner], 0.5 * x[inner][:, ::-1], rtol=1e-9, atol=1e-9)
    miss = np.abs(morris - exact)[inner].max() / np.abs(exact[inner]).max()
    assert miss > 0.3  # the Morris form alone is not div(2 nu D)


def test_transpose_term_on_a_perturbed_lattice_has_no_bias():
    """On a lattice perturbed by 0.2 dx the nested corrected derivatives of the analytic
    field scatter about (y/2, x/2) (the zeroth-order particle noise of any nested SPH
    second derivative, here ~20 % pointwise) with a mean error that is small and falls
    with dx: the term adds no systematic stress."""
    bias, scatter = [], []
    for n in (16, 32):
        dx = 1.6 / n
        rng = np.random.default_rng(5)
        x = lattice(n, n, dx) + rng.uniform(-0.2, 0.2, (n * n, 2)) * dx
        nu, u = _field(x)
        start, j = find_neighbors(x, x, 2.4 * dx, exclude_self=True)
        vol = np.full(len(x), dx * dx)
        L = np.empty((len(x), 2, 2))
        K.correction_matrices(x, vol, start, j, 1.2 * dx, KIND, L)
        col_of = np.arange(len(x))
        gp = np.zeros((len(x), 2))
        gv = np.zeros((len(x), 2, 2))
        K.gradients(x, np.zeros(len(x)), u, vol, L, start, j, len(x), 1.2 * dx, KIND, gp, gv)
        tau = np.ascontiguousarray(nu[:, None, None] * np.transpose(gv, (0, 2, 1)))
        out = np.empty((len(x), 2))
        VO.transpose_stress_divergence(x, vol, tau, start, j, col_of, L, len(x), 1.2 * dx, KIND,
                                      out)
        inner = np.all((x > 0.5) & (x < 1.1), axis=1)
        ref = 0.5 * x[inner][:, ::-1]
        err = (out[inner] - ref) / np.abs(ref).mean()
        bias.append(np.abs(err.mean(axis=0)).max())
        scatter.append(np.sqrt((err ** 2).mean()))
    print(bias, scatter)
    assert bias[0] < 0.02 and bias[1] < 0.01, bias
    assert max(scatter) < 0.3, scatter


@pytest.mark.parametrize("with_mirror", [False, True])
def test_transpose_matrix_equals_the_kernel(with_mirror):
    """B U + e of transpose_operator equals the gather kernel with the boundary velocities
    known (or mirrored, u_w = target - S u)."""
    rng = np.random.default_rng(11)
    x = lattice(10, 10, DX) + rng.uniform(-0.2, 0.2, (100, 2)) * DX
    nf = 80
    nb = 20
    v = rng.normal(size=(100, 2))
    nu = rng.uniform(0.5, 2.0, 100)
    start, j, vol, L, col_of = _setup(x, nf)
    mirror = None
    if with_mirror:
        S = sp.csr_array(rng.uniform(0, 1, (nb, nf)) * (rng.uniform(0, 1, (nb, nf)) < 0.1))
        target = rng.normal(size=(nb, 2))
        mirror = (S, target)
        v[nf:] = target - S @ v[:nf]
    B, e = VO.transpose_operator(x, vol, nu[:nf], L, start, j, nf, H, KIND, col_of, v, mirror)
    assert_allclose(B.tocsr() @ v[:nf].T.reshape(-1), B @ v[:nf].T.reshape(-1), rtol=1e-12,
                    atol=1e-12)
    U = v[:nf].T.reshape(-1)
    got = (B @ U).reshape(2, nf).T + e
    assert_allclose(got, _kernel_term(x, v, vol, nu, L, start, j, nf, col_of), rtol=1e-10,
                    atol=1e-10)


def test_coupled_solve_matches_the_direct_solve():
    """GMRES with the block AMG preconditioner (viscous.solve_coupled) gives the sparse
    LU's answer of a coupled 2-component system like the stress operator's: a stiff
    diffusion block per component (I - dt nu lap, dt nu / dx^2 = 500) coupled by a
    grad-div-like part of the same order."""
    from fsi_sph.fluid.viscous_solvers import solve_coupled, solve_direct

    m = 24
    lap1 = sp.diags_array([np.ones(m - 1), -2.0 * np.ones(m), np.ones(m - 1)],
                          offsets=[-1, 0, 1])
    eye = sp.identity(m)
    lap = sp.kron(lap1, eye) + sp.kron(eye, lap1)
    dx1 = sp.diags_array([-np.ones(m - 1), np.ones(m - 1)], offsets=[-1, 1]) * 0.5
    gx, gy = sp.kron(dx1, eye), sp.kron(eye, dx1)
    A = sp.csr_array(sp.identity(m * m) - 500.0 * lap)
    B = 500.0 * sp.block_array([[gx @ gx, gx @ gy], [gy @ gx, gy @ gy]])
    A2 = sp.csr_array(sp.block_diag([A, A]) - B)
    rng = np.random.default_rng(0)
    b = rng.normal(size=2 * m * m)
    u, stats = solve_coupled(A, A2, b, np.zeros(2 * m * m), 1e-8)
    ud, _ = solve_direct(A2, b)
    assert stats.iterations > 0  # the Krylov path, not the fallback
    assert np.abs(u - ud).max() < 1e-6 * np.abs(ud).max()


def test_amplification_bound():
    rhs = np.array([[0.1, -0.3], [0.0, 0.2]])
    assert not VS.amplifies(rhs, rhs)
    assert not VS.amplifies(1.9 * rhs, rhs)
    assert VS.amplifies(np.array([[0.0, 0.0], [0.25, 0.0]]), rhs)  # x: 0.25 > 2 x 0.1
    assert VS.amplifies(np.array([[1e-13, 0.0], [0.0, 0.0]]), np.zeros((2, 2))) is False
    assert VS.amplifies(np.array([[1e-3, 0.0], [0.0, 0.0]]), np.zeros((2, 2)))


class _Cluster:
    """The few attributes of a fluid's particle set that ViscousStep.solve_step reads: a perturbed lattice,
    all fluid (no boundary rows)."""

    def __init__(self, nu):
        rng = np.random.default_rng(5)
        self.x_all = lattice(6, 6, DX) + rng.uniform(-0.2, 0.2, (36, 2)) * DX
        self.nf = 36
        self.ff_start, self.ff_j, self.vol_all, self.L, self.col_of = _setup(self.x_all, 36)
        self.nu_all = np.full(36, nu)
        self.h, self.kernel = H, KIND
        self.v_all = np.zeros((36, 2))
        self.v_old = rng.normal(size=(36, 2)) * 0.01
        self.cfg = type("cfg", (), {"viscous_rtol": 1e-10})()


def _morris_matrix(fl, dt):
    c = np.zeros(len(fl.ff_j))
    VO.pair_coefficients(fl.x_all, fl.vol_all, fl.nu_all, fl.ff_start, fl.ff_j, fl.nf, fl.h,
                        fl.kernel, (0.1 * H) ** 2, c)
    rows = np.repeat(np.arange(fl.nf), np.diff(fl.ff_start))
    C = sp.csr_array((c, (rows, fl.ff_j)), shape=(fl.nf, fl.nf))
    D = sp.diags_array(np.asarray(C.sum(axis=1)).ravel())
    return sp.csr_array(sp.identity(fl.nf) + dt * (D - C))


def test_stress_step_that_amplifies_falls_back_to_the_morris_step(monkeypatch):
    """A transposed part that makes the coupled matrix nearly singular (here an
    anti-dissipative B = (1 - 1e-4) blockdiag(A, A) / dt, standing for the lopsided
    supports of a few particles on the floor) gives a step thousands of times the
    right-hand side; the step is then the Morris solve, flagged as a fallback."""
    fl = _Cluster(nu=0.02)
    dt = 5e-3
    A = _morris_matrix(fl, dt)
    rhs = fl.v_old + np.array([0.0, -9.81 * dt])
    good, _ = V.ViscousStep(fl, None, None, None, None).solve_step(A, rhs, dt, fl.col_of, None, stress=False)
    assert np.abs(good).max() <= np.abs(rhs).max() * (1 + 1e-9)  # the Morris max principle
    bad_B = (1.0 - 1e-4) * sp.csr_array(sp.block_diag([A, A])) / dt
    monkeypatch.setattr(V, "transpose_operator",
                        lambda *a, **k: (bad_B, np.zeros((fl.nf, 2))))
    u, stats = V.ViscousStep(fl, None, None, None, None).solve_step(A, rhs, dt, fl.col_of, None, stress=True)
    assert stats.fallback
    assert_allclose(u, good, rtol=1e-8, atol=1e-12)


def test_a_regular_stress_step_is_kept():
    """The real transposed operator on a perturbed lattice at dt nu / dx^2 = 10: no
    fallback, and the step differs from the Morris one (the transposed part acts)."""
    fl = _Cluster(nu=0.2)
    fl.nu_all = 0.2 * (1.0 + 0.5 * fl.x_all[:, 0] / DX)  # a varying viscosity
    dt = 10.0 * DX * DX / 0.2
    A = _morris_matrix(fl, dt)
    rhs = fl.v_old + np.array([0.0, -9.81 * dt])
    u, stats = V.ViscousStep(fl, None, None, None, None).solve_step(A, rhs, dt, fl.col_of, None, stress=True)
    morris, _ = V.ViscousStep(fl, None, None, None, None).solve_step(A, rhs, dt, fl.col_of, None, stress=False)
    assert not stats.fallback
    assert np.abs(u - morris).max() > 1e-6 * np.abs(morris).max()


def test_coupled_matrix_product_equals_the_assembled_matrix():
    """CoupledMatrix (blockdiag(A, A) - dt B as products) against its assembled form."""
    fl = _Cluster(nu=0.2)
    dt = 1e-3
    A = _morris_matrix(fl, dt)
    B, _ = VO.transpose_operator(fl.x_all, fl.vol_all, fl.nu_all, fl.L, fl.ff_start, fl.ff_j,
                                fl.nf, fl.h, fl.kernel, fl.col_of, fl.v_all)
    M = VS.CoupledMatrix(A, B, dt)
    U = np.random.default_rng(2).normal(size=2 * fl.nf)
    assert_allclose(M @ U, M.tocsr() @ U, rtol=1e-12, atol=1e-12)
    assert M.tocsr().shape == (2 * fl.nf, 2 * fl.nf)
