"""The linear solves of the implicit viscous step: CG or BiCGStab with a smoothed-
aggregation AMG per velocity component (the Morris matrix), flexible GMRES with a kept AMG
V-cycle for the coupled stress system, a sparse LU when an iterative solve does not
converge, and the guard against an amplifying stress step."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import pyamg
import scipy.sparse as sp

from fsi_sph.fluid import amg, krylov


@dataclass
class ViscousStats:
    """One implicit viscous solve: CG iterations (sum over both components), largest final
    relative residual, wall time (s)."""

    iterations: int = 0
    residual: float = 0.0
    time: float = 0.0
    fallback: bool = False  # the stress operator's solve was replaced by the Morris one


def solve(A, rhs, x0, rtol):
    """Solve ``A u = rhs`` column by column (CG + smoothed-aggregation AMG); returns
    ``(u, ViscousStats)``."""
    t0 = time.perf_counter()
    n = A.shape[0]
    out = np.empty_like(rhs)
    stats = ViscousStats()
    if n == 0:
        return out, stats
    A = sp.csr_matrix(A)
    A.indices = A.indices.astype(np.int32)
    A.indptr = A.indptr.astype(np.int32)
    sym = abs(A - A.T).max() <= 1e-12 * abs(A).max()
    accel = "cg" if sym else "bicgstab"
    ml = amg.seeded_build(pyamg.smoothed_aggregation_solver, A,
                          symmetry="symmetric" if sym else "nonsymmetric", max_coarse=50)
    for k in range(rhs.shape[1]):
        b = np.ascontiguousarray(rhs[:, k])
        res = []
        u = ml.solve(b, x0=np.ascontiguousarray(x0[:, k]), tol=rtol, accel=accel, maxiter=200,
                     residuals=res)
        nb = np.linalg.norm(b)
        rel = float(np.linalg.norm(b - A @ u) / nb) if nb > 0 else 0.0
        if not rel <= 10.0 * rtol:  # not converged: a direct solve, so the step stays right
            from scipy.sparse.linalg import spsolve

            u = spsolve(A.tocsc(), b)
            rel = float(np.linalg.norm(b - A @ u) / nb) if nb > 0 else 0.0
        out[:, k] = u
        stats.iterations += max(len(res) - 1, 0)
        stats.residual = max(stats.residual, rel)
    stats.time = time.perf_counter() - t0
    return out, stats


def solve_implicit(A, rhs, x0, rtol, coupled=None, pre=None):
    """The implicit viscous step's solve: ``A u = rhs`` per component (:func:`solve`), or
    with ``coupled = (B, b, dt)`` the stress operator's ``(blockdiag(A, A) - dt B) U = b``
    (:func:`solve_coupled`, ``U = [u_x; u_y]``, hierarchy kept in ``pre``), replaced by the
    Morris step where it amplifies (:func:`amplifies`). ``rhs, b, x0``: (n, 2). Returns
    ``(u (n, 2), ViscousStats)``."""
    if coupled is None:
        return solve(A, rhs, x0, rtol)
    B, b, dt = coupled
    n = A.shape[0]
    u, stats = solve_coupled(A, CoupledMatrix(A, B, dt), b.T.reshape(-1), x0.T.reshape(-1),
                             rtol, pre)
    u = u.reshape(2, n).T
    if amplifies(u, b):
        u, stats = solve(A, rhs, x0, rtol)
        stats.fallback = True
    return u, stats


class CoupledMatrix:
    """``blockdiag(A, A) - dt B`` of the stress operator's step as products (``A`` the Morris
    matrix, ``B`` the transposed term, :class:`TransposeTerm` or a sparse matrix);
    ``tocsr()`` assembles it (direct solve)."""

    def __init__(self, A, B, dt):
        self.A, self.B, self.dt = A, B, dt
        self.n = A.shape[0]
        self.shape = (2 * self.n, 2 * self.n)
        self.dtype = np.dtype(np.float64)

    def __matmul__(self, U):
        n = self.n
        return np.concatenate([self.A @ U[:n], self.A @ U[n:]]) - self.dt * (self.B @ U)

    def tocsr(self):
        return sp.csr_array(sp.block_diag([self.A, self.A], format="csr")
                            - self.dt * self.B.tocsr())


#: the stress operator's solution may exceed the bound of the Morris one by this factor
AMPLIFICATION_LIMIT = 2.0


def amplifies(u, rhs):
    """True if the implicit stress-operator step ``u`` (nf, 2) has a component larger than
    ``AMPLIFICATION_LIMIT`` times the largest of the right-hand side ``rhs`` (nf, 2).

    The Morris matrix ``A = I + dt (D - C)`` is an M-matrix whose row sums are at least 1,
    so its solution obeys ``max_i |u_i,k| <= max_i |rhs_i,k|`` per component: viscosity
    only takes velocity away. The nested corrected gradients of the transposed term ``B``
    carry no such guarantee: on a lopsided support (a few particles left on the floor, the
    correction matrices up to ``1 / DET_MIN``) ``blockdiag(A, A) - dt B`` can be nearly
    singular, and at ``dt nu / dx^2 ~ 4-50`` its solution was 8 m/s for a right-hand side of
    0.03 m/s (a = 8 collapse, deposit at rest: a particle thrown at 45 m/s;
    docs/numerics/granular.md, "Implicit viscous step"). Such a step is not a viscous step."""
    for k in range(2):
        bound = float(np.max(np.abs(rhs[:, k]))) if len(rhs) else 0.0
        if float(np.max(np.abs(u[:, k]), initial=0.0)) > AMPLIFICATION_LIMIT * bound + 1e-12:
            return True
    return False


def solve_coupled(A, A2, b, x0, rtol, pre=None):
    """The coupled system ``A2 U = b`` of the stress operator (a sparse matrix or a
    :class:`CoupledMatrix`) by flexible GMRES (:func:`krylov.fgmres`), preconditioned by a
    smoothed-aggregation AMG V-cycle of the Morris matrix ``A`` on each velocity component
    (the block diagonal of ``A2``; the transposed part ``dt B`` it leaves out is of the same
    order but couples the components); ``pre`` a :class:`MorrisPreconditioner` that keeps
    the hierarchy across steps (None: a fresh one). A sparse LU (:func:`solve_direct`) if
    GMRES does not reach ``10 rtol`` in 200 iterations. Returns ``(u, ViscousStats)``."""
    t0 = time.perf_counter()
    n = A.shape[0]
    if n == 0:
        return np.zeros(0), ViscousStats()
    pre = MorrisPreconditioner() if pre is None else pre
    vc = pre.prepare(A)

    def apply(r):
        return np.concatenate([vc(r[:n]), vc(r[n:])])

    u, its, rel = krylov.fgmres(_Operator(A2), np.ascontiguousarray(b, dtype=np.float64),
                             np.ascontiguousarray(x0, dtype=np.float64), apply, rtol, 200,
                             restart=50)
    pre.record(its)
    if not rel <= 10.0 * rtol:  # not converged: a direct solve, so the step stays right
        return solve_direct(A2 if sp.issparse(A2) else A2.tocsr(), b)
    stats = ViscousStats()
    stats.iterations = its
    stats.residual = rel
    stats.time = time.perf_counter() - t0
    return u, stats


class _Operator:
    """``matvec`` and ``residual`` of a sparse matrix or a :class:`CoupledMatrix` for
    :func:`krylov.fgmres`."""

    def __init__(self, M):
        self.M = M
        self.shape = M.shape

    def matvec(self, x, out=None):
        y = self.M @ x
        if out is None:
            return y
        out[:] = y
        return out

    def residual(self, x, b, out):
        np.subtract(b, self.M @ x, out=out)
        return out


class MorrisPreconditioner:
    """The smoothed-aggregation hierarchy of the Morris matrix as a numba V-cycle
    (:class:`amg.VCycle`), kept across steps like the PPE's (:mod:`ppe`): each step its
    finest level is the step's matrix (``refresh_finest``), and the hierarchy is rebuilt
    every ``REBUILD_EVERY`` steps, when the GMRES iterations exceed ``GROWTH`` times those
    right after the last rebuild (plus 2), or when the number of unknowns changes. The
    set-up was 44 ms of a 160 ms mu(I) step at 3 250 particles."""

    REBUILD_EVERY = 10
    GROWTH = 1.5

    def __init__(self):
        self.vc = None
        self.age = 0
        self.base = None
        self.stale = False

    def prepare(self, A):
        """The V-cycle for this step's Morris matrix ``A``."""
        n = A.shape[0]
        if (self.vc is None or self.stale or self.age >= self.REBUILD_EVERY
                or self.vc.A[0].shape[0] != n):
            ml = amg.seeded_build(pyamg.smoothed_aggregation_solver, sp.csr_matrix(A),
                                  symmetry="nonsymmetric", max_coarse=50)
            self.vc = amg.VCycle(ml)
            self.age, self.base, self.stale = 0, None, False
        else:
            self.vc.refresh_finest(A)
            self.age += 1
        return self.vc

    def record(self, iterations):
        """The iterations of this step's solve (decides the next rebuild)."""
        if self.base is None:
            self.base = iterations
        self.stale = iterations > self.GROWTH * self.base + 2


def solve_direct(A, b):
    """Sparse LU (SuperLU) solve of the coupled system. Its nested operator reaches two
    neighbour rings and is not symmetric; there the smoothed-aggregation set-up of the
    AMG-Krylov path costs more per step than a direct factorisation at the sizes of the
    mu(I) cases (2 nf <= ~10^4 unknowns). Returns ``(u, ViscousStats)``."""
    from scipy.sparse.linalg import splu

    t0 = time.perf_counter()
    stats = ViscousStats()
    if A.shape[0] == 0:
        return np.zeros(0), stats
    u = splu(sp.csc_matrix(A)).solve(b)
    nb = np.linalg.norm(b)
    stats.residual = float(np.linalg.norm(b - A @ u) / nb) if nb > 0 else 0.0
    stats.time = time.perf_counter() - t0
    return u, stats
