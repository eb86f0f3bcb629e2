"""Applying a pyamg hierarchy fast: a numba V-cycle (the Krylov solvers it preconditions
are in :mod:`fsi_sph.fluid.krylov`).

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

from fsi_sph.neighbors import transpose_order


def seeded_build(build, *args, **kwargs):
    """``build(*args, **kwargs)`` with numpy's global random state fixed, then restored.

    pyamg's smoothed aggregation estimates the spectral radius of ``D^-1 A`` (for its
    prolongation smoother) by Arnoldi/Lanczos from ``np.random.rand`` start vectors, so two
    builds of one matrix differ at round-off, and a chaotic flow (the mu(I) collapse)
    amplified that into run-outs that differed by 0.1 in r between identical runs. Seeding
    makes the hierarchy, and with it every run, reproducible."""
    # pyamg draws from numpy's legacy global generator, so that is the one to fix
    state = np.random.get_state()  # noqa: NPY002
    np.random.seed(20261130)  # noqa: NPY002
    try:
        return build(*args, **kwargs)
    finally:
        np.random.set_state(state)  # noqa: NPY002


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
def _sweep_rows(indptr, indices, data, dinv, block, xx, b, rows, lo, hi, forward):
    """Gauss-Seidel over ``rows[lo:hi]`` (in increasing or decreasing order) on the matrix
    itself (``indptr, indices, data``): ``x_i = (b_i - sum_{j != i} a_ij x_j) / a_ii``
    (``dinv`` = 1 / a_ii; a row with a_ii = 0, dinv 0, is left as it is), where a column
    ``j`` of another block than the row's (``block``) is read from the frozen copy
    ``xx[n + j]``."""
    n = b.shape[0]
    m = hi - lo
    for step in range(m):
        i = rows[lo + (step if forward else m - 1 - step)]
        s = b[i]
        bi = block[i]
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            if j == i:
                continue
            s -= data[k] * xx[j if block[j] == bi else n + j]
        if dinv[i] != 0.0:
            xx[i] = s * dinv[i]


@njit(cache=True, parallel=True)
def gauss_seidel(indptr, indices, data, dinv, block, xx, b, forward, rows, rows_start):
    """One hybrid Gauss-Seidel sweep on ``A x = b`` in place, ``x = xx[:n]``.

    The rows are split into blocks (block ``q`` holds ``rows[rows_start[q]:rows_start[q+1]]``,
    ``block[i]`` is row ``i``'s) swept in parallel: each block is a Gauss-Seidel sweep over
    its rows in increasing (``forward``) or decreasing order that reads the other blocks'
    unknowns as they were before the sweep, from ``xx[n:]``. It reads ``A`` itself (an
    off-diagonal copy with the other blocks' columns moved to ``n + j`` held a quarter of the
    step's memory at 1 M particles and cost a pass over ``A`` per step; the sums are the
    same, in the same order). The result depends on the blocks only, never on the number of
    threads."""
    n = b.shape[0]
    for i in prange(n):
        xx[n + i] = xx[i]
    for q in prange(rows_start.shape[0] - 1):
        _sweep_rows(indptr, indices, data, dinv, block, xx, b, rows, rows_start[q],
                    rows_start[q + 1], forward)


@njit(cache=True)
def gauss_seidel_serial(indptr, indices, data, dinv, x, b, forward):
    """One plain Gauss-Seidel sweep in place, on one thread (off-diagonal part and ``dinv``
    as in :func:`gauss_seidel`)."""
    n = x.shape[0]
    for step in range(n):
        i = step if forward else n - 1 - step
        s = b[i]
        for k in range(indptr[i], indptr[i + 1]):
            s -= data[k] * x[indices[k]]
        if dinv[i] != 0.0:
            x[i] = s * dinv[i]


@njit(cache=True)
def _split_off_diagonal(indptr, indices, data, n, out_indptr, out_indices, out_data, dinv):
    """The off-diagonal part of a CSR matrix (entries in the original order) and 1 / the
    diagonal (the sum of the diagonal entries; 0 where that is 0)."""
    m = 0
    for i in range(n):
        out_indptr[i] = m
        d = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            if j == i:
                d += data[k]
            else:
                out_indices[m] = j
                out_data[m] = data[k]
                m += 1
        dinv[i] = 1.0 / d if d != 0.0 else 0.0
    out_indptr[n] = m
    return m


@njit(cache=True, parallel=True)
def _inverse_diagonal(indptr, indices, data, dinv):
    """1 / the diagonal of a CSR matrix (the sum of the row's diagonal entries; 0 where that
    is 0), as :func:`_split_off_diagonal` computes it."""
    for i in prange(dinv.shape[0]):
        d = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            if indices[k] == i:
                d += data[k]
        dinv[i] = 1.0 / d if d != 0.0 else 0.0


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


class _Smoother:
    """Gauss-Seidel data of one level: ``1 / diag(A)``; in blocks (the finest level) ``A``
    itself and the blocks' row lists (:func:`gauss_seidel`), else (plain Gauss-Seidel, the
    small coarse levels) a copy of ``A``'s off-diagonal part."""

    def __init__(self, A, block=None):
        self._indices = np.empty(0, dtype=np.int32)
        self._data = np.empty(0)
        self.dinv = np.empty(0)
        self.update(A, block)

    def update(self, A, block=None):
        """Rebuild from ``A`` (a :class:`_Csr`), reusing the arrays when they are large
        enough (a refresh every step: no new memory to fault in). In blocks (the finest
        level) the sweep reads ``A`` itself and only ``1 / diag(A)`` is made here."""
        n = A.shape[0]
        self.n = n
        self.blocks = _Blocks(block) if block is not None else None
        if len(self.dinv) != n:  # (a refresh of the same size writes into the last one)
            self.dinv = np.empty(n)
        if block is not None:
            self.indptr, self.indices, self.data = A.indptr, A.indices, A.data
            _inverse_diagonal(A.indptr, A.indices, A.data, self.dinv)
            return
        nnz = len(A.data)
        if len(self._data) < nnz:
            self._indices = np.empty(nnz, dtype=np.int32)
            self._data = np.empty(nnz)
        self.indptr = np.empty(n + 1, dtype=np.int32)
        m = _split_off_diagonal(A.indptr, A.indices, A.data, n, self.indptr, self._indices,
                                self._data, self.dinv)
        self.indices = self._indices[:m]
        self.data = self._data[:m]

    def zeros(self):
        """A zero ``x`` for the sweeps (with room for the frozen copy when in blocks)."""
        if self.blocks is None:
            return np.zeros(self.n)
        return np.zeros(2 * self.n)[:self.n]

    def sweep(self, x, b, forward):
        if self.blocks is None:
            gauss_seidel_serial(self.indptr, self.indices, self.data, self.dinv, x, b, forward)
        else:
            gauss_seidel(self.indptr, self.indices, self.data, self.dinv, self.blocks.block,
                         x.base, b, forward, self.blocks.rows, self.blocks.rows_start)


