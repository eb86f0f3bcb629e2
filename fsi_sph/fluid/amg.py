"""Applying a pyamg hierarchy fast: a numba V-cycle and a preconditioned BiCGStab.

pyamg builds the hierarchy (Ruge-Stuben or smoothed aggregation: the levels' ``A``, ``P``,
``R`` and the coarse LU factors); this module only *applies* it. pyamg's own
``aspreconditioner()`` runs each V-cycle through ``MultilevelSolver.solve``, which computes
two extra residual norms per call and does every sparse product single-threaded in scipy.
Here the V-cycle is the same algorithm (pre-smoothing from a zero guess, residual,
restriction, coarse correction, prolongation, post-smoothing) with

- Gauss-Seidel sweeps (forward before, backward after the coarse correction) in numba; on
  the finest level two row blocks are swept in parallel (hybrid Gauss-Seidel: each block
  reads the other's unknowns from before the sweep; deterministic, independent of the thread
  count; see :func:`two_blocks` for how the PPE rows are split);
- every sparse matrix-vector product a parallel numba loop over rows;
- the coarsest level solved by the LU factors of scipy's ``splu``.

With one block it matches pyamg's V-cycle with the same smoothers to round-off; with the
two blocks of :func:`two_blocks` the PPE's BiCGStab iteration counts stay those of plain
Gauss-Seidel (tests/unit/test_amg.py).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numba import njit, prange


@njit(cache=True)
def _row_dot(indptr, indices, data, x, i):
    """Row ``i`` of ``A x``."""
    s = 0.0
    for k in range(indptr[i], indptr[i + 1]):
        s += data[k] * x[indices[k]]
    return s


@njit(cache=True, parallel=True)
def spmv(indptr, indices, data, x, out):
    """``out = A x`` for a CSR matrix."""
    for i in prange(out.shape[0]):
        out[i] = _row_dot(indptr, indices, data, x, i)


@njit(cache=True, parallel=True)
def residual(indptr, indices, data, x, b, out):
    """``out = b - A x``."""
    for i in prange(out.shape[0]):
        out[i] = b[i] - _row_dot(indptr, indices, data, x, i)


@njit(cache=True)
def spmv_serial(indptr, indices, data, x, out):
    """:func:`spmv` on one thread (small levels: no parallel region to start)."""
    for i in range(out.shape[0]):
        out[i] = _row_dot(indptr, indices, data, x, i)


@njit(cache=True)
def residual_serial(indptr, indices, data, x, b, out):
    """:func:`residual` on one thread."""
    for i in range(out.shape[0]):
        out[i] = b[i] - _row_dot(indptr, indices, data, x, i)


@njit(cache=True)
def gauss_seidel_serial(indptr, indices, data, x, b, forward):
    """One plain Gauss-Seidel sweep in place, on one thread."""
    n = x.shape[0]
    for step in range(n):
        i = step if forward else n - 1 - step
        s = b[i]
        diag = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            if j == i:
                diag += data[k]
            else:
                s -= data[k] * x[j]
        if diag != 0.0:
            x[i] = s / diag


@njit(cache=True, parallel=True)
def gauss_seidel(indptr, indices, data, x, b, forward, rows, rows_start, block, x_frozen):
    """One hybrid Gauss-Seidel sweep on ``A x = b`` in place.

    The rows are split into blocks (block ``q`` holds ``rows[rows_start[q]:rows_start[q+1]]``,
    ``block[i]`` is the block of row ``i``), swept in parallel: each block is a Gauss-Seidel
    sweep over its rows in increasing (``forward``) or decreasing order that reads the other
    blocks' unknowns as they were before the sweep (``x_frozen``, work array). The result
    depends on the blocks only, never on the number of threads; one block is plain
    Gauss-Seidel."""
    n = x.shape[0]
    x_frozen[:n] = x
    for q in prange(rows_start.shape[0] - 1):
        m = rows_start[q + 1] - rows_start[q]
        for step in range(m):
            i = rows[rows_start[q] + (step if forward else m - 1 - step)]
            s = b[i]
            diag = 0.0
            for k in range(indptr[i], indptr[i + 1]):
                j = indices[k]
                if j == i:
                    diag += data[k]
                elif block[j] == q:
                    s -= data[k] * x[j]
                else:
                    s -= data[k] * x_frozen[j]
            if diag != 0.0:
                x[i] = s / diag


@njit(cache=True)
def _boundary_blocks(indptr, indices, nf, block):
    """A boundary row (``i >= nf``) joins the block that most of its fluid columns are in."""
    for i in range(nf, indptr.shape[0] - 1):
        n0 = 0
        n1 = 0
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            if j < nf:
                if block[j] == 0:
                    n0 += 1
                else:
                    n1 += 1
        block[i] = 0 if n0 > n1 else 1


def two_blocks(A, nf):
    """Block ids of the rows of a PPE matrix for the hybrid smoother: the fluid rows cut in
    two halves by index (particles are numbered in fill order, so each half is one region of
    the fluid) and every boundary row with the fluid it extrapolates from, so that the strong
    fluid-boundary couplings stay inside a block."""
    n = A.shape[0]
    block = np.zeros(n, dtype=np.int32)
    block[nf // 2:nf] = 1
    _boundary_blocks(np.asarray(A.indptr), np.asarray(A.indices), nf, block)
    return block


class _Blocks:
    """Row lists of a block assignment, in the form :func:`gauss_seidel` takes."""

    def __init__(self, block):
        self.block = np.ascontiguousarray(block, dtype=np.int32)
        nb = int(self.block.max()) + 1 if len(self.block) else 1
        self.rows = np.argsort(self.block, kind="stable").astype(np.int32)
        self.rows_start = np.zeros(nb + 1, dtype=np.int64)
        np.cumsum(np.bincount(self.block, minlength=nb), out=self.rows_start[1:])

    @classmethod
    def single(cls, n):
        return cls(np.zeros(n, dtype=np.int32))


PARALLEL_ROWS = 8000  # below this many rows a loop runs on one thread (fewer barriers)


class _Csr:
    """The three CSR arrays of a matrix, contiguous and typed for the numba loops."""

    def __init__(self, M):
        M = sp.csr_matrix(M)
        if not M.has_sorted_indices:
            M.sort_indices()
        self.indptr = np.ascontiguousarray(M.indptr, dtype=np.int32)
        self.indices = np.ascontiguousarray(M.indices, dtype=np.int32)
        self.data = np.ascontiguousarray(M.data, dtype=np.float64)
        self.shape = M.shape

    def matvec(self, x, out=None):
        out = np.empty(self.shape[0]) if out is None else out
        f = spmv if self.shape[0] >= PARALLEL_ROWS else spmv_serial
        f(self.indptr, self.indices, self.data, x, out)
        return out

    def residual(self, x, b, out):
        f = residual if self.shape[0] >= PARALLEL_ROWS else residual_serial
        f(self.indptr, self.indices, self.data, x, b, out)
        return out


def as_csr(A):
    """A scipy CSR matrix as the typed arrays of the numba loops (no copy when it already has
    sorted int32 indices, as the PPE assembly makes it)."""
    return _Csr(A)


class VCycle:
    """One V-cycle of a pyamg ``MultilevelSolver`` as a preconditioner ``z = M r``."""

    def __init__(self, ml, block0=None):
        levels = ml.levels
        self.A = [_Csr(lv.A) for lv in levels]
        self.P = [_Csr(lv.P) for lv in levels[:-1]]
        self.R = [_Csr(lv.R) for lv in levels[:-1]]
        self.lu = spla.splu(sp.csc_matrix(levels[-1].A))
        self.work = [np.empty(a.shape[0]) for a in self.A]
        self.frozen = np.empty(self.A[0].shape[0])
        # the finest level (most of the work) is smoothed in blocks, coarser ones plainly
        n0 = self.A[0].shape[0]
        self.blocks = [_Blocks(block0) if block0 is not None else _Blocks.single(n0)]
        self.blocks += [_Blocks.single(a.shape[0]) for a in self.A[1:]]

    def __call__(self, r):
        return self._cycle(0, np.ascontiguousarray(r, dtype=np.float64))

    def _cycle(self, lvl, b):
        if lvl == len(self.A) - 1:
            return self.lu.solve(b)
        A = self.A[lvl]
        x = np.zeros_like(b)
        self._smooth(lvl, x, b, True)
        res = A.residual(x, b, self.work[lvl])
        xc = self._cycle(lvl + 1, self.R[lvl].matvec(res))
        x += self.P[lvl].matvec(xc)
        self._smooth(lvl, x, b, False)
        return x

    def _smooth(self, lvl, x, b, forward):
        A = self.A[lvl]
        bl = self.blocks[lvl]
        if len(bl.rows_start) > 2:
            gauss_seidel(A.indptr, A.indices, A.data, x, b, forward, bl.rows, bl.rows_start,
                         bl.block, self.frozen)
        else:
            gauss_seidel_serial(A.indptr, A.indices, A.data, x, b, forward)


def bicgstab(A, b, x0, precond, rtol, maxiter):
    """Right-preconditioned BiCGStab (van der Vorst 1992) for ``A x = b``.

    ``A`` is a :class:`_Csr`, ``precond`` a callable ``z = M r``. Stops when the true
    relative residual ``||b - A x|| / ||b||`` is at most ``rtol`` (the recurrence residual is
    checked first and then confirmed), or after ``maxiter`` iterations. Returns
    ``(x, iterations, relative residual)``.
    """
    bnorm = float(np.linalg.norm(b))
    x = np.array(x0, dtype=np.float64)
    r = np.empty_like(b)
    A.residual(x, b, r)
    rel = float(np.linalg.norm(r)) / bnorm
    if rel <= rtol:
        return x, 0, rel
    rhat = r.copy()
    p = r.copy()
    rho = float(rhat @ r)
    v = np.empty_like(b)
    t = np.empty_like(b)
    it = 0
    while it < maxiter:
        it += 1
        y = precond(p)
        A.matvec(y, v)
        alpha = rho / float(rhat @ v)
        s = r - alpha * v
        if float(np.linalg.norm(s)) / bnorm <= rtol:
            x += alpha * y
            A.residual(x, b, r)
            rel = float(np.linalg.norm(r)) / bnorm
            if rel <= rtol:
                return x, it, rel
            rhat = r.copy()  # recurrence drifted: restart from the true residual
            p = r.copy()
            rho = float(rhat @ r)
            continue
        z = precond(s)
        A.matvec(z, t)
        tt = float(t @ t)
        omega = float(t @ s) / tt if tt > 0.0 else 0.0
        x += alpha * y + omega * z
        r = s - omega * t
        rel = float(np.linalg.norm(r)) / bnorm
        if rel <= rtol:
            A.residual(x, b, r)
            rel = float(np.linalg.norm(r)) / bnorm
            if rel <= rtol:
                return x, it, rel
            rhat = r.copy()
            p = r.copy()
            rho = float(rhat @ r)
            continue
        rho_new = float(rhat @ r)
        if rho == 0.0 or omega == 0.0:
            break  # breakdown; the caller sees the residual
        beta = (rho_new / rho) * (alpha / omega)
        rho = rho_new
        p = r + beta * (p - omega * v)
    A.residual(x, b, r)
    return x, it, float(np.linalg.norm(r)) / bnorm


def warm_up():
    """Compile the loops on a tiny system."""
    A = sp.csr_matrix(np.array([[2.0, -1.0], [-1.0, 2.0]]))
    c = _Csr(A)
    x = np.zeros(2)
    b = np.ones(2)
    out = np.empty(2)
    spmv(c.indptr, c.indices, c.data, x, out)
    residual(c.indptr, c.indices, c.data, x, b, out)
    spmv_serial(c.indptr, c.indices, c.data, x, out)
    residual_serial(c.indptr, c.indices, c.data, x, b, out)
    gauss_seidel_serial(c.indptr, c.indices, c.data, x, b, True)
    bl = _Blocks(np.array([0, 1], dtype=np.int32))
    gauss_seidel(c.indptr, c.indices, c.data, x, b, True, bl.rows, bl.rows_start, bl.block,
                 np.empty(2))
    _boundary_blocks(c.indptr, c.indices, 1, bl.block)
