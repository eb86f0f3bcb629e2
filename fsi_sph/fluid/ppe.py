"""Pressure Poisson equation: numba assembly straight into CSR arrays, pyamg solve.

The matrix has one row per fluid particle (the blended Morris-Laplacian rows of
[F 17, F 20-21]) and one per wall particle (Adami's extrapolation, PHYSICS.md §2), so the
fluid and the wall pressures come out of the same solve. It is not symmetric (blended rows,
wall rows), so the Krylov method is BiCGStab or GMRES, preconditioned by an AMG hierarchy.

Hierarchy reuse: building the AMG hierarchy costs about as much as a solve, and the matrix
changes little from one step to the next. The hierarchy built on an earlier matrix (its
splitting, ``P``, ``R`` and coarse matrices) stays the preconditioner as long as the
iteration count stays within ``rebuild_growth`` times the count right after the last rebuild
(and at most ``rebuild_every`` steps); then it is rebuilt. Its finest level is this step's
matrix (``refresh_finest``: smoothing and residual with the current matrix, one pass over it
per step): with the old finest matrix the dam break's V-cycles grew by about one per step
(6 -> 10 in 7 steps, then a rebuild); with the current one they stay at the fresh
hierarchy's count. When the rows are renumbered (open boundaries: particles come and go),
the hierarchy follows them (:meth:`PressureSolver.remap`) instead of being rebuilt.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import pyamg
import scipy.sparse as sp

from fsi_sph.errors import SimulationError
from fsi_sph.fluid import _kernels as K
from fsi_sph.fluid import amg, krylov


@dataclass
class PPEStats:
    """One pressure solve: Krylov iterations, final relative residual ||b - A p|| / ||b||,
    wall times (s) of the assembly, of the AMG set-up (0 when reused) and of the solve."""

    iterations: int = 0
    residual: float = 0.0
    assemble_time: float = 0.0
    setup_time: float = 0.0
    solve_time: float = 0.0
    rebuilt: bool = False
    n_unknowns: int = 0
    vcycles: int = 0  # preconditioner (AMG V-cycle) applications
    matvecs: int = 0  # products with A, residual evaluations included


def assemble(x, vol, alpha, source, L, consistent, f_start, f_j, w_start, w_j, nf, nw, h, kind,
             eta2, lap_scale, diag_ref, rho, gb, implicit=None, pair_w=None):
    """Build the PPE as a ``scipy.sparse.csr_array`` and its right-hand side.

    Rows are counted first (:func:`_kernels.ppe_row_lengths`), then filled in place
    (:func:`_kernels.ppe_fill`); see there for the equations.
    """
    n = nf + nw
    if pair_w is None:  # plain pair terms (the identity) where rows are implicit
        implicit_rows = implicit is not None and bool(np.any(implicit > 0.0))
        pair_w = np.tile(np.eye(2), (nf, 1, 1)) if implicit_rows else np.zeros((0, 2, 2))
    row_len = np.empty(n, dtype=np.int64)
    K.ppe_row_lengths(alpha, f_start, w_start, nf, nw, row_len)
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(row_len, out=indptr[1:])
    nnz = int(indptr[-1])
    indices = np.empty(nnz, dtype=np.int32)  # pyamg's C++ routines take int32 indices
    data = np.empty(nnz, dtype=np.float64)
    b = np.empty(n, dtype=np.float64)
    K.ppe_fill(x, vol, alpha, source, L, consistent, f_start, f_j, w_start, w_j, nf, nw, h, kind,
               eta2, lap_scale, diag_ref, rho, gb,
               np.zeros(nw) if implicit is None else implicit, pair_w, indptr, indices, data, b)
    A = sp.csr_array((data, indices, indptr.astype(np.int32)), shape=(n, n))
    A.has_sorted_indices = True
    return A, b


def increment_rhs(A, b, p_n, alpha, dirichlet, nf):
    """Right-hand side of the PPE for the increment ``phi = p^{n+1} - p^n`` of the incremental
    projection (Goda 1979; van Kan 1986) with the standard matrix ``A`` (:func:`assemble`,
    whose right-hand side ``b`` was built from the source of the incremental ``u*``).

    A fluid row is ``alpha_i (-lap p_i - source_i) + (1 - alpha_i) D_i p_i = 0`` (the [F 20-21]
    blend of the Poisson row and the free-surface row ``p_i = 0``, ``D_i = A_ii``). For the
    increment the Poisson part is ``-lap phi_i = source_i`` (the source of the incremental
    ``u*``) and the surface part is ``p^{n+1}_i = 0``, i.e. ``phi_i = -p^n_i``::

        (A phi)_i = alpha_i source_i - (1 - alpha_i) A_ii p^n_i

    (``alpha_i`` taken as 0 on the pure Dirichlet rows, ``dirichlet``: free surface or no
    neighbours, where ``b_i = 0``). A boundary row imposes on ``p^{n+1}`` the standard row's
    condition (Adami's extrapolation), so its increment is the residual of ``p^n`` in it::

        (A phi)_w = b_w - (A p^n)_w

    which vanishes for a fluid at rest whose ``p^n`` is hydrostatic."""
    out = b - A @ p_n
    blend = np.where(dirichlet, 0.0, alpha)
    out[:nf] = b[:nf] - (1.0 - blend) * A.diagonal()[:nf] * p_n[:nf]
    return out


class KeptPreconditioner:
    """The reuse policy of a preconditioner kept across steps (module docstring), for the
    serial solver and PETSc's (fsi_sph/parallel/petsc_ppe.py): ``cfg`` a ``PPESection``."""

    def __init__(self, cfg):
        self.cfg = cfg
        self.age = 0  # solves since it was built
        self.base_iterations = None  # iterations of its first solve
        self.last_iterations = 0

    def built(self):
        """A new preconditioner: its age and iteration base start anew."""
        self.age = 0
        self.base_iterations = None

    def stale(self):
        """Due for a rebuild: ``rebuild_every`` solves old, or the last solve's iterations
        past ``max(rebuild_growth * base, base + 2)``."""
        if self.age >= self.cfg.rebuild_every:
            return True
        base = self.base_iterations
        if base is None:
            return False
        return self.last_iterations > max(self.cfg.rebuild_growth * base, base + 2)

    def solved(self, stats, solver="PPE"):
        """Count a solve (``PPEStats``); raises ``RuntimeError`` when it did not converge."""
        self.last_iterations = stats.iterations
        if self.base_iterations is None:
            self.base_iterations = stats.iterations
        self.age += 1
        if stats.residual > self.cfg.rtol:
            raise SimulationError(f"{solver}: no convergence in {self.cfg.maxiter} iterations "
                               f"(relative residual {stats.residual:.3g} > {self.cfg.rtol:g})")


class PressureSolver(KeptPreconditioner):
    """pyamg-preconditioned Krylov solver with the hierarchy-reuse policy of the module
    docstring. ``cfg`` is a ``PPESection``."""

    def __init__(self, cfg):
        super().__init__(cfg)
        self.vcycle = None

    def _needs_rebuild(self, n):
        return self.vcycle is None or self.vcycle.n != n or self.stale()

    def _build(self, A, nf=None):
        if self.cfg.amg == "ruge_stuben":
            # one forward Gauss-Seidel sweep before and one backward sweep after the coarse
            # correction: half the cost of the default symmetric sweeps, same iterations
            # RS coarsening with its second pass (which makes every strong F-F connection
            # share a C point): operator complexity 1.34 instead of 1.33, and BiCGStab
            # iterations to rtol 1e-6 from a zero guess 3/3/4 instead of 5/5/7 at
            # 10k/40k/160k unknowns of the dam break's PPE
            ml = pyamg.ruge_stuben_solver(
                A, CF=("RS", {"second_pass": True}), max_coarse=500, coarse_solver="splu",
                strength=("classical", {"theta": self.cfg.strength_theta}),
                presmoother=("gauss_seidel", {"sweep": "forward"}),
                postsmoother=("gauss_seidel", {"sweep": "backward"}))
        else:
            ml = amg.seeded_build(pyamg.smoothed_aggregation_solver, A,
                                       symmetry="nonsymmetric", max_coarse=500,
                                       coarse_solver="splu")
        # the V-cycle applied by numba (fsi_sph/fluid/amg.py), finest level in two blocks;
        # pyamg's own object is not kept: it holds the matrix it was built on (replaced on
        # the finest level at every later step) and each level's strength-of-connection
        # matrix, which the V-cycle does not use (with it the hierarchy held about 1 kB per
        # fluid particle at 1 M particles; validation/benchmark_scaling.py)
        self.vcycle = amg.VCycle(ml, amg.two_blocks(A, nf) if nf else None)
        self.built()

    def remap(self, old_of_new):
        """The rows were renumbered (open boundaries): keep the hierarchy for the rows that
        stay (:meth:`amg.VCycle.remap`) instead of building a new one at the next solve."""
        if self.vcycle is None:
            return
        if not self.cfg.refresh_finest or not self.vcycle.remap(old_of_new):
            self.vcycle = None  # (without the refresh the finest matrix would not fit)

    def reset(self):
        """Drop the hierarchy; the next solve builds a new one. Called at every snapshot, so
        that a run restarted from a snapshot uses the same preconditioners as an
        uninterrupted one (bit-identical restart)."""
        self.vcycle = None
        self.built()

    def solve(self, A, b, x0, nf=None, low_rank=None):
        """Solve ``A p = b`` from the initial guess ``x0`` (the last pressure); returns
        ``(p, PPEStats)``. ``nf``: the number of fluid rows (the rest are boundary rows), used
        to split the smoother's blocks. ``low_rank``: the free bodies'
        :class:`~fsi_sph.fluid.boundary.RigidTerms` ``U, G``: solve ``(A + U G) p = b``
        instead (the AMG hierarchy is still that of ``A``). Raises ``RuntimeError`` if the
        iteration limit is reached."""
        stats = PPEStats(n_unknowns=A.shape[0])
        bnorm = float(np.linalg.norm(b))
        if bnorm == 0.0:
            return np.zeros_like(b), stats
        Ac = amg.as_csr(A)
        if self._needs_rebuild(A.shape[0]):
            self._timed_build(A, stats, nf)
        elif self.cfg.refresh_finest:
            # the kept hierarchy's coarse levels with this step's matrix on the finest level
            self.vcycle.refresh_finest(Ac, amg.two_blocks(A, nf) if nf else None)
        op = Ac if low_rank is None else amg.LowRank(Ac, low_rank.U, low_rank.G())
        p = self._krylov(op, b, x0, bnorm, stats)
        if stats.residual > self.cfg.rtol and not stats.rebuilt:
            # a stale hierarchy that no longer preconditions well: rebuild and solve again
            self._timed_build(A, stats, nf)
            p = self._krylov(op, b, p, bnorm, stats)
        self.solved(stats)
        return p, stats

    def _timed_build(self, A, stats, nf=None):
        t0 = time.perf_counter()
        self._build(A, nf)
        stats.rebuilt = True
        stats.setup_time += time.perf_counter() - t0

    def _krylov(self, A, b, x0, bnorm, stats):
        """``A``: the matrix as :func:`amg.as_csr` arrays."""
        t0 = time.perf_counter()
        counts = krylov.Counts()
        solver = krylov.bicgstab if self.cfg.krylov == "bicgstab" else krylov.fgmres
        kw = {} if self.cfg.krylov == "bicgstab" else {"restart": self.cfg.gmres_restart}
        p, its, res = solver(A, b, x0, self.vcycle, self.cfg.rtol, self.cfg.maxiter,
                             counts=counts, **kw)
        stats.iterations += its
        stats.residual = res
        stats.vcycles += counts.precond
        stats.matvecs += counts.matvecs
        stats.solve_time += time.perf_counter() - t0
        return p