PARALLEL_ROWS = 8000  # below this many rows a loop runs on one thread (fewer barriers)


@njit(cache=True)
def take_rows(indptr, indices, data, old):
    """CSR arrays ``(indptr, indices, data)`` of the matrix whose row ``i`` is row
    ``old[i]`` of the given one, or empty where ``old[i] < 0``; explicit zeros dropped (as a
    sparse product would). Rows keep their order of columns."""
    n = len(old)
    ptr = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        count = 0
        if old[i] >= 0:
            for k in range(indptr[old[i]], indptr[old[i] + 1]):
                if data[k] != 0.0:
                    count += 1
        ptr[i + 1] = ptr[i] + count
    out_indices = np.empty(ptr[n], dtype=indices.dtype)
    out_data = np.empty(ptr[n], dtype=np.float64)
    for i in range(n):
        e = ptr[i]
        if old[i] >= 0:
            for k in range(indptr[old[i]], indptr[old[i] + 1]):
                if data[k] != 0.0:
                    out_indices[e] = indices[k]
                    out_data[e] = data[k]
                    e += 1
    return ptr, out_indices, out_data


def transpose(indptr, indices, data, n_cols):
    """CSR arrays of the transpose, each row sorted by column
    (:func:`fsi_sph.neighbors.transpose_order`)."""
    t_start, t_idx, perm = transpose_order(indptr, indices, n_cols)
    return t_start, t_idx, data[perm]


class _Csr:
    """The three CSR arrays of a matrix, contiguous and typed for the numba loops."""

    def __init__(self, M):
        if not (sp.issparse(M) and M.format == "csr" and M.has_sorted_indices):
            M = sp.csr_matrix(M)  # (a CSR matrix known to be sorted is read as it is)
            if not M.has_sorted_indices:
                M.sort_indices()
        self.set_arrays(M.indptr, M.indices, M.data, M.shape)

    def set_arrays(self, indptr, indices, data, shape):
        """Hold the CSR arrays contiguous and typed for the numba loops."""
        self.indptr = np.ascontiguousarray(indptr, dtype=np.int32)
        self.indices = np.ascontiguousarray(indices, dtype=np.int32)
        self.data = np.ascontiguousarray(data, dtype=np.float64)
        self.shape = shape

    @classmethod
    def from_arrays(cls, indptr, indices, data, shape):
        """From CSR arrays whose rows are already sorted by column."""
        c = cls.__new__(cls)
        c.set_arrays(indptr, indices, data, shape)
        return c

    def matvec(self, x, out=None):
        out = np.empty(self.shape[0]) if out is None else out
        f = spmv if self.shape[0] >= PARALLEL_ROWS else spmv_serial
        f(self.indptr, self.indices, self.data, x, out)
        return out

    def residual(self, x, b, out):
        f = residual if self.shape[0] >= PARALLEL_ROWS else residual_serial
        f(self.indptr, self.indices, self.data, x, b, out)
        return out


