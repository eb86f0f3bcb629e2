"""The numba V-cycle, BiCGStab and flexible GMRES of fsi_sph/fluid/amg.py against pyamg and
scipy."""

import numba
import numpy as np
import pyamg
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from fsi_sph.fluid import amg, krylov


def _nonsymmetric(n=40):
    """2D Poisson plus a first-order convection term: nonsymmetric, like the PPE."""
    A = pyamg.gallery.poisson((n, n), format="csr")
    c = sp.diags([np.full(n * n - 1, -0.3), np.full(n * n - 1, 0.3)], [-1, 1])
    return sp.csr_matrix(A + c)


def _hierarchy(A):
    return pyamg.ruge_stuben_solver(A, max_coarse=50, coarse_solver="splu",
                                    presmoother=("gauss_seidel", {"sweep": "forward"}),
                                    postsmoother=("gauss_seidel", {"sweep": "backward"}))


def test_single_block_vcycle_matches_pyamg():
    A = _nonsymmetric()
    ml = _hierarchy(A)
    r = np.random.default_rng(0).random(A.shape[0])
    ref = ml.aspreconditioner() @ r
    ours = amg.VCycle(ml)(r)
    assert np.abs(ours - ref).max() < 1e-12 * np.abs(ref).max()


def _with_threads(fn):
    """``fn()`` with one thread and with all of numba's threads."""
    out = []
    threads = numba.get_num_threads()
    try:
        for t in sorted({1, threads}):
            numba.set_num_threads(t)
            out.append(fn())
    finally:
        numba.set_num_threads(threads)
    return out


