"""The numba V-cycle and BiCGStab of fsi_sph/fluid/amg.py against pyamg and scipy."""

import numba
import numpy as np
import pyamg
import scipy.sparse as sp

from fsi_sph.fluid import amg


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


def test_block_sweep_does_not_depend_on_thread_count():
    A = _nonsymmetric(30)
    c = amg.as_csr(A)
    block = (np.arange(A.shape[0]) >= A.shape[0] // 2).astype(np.int32)
    bl = amg._Blocks(block)
    b = np.random.default_rng(1).random(A.shape[0])
    out = []
    threads = numba.get_num_threads()
    try:
        for t in sorted({1, threads}):
            numba.set_num_threads(t)
            x = np.zeros(A.shape[0])
            amg.gauss_seidel(c.indptr, c.indices, c.data, x, b, True, bl.rows, bl.rows_start,
                             bl.block, np.empty_like(x))
            out.append(x)
    finally:
        numba.set_num_threads(threads)
    assert all(np.array_equal(out[0], o) for o in out)
    # and it is a Gauss-Seidel sweep inside each block: row 0 solved exactly from b
    assert np.isclose(out[0][0], b[0] / A[0, 0])


def test_bicgstab_reaches_the_tolerance_with_two_blocks():
    A = _nonsymmetric()
    ml = _hierarchy(A)
    n = A.shape[0]
    b = np.random.default_rng(2).random(n)
    nf = n - 40  # pretend the last 40 rows are boundary rows
    pre = amg.VCycle(ml, amg.two_blocks(sp.csr_matrix(A, dtype=np.float64), nf))
    x, its, rel = amg.bicgstab(amg.as_csr(A), b, np.zeros(n), pre, 1e-8, 100)
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