class LowRank:
    """``A + U G``: a :class:`_Csr` plus a dense term of low rank ``m`` (``U`` n x m,
    ``G`` m x n), e.g. the rigid-body rows of free structures in the PPE. Krylov methods
    take it like a :class:`_Csr`; the preconditioner is built on ``A`` alone."""

    def __init__(self, A, U, G):
        self.A = A
        self.U = np.ascontiguousarray(U)
        self.G = np.ascontiguousarray(G)
        self.shape = A.shape

    def matvec(self, x, out=None):
        out = self.A.matvec(x, out)
        out += self.U @ (self.G @ x)
        return out

    def residual(self, x, b, out):
        self.A.residual(x, b, out)
        out -= self.U @ (self.G @ x)
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
        # the finest level (most of the work) is smoothed in blocks, coarser ones plainly
        self.smoothers = [_Smoother(a, block0 if lvl == 0 else None)
                          for lvl, a in enumerate(self.A[:-1])]
        self.applications = 0  # V-cycles applied so far (for the statistics)

    @property
    def n(self):
        """Rows of the finest level (of ``P`` after a :meth:`remap`)."""
        return self.P[0].shape[0] if self.P else self.A[0].shape[0]

    def remap(self, old_of_new):
        """The finest level's rows are renumbered (open boundaries: particles come and go
        between steps): new row ``i`` is old row ``old_of_new[i]``, or a new particle
        (``-1``). ``P`` keeps the rows of the particles that stay (a new particle's row is
        zero: the smoother alone acts on it until the next rebuild) and ``R`` the same
        columns; the coarse levels are kept. The finest matrix comes with the next
        :meth:`refresh_finest`. Returns False for a one-level hierarchy (nothing to keep)."""
        if len(self.A) == 1:
            return False
        old = np.asarray(old_of_new, dtype=np.int64)
        P, R = self.P[0], self.R[0]
        self.P[0] = _Csr.from_arrays(*take_rows(P.indptr, P.indices, P.data, old),
                                     (len(old), P.shape[1]))
        # R's columns follow the rows of P: the rows of R^T, taken the same way
        RT = take_rows(*transpose(R.indptr, R.indices, R.data, R.shape[1]), old)
        self.R[0] = _Csr.from_arrays(*transpose(*RT, R.shape[0]), (R.shape[0], len(old)))
        self.work[0] = np.empty(len(old))
        return True

    def refresh_finest(self, A, block0=None):
        """Smooth and compute residuals on the finest level with ``A`` (same size as the
        matrix the hierarchy was built on), keeping the coarse levels, ``P`` and ``R``.

        For the PPE of a later step this is nearly as good as a new hierarchy: on the dam
        break at 43k unknowns a hierarchy 11 steps old takes 13 V-cycles (FGMRES) with its
        own finest matrix, 5 with the current one, 6 with a fresh hierarchy. Costs one pass
        over ``A`` (the off-diagonal split of :class:`_Smoother`)."""
        if A.shape[0] != self.n:
            raise ValueError(f"refresh_finest: {A.shape} instead of {self.n} rows")
        self.A[0] = A if isinstance(A, _Csr) else _Csr(A)
        if len(self.A) == 1:  # a one-level "hierarchy" is the LU solve of the matrix
            self.lu = spla.splu(sp.csc_matrix(sp.csr_matrix(
                (self.A[0].data, self.A[0].indices, self.A[0].indptr), shape=A.shape)))
        else:
            self.smoothers[0].update(self.A[0], block0)

    def __call__(self, r):
        self.applications += 1
        return self._cycle(0, np.ascontiguousarray(r, dtype=np.float64))

    def _cycle(self, lvl, b):
        if lvl == len(self.A) - 1:
            return self.lu.solve(b)
        A = self.A[lvl]
        sm = self.smoothers[lvl]
        x = sm.zeros()
        sm.sweep(x, b, True)
        res = A.residual(x, b, self.work[lvl])
        xc = self._cycle(lvl + 1, self.R[lvl].matvec(res))
        x += self.P[lvl].matvec(xc)
        sm.sweep(x, b, False)
        return x


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
    for block in (None, np.array([0, 1], dtype=np.int32)):
        sm = _Smoother(c, block)
        sm.sweep(sm.zeros(), b, True)
    _boundary_blocks(c.indptr, c.indices, 1, np.array([0, 1], dtype=np.int32))
    transpose(*take_rows(c.indptr, c.indices, c.data, np.array([1, -1])), 2)