def test_block_sweep_does_not_depend_on_thread_count():
    A = _nonsymmetric(30)
    n = A.shape[0]
    block = (np.arange(n) >= n // 2).astype(np.int32)
    sm = amg._Smoother(amg.as_csr(A), block)
    b = np.random.default_rng(1).random(n)

    def sweep():
        x = sm.zeros()
        sm.sweep(x, b, True)
        return x.copy()

    out = _with_threads(sweep)
    assert all(np.array_equal(out[0], o) for o in out)
    x = out[0]
    # a Gauss-Seidel sweep inside each block: row 0 solved exactly from b
    assert np.isclose(x[0], b[0] / A[0, 0])
    # the first row of block 1 reads block 0's unknowns from before the sweep (zero), but
    # its own block's as they are updated
    i = n // 2
    Ad = A.toarray()
    assert np.isclose(x[i], b[i] / Ad[i, i])
    expect = (b[i + 1] - Ad[i + 1, i] * x[i]) / Ad[i + 1, i + 1]
    assert np.isclose(x[i + 1], expect)
    # one block is plain (forward) Gauss-Seidel: the lower triangle solve
    one = amg._Smoother(amg.as_csr(A))
    y = one.zeros()
    one.sweep(y, b, True)
    assert np.allclose(y, spla.spsolve_triangular(sp.csr_matrix(sp.tril(A)), b, lower=True))


def test_bicgstab_reaches_the_tolerance_with_two_blocks():
    A = _nonsymmetric()
    ml = _hierarchy(A)
    n = A.shape[0]
    b = np.random.default_rng(2).random(n)
    nf = n - 40  # pretend the last 40 rows are boundary rows
    pre = amg.VCycle(ml, amg.two_blocks(sp.csr_matrix(A, dtype=np.float64), nf))
    x, its, rel = krylov.bicgstab(amg.as_csr(A), b, np.zeros(n), pre, 1e-8, 100)
    true = np.linalg.norm(b - A @ x) / np.linalg.norm(b)
    assert rel <= 1e-8 and true <= 1e-8 and np.isclose(rel, true)
    assert 0 < its < 30


def test_boundary_rows_join_the_block_of_their_fluid():
    # 6 fluid rows (blocks 0,0,0,1,1,1) and 2 boundary rows coupled to fluid rows 0-1 and 4-5
    A = sp.lil_matrix((8, 8))
    for i in range(8):
        A[i, i] = 4.0
    A[6, 0] = A[6, 1] = -1.0
    A[7, 4] = A[7, 5] = -1.0
    block = amg.two_blocks(sp.csr_matrix(A), 6)
    assert list(block) == [0, 0, 0, 1, 1, 1, 0, 1]


def _ppe_system(dx=0.05):
    """The PPE of the first step of a small dam break (1 x 2 column, 3 wall layers)."""
    from pathlib import Path

    from fsi_sph.config import load_config
    from fsi_sph.simulation import Simulation

    case = Path(__file__).resolve().parents[2] / "cases" / "dam_break.toml"
    sim = Simulation(load_config(case, [f"case.dx={dx}"]))
    sim.step()
    f = sim.fluid
    return sp.csr_matrix(f.pressure.A), f.pressure.rhs.copy(), f.nf


def test_fgmres_solves_a_ppe_to_rtol_like_a_direct_solve():
    from fsi_sph.config import PPESection
    from fsi_sph.fluid.ppe import PressureSolver

    A, b, nf = _ppe_system()
    exact = spla.spsolve(sp.csc_matrix(A), b)
    ps = PressureSolver(PPESection(krylov="gmres"))
    p, st = ps.solve(A, b, np.zeros_like(b), nf)
    true = np.linalg.norm(b - A @ p) / np.linalg.norm(b)
    assert true <= 1e-6 and np.isclose(st.residual, true, rtol=1e-6)
    assert np.abs(p - exact).max() < 1e-4 * np.abs(exact).max()
    # one V-cycle per iteration, one product per iteration plus the true residuals
    assert st.vcycles == st.iterations > 0
    assert st.iterations + 2 <= st.matvecs <= st.iterations + 2 + st.iterations // 20
    # BiCGStab on the same system: two V-cycles per (full) iteration
    pb, sb = PressureSolver(PPESection(krylov="bicgstab")).solve(A, b, np.zeros_like(b), nf)
    assert np.linalg.norm(b - A @ pb) / np.linalg.norm(b) <= 1e-6
    assert 2 * sb.iterations - 1 <= sb.vcycles <= 2 * sb.iterations


def test_fgmres_counts_are_honest_and_the_true_residual_decides():
    A = _nonsymmetric()
    ml = _hierarchy(A)
    n = A.shape[0]
    b = np.random.default_rng(3).random(n)
    M = amg.VCycle(ml)
    c = krylov.Counts()
    x, its, rel = krylov.fgmres(amg.as_csr(A), b, np.zeros(n), M, 1e-10, 100, counts=c)
    true = np.linalg.norm(b - A @ x) / np.linalg.norm(b)
    assert rel <= 1e-10 and np.isclose(rel, true, rtol=1e-6)
    assert c.precond == its and M.applications == its
    # a short restart length still converges, with more iterations and one true residual
    # (one product) per cycle
    c2 = krylov.Counts()
    x2, its2, rel2 = krylov.fgmres(amg.as_csr(A), b, np.zeros(n), M, 1e-10, 100, restart=2,
                                counts=c2)
    assert rel2 <= 1e-10 and its2 > its
    assert c2.matvecs == its2 + 1 + (its2 + 1) // 2
    # the iteration limit: stops there, reports the residual it reached
    x3, its3, rel3 = krylov.fgmres(amg.as_csr(A), b, np.zeros(n), M, 1e-14, 2)
    assert its3 == 2 and rel3 > 1e-14
    assert np.isclose(rel3, np.linalg.norm(b - A @ x3) / np.linalg.norm(b))
    # an exact initial guess: no iteration
    x4, its4, rel4 = krylov.fgmres(amg.as_csr(A), b, x, M, 1e-8, 100)
    assert its4 == 0 and np.array_equal(x4, x)


def test_fgmres_does_not_depend_on_thread_count():
    A = _nonsymmetric(100)  # 10000 rows: the parallel loops are used
    assert A.shape[0] >= amg.PARALLEL_ROWS
    ml = _hierarchy(A)
    n = A.shape[0]
    b = np.random.default_rng(4).random(n)
    pre = amg.VCycle(ml, amg.two_blocks(sp.csr_matrix(A), n))
    out = _with_threads(lambda: krylov.fgmres(amg.as_csr(A), b, np.zeros(n), pre, 1e-8, 100)[0])
    assert all(np.array_equal(out[0], o) for o in out)


def test_kept_hierarchy_with_the_current_finest_matrix_is_as_good_as_a_new_one():
    """The hierarchy of the first step's PPE applied 10 steps later: with its own (old)
    finest matrix the V-cycles more than double (measured 14 vs 6), with the current one
    (``refresh_finest``) they are those of a new hierarchy (measured 6 vs 9)."""
    from pathlib import Path

    from fsi_sph.config import PPESection, load_config
    from fsi_sph.fluid.ppe import PressureSolver
    from fsi_sph.simulation import Simulation

    case = Path(__file__).resolve().parents[2] / "cases" / "dam_break.toml"
    sim = Simulation(load_config(case, ["case.dx=0.05"]))
    sim.step()
    A0, b0, nf = sp.csr_matrix(sim.fluid.pressure.A), sim.fluid.pressure.rhs.copy(), sim.fluid.nf
    for _ in range(10):
        sim.step()
    A1, b1 = sp.csr_matrix(sim.fluid.pressure.A), sim.fluid.pressure.rhs.copy()
    vc = {}
    for refresh in (False, True):
        ps = PressureSolver(PPESection(refresh_finest=refresh, rebuild_growth=100.0))
        ps.solve(A0, b0, np.zeros_like(b0), nf)
        p, st = ps.solve(A1, b1, np.zeros_like(b1), nf)
        assert not st.rebuilt and st.residual <= 1e-6
        assert np.linalg.norm(b1 - A1 @ p) / np.linalg.norm(b1) <= 1e-6
        vc[refresh] = st.vcycles
    _, fresh = PressureSolver(PPESection()).solve(A1, b1, np.zeros_like(b1), nf)
    assert fresh.rebuilt
    assert vc[True] <= fresh.vcycles + 1
    assert vc[False] >= 2 * vc[True]


def test_refresh_of_a_one_level_hierarchy_is_the_new_lu():
    A = _nonsymmetric(10)  # 100 rows: below max_coarse, one level
    ml = pyamg.ruge_stuben_solver(A, max_coarse=500, coarse_solver="splu")
    assert len(ml.levels) == 1
    vc = amg.VCycle(ml)
    A2 = sp.csr_matrix(A + sp.identity(A.shape[0]))
    vc.refresh_finest(A2)
    b = np.random.default_rng(5).random(A.shape[0])
    assert np.allclose(A2 @ vc(b), b)


def test_seeded_build_is_reproducible_and_leaves_the_global_generator_alone():
    """pyamg's smoothed aggregation starts its spectral-radius estimate from
    np.random.rand: unseeded, two builds of one matrix differ at round-off (the mu(I) runs
    were not reproducible); amg.seeded_build fixes the state and restores it."""
    import pyamg
    import scipy.sparse as sp

    from fsi_sph.fluid import amg as AMG

    n = 400
    rng = np.random.default_rng(5)
    A = sp.diags([-1.2, 2.5, -1.0], [-1, 0, 1], shape=(n, n), format="csr")
    A = (A + sp.random(n, n, density=0.01, random_state=rng) * 0.05).tocsr()

    def smoother_p(ml):
        return ml.levels[0].P.toarray()

    np.random.seed(1)  # noqa: NPY002
    before = np.random.random()  # noqa: NPY002
    np.random.seed(1)  # noqa: NPY002
    a = AMG.seeded_build(pyamg.smoothed_aggregation_solver, A, symmetry="nonsymmetric")
    assert np.random.random() == before  # noqa: NPY002  (state restored)
    np.random.seed(2)  # noqa: NPY002
    b = AMG.seeded_build(pyamg.smoothed_aggregation_solver, A, symmetry="nonsymmetric")
    assert np.array_equal(smoother_p(a), smoother_p(b))
    # what it fixes: unseeded builds from different global states differ
    np.random.seed(1)  # noqa: NPY002
    c = pyamg.smoothed_aggregation_solver(A, symmetry="nonsymmetric")
    np.random.seed(2)  # noqa: NPY002
    d = pyamg.smoothed_aggregation_solver(A, symmetry="nonsymmetric")
    assert not np.array_equal(smoother_p(c), smoother_p(d))


def test_remap_keeps_the_rows_that_stay_and_zeroes_the_new_ones():
    """VCycle.remap against a dense oracle: new row i of P (column i of R) is old row
    ``old[i]`` (column), zero for a new particle; the coarse levels are untouched; the
    identity renumbering leaves the V-cycle bit for bit as it was."""
    A = _nonsymmetric(30)  # 900 rows: more than one level
    ml = _hierarchy(A)
    n = A.shape[0]
    vc = amg.VCycle(ml)
    r = np.random.default_rng(6).random(n)
    z0 = vc(r)
    assert vc.remap(np.arange(n))
    vc.refresh_finest(A)
    assert np.array_equal(vc(r), z0)
    P = ml.levels[0].P.toarray()
    R = ml.levels[0].R.toarray()
    coarse = vc.A[1]
    old = np.concatenate([np.arange(5, n), [-1, -1, -1], [2, 0]])  # 5 gone, 3 new, reordered
    assert vc.remap(old)
    Pn = np.where((old >= 0)[:, None], P[np.maximum(old, 0)], 0.0)
    Rn = np.where((old >= 0)[None, :], R[:, np.maximum(old, 0)], 0.0)

    def dense(c):
        return sp.csr_matrix((c.data, c.indices, c.indptr), shape=c.shape).toarray()

    assert np.array_equal(dense(vc.P[0]), Pn) and np.array_equal(dense(vc.R[0]), Rn)
    assert vc.A[1] is coarse and vc.n == len(old)
    A2 = sp.csr_matrix(A)[np.maximum(old, 0)][:, np.maximum(old, 0)] + sp.identity(len(old))
    vc.refresh_finest(A2)
    b = np.random.default_rng(7).random(len(old))
    x, its, rel = krylov.fgmres(amg.as_csr(A2), b, np.zeros(len(old)), vc, 1e-8, 100)
    assert rel <= 1e-8


def test_remap_gives_the_arrays_of_the_sparse_products():
    """The row gather of :func:`amg.take_rows` gives, array for array, what the sparse
    products ``diag(kept) P[take]`` and ``R[:, take] diag(kept)`` gave (the implementation it
    replaced): duplicated and dropped rows, new rows, explicit zeros."""
    rng = np.random.default_rng(0)
    for trial in range(30):
        n, nc = int(rng.integers(5, 300)), int(rng.integers(2, 60))
        P = sp.random(n, nc, density=0.1, random_state=trial, format="csr")
        R = sp.random(nc, n, density=0.1, random_state=trial + 100, format="csr")
        if trial % 3 == 0:
            P.data[::7] = 0.0
            R.data[::5] = 0.0
        old = rng.integers(-1, n, int(rng.integers(1, 2 * n)))
        kept = old >= 0
        scale = sp.diags(kept.astype(np.float64))
        want_P = amg._Csr(scale @ P[np.where(kept, old, 0)])
        want_R = amg._Csr(R[:, np.where(kept, old, 0)] @ scale)
        vc = amg.VCycle.__new__(amg.VCycle)
        vc.A, vc.P, vc.R, vc.work = [None, None], [amg._Csr(P)], [amg._Csr(R)], [None]
        assert vc.remap(old)
        for want, got in ((want_P, vc.P[0]), (want_R, vc.R[0])):
            assert want.shape == got.shape
            for k in ("indptr", "indices", "data"):
                assert np.array_equal(getattr(want, k), getattr(got, k)), (trial, k)
                assert getattr(want, k).dtype == getattr(got, k).dtype
