"""The pressure Poisson equation solved by PETSc over the MPI ranks (issue 32, item 3).

Each rank owns a contiguous block of global rows ``[row_start, row_start + n_local)`` and
passes them as CSR arrays whose column indices are GLOBAL rows. They become a PETSc ``aij``
matrix (``MPIAIJ`` on several ranks, ``SeqAIJ`` on one) preallocated from the row lengths,
solved by flexible GMRES (right preconditioning, so the residual it tests is the true one,
``||b - A p|| / ||b|| <= rtol``) preconditioned by hypre's BoomerAMG, or by PETSc's GAMG
where PETSc was built without hypre.

The preconditioner is kept across steps like the serial solver's AMG hierarchy
(:class:`fsi_sph.fluid.ppe.PressureSolver`): reused while the global size is unchanged, rebuilt
after ``rebuild_every`` solves or when the iterations grow past
``max(rebuild_growth * base, base + 2)``, and rebuilt once more (and the solve repeated) when
a solve with the kept one does not converge. Unlike the serial solver's ``refresh_finest`` a
kept BoomerAMG hierarchy smooths with the matrix it was built on; the Krylov method always
uses the current matrix.

The PETSc options prefix ``fsi_ppe_`` lets a run change the settings from the command line
or ``PETSC_OPTIONS`` (e.g. ``-fsi_ppe_ksp_monitor``,
``-fsi_ppe_pc_hypre_boomeramg_coarsen_type HMIS``). petsc4py is imported only when a solver
is made: this module imports without it (:func:`available`).
"""

from __future__ import annotations

import time

import numpy as np

from fsi_sph.fluid.ppe import KeptPreconditioner, PPEStats

#: options prefix of the PPE's KSP and PC
PREFIX = "fsi_ppe_"
#: BoomerAMG's smoother on every level, down and up: one forward Gauss-Seidel sweep within a
#: rank (Jacobi between ranks). PETSc's default (the symmetric sweep, twice the work) took the
#: same iterations and a third more time: dam break at 163 k, steps 300-307 on 2 ranks, 9.9
#: iterations a step either way, Krylov 0.88-0.93 s against 1.31-1.41 s over the 8 solves
#: (``validation/benchmark_petsc_ppe.py --step 300``; docs/parallel.md).
RELAX = "SOR/Jacobi"


def _petsc():
    """The ``petsc4py.PETSc`` module (initialises PETSc, and MPI, on first import)."""
    from petsc4py import PETSc

    return PETSc


def available() -> bool:
    """True when the petsc4py package can be imported. Does not load PETSc (nor start MPI):
    a test collection or a serial run that only asks stays free of MPI."""
    try:
        import petsc4py  # noqa: F401
    except ImportError:
        return False
    return True


def has_hypre() -> bool:
    """True when the PETSc build includes hypre (BoomerAMG)."""
    return available() and bool(_petsc().Sys.hasExternalPackage("hypre"))


def engine() -> str:
    """What solves the PPE with this module, e.g. ``"PETSc 3.18.5 fgmres + hypre
    BoomerAMG"``, or ``"pyamg (petsc4py not installed)"`` without petsc4py."""
    if not available():
        return "pyamg (petsc4py not installed)"
    version = ".".join(str(v) for v in _petsc().Sys.getVersion())
    pc = "hypre BoomerAMG" if has_hypre() else "GAMG"
    return f"PETSc {version} fgmres + {pc}"


def petsc_comm(comm=None):
    """A PETSc communicator: ``COMM_WORLD`` for None, ``COMM_SELF`` for a one-rank stand-in
    without MPI (``fsi_sph.parallel.comm.SerialComm``), else the mpi4py communicator's."""
    PETSc = _petsc()
    if comm is None:
        return PETSc.COMM_WORLD
    if isinstance(comm, PETSc.Comm):
        return comm
    if type(comm).__module__.startswith("mpi4py"):
        return PETSc.Comm(comm)
    if getattr(comm, "size", None) == 1:
        return PETSc.COMM_SELF
    raise TypeError(f"not an MPI communicator: {comm!r}")


def diagonal_block_counts(indptr, gcols, row_start, n_local):
    """Per local row, the entries whose column is owned by this rank (``d_nnz``) and the
    others (``o_nnz``): PETSc's MPIAIJ preallocation."""
    indptr = np.asarray(indptr)
    row_len = np.diff(indptr)
    own = (gcols >= row_start) & (gcols < row_start + n_local)
    rows = np.repeat(np.arange(n_local), row_len)
    d_nnz = np.bincount(rows, weights=own, minlength=n_local).astype(np.int64)
    return d_nnz, row_len - d_nnz


class PetscPressureSolver:
    """The PPE's rows of this rank solved with PETSc on ``comm`` (an mpi4py communicator;
    None: ``COMM_WORLD``); ``cfg`` a ``PPESection`` (``rtol``, ``maxiter``,
    ``gmres_restart``, ``rebuild_every``, ``rebuild_growth``, ``strength_theta``).
    ``pc``: ``"hypre"`` or ``"gamg"`` to choose the preconditioner (default: hypre's
    BoomerAMG when PETSc has it, else GAMG). Every rank calls :meth:`solve` together."""

    def __init__(self, cfg, comm=None, pc=None):
        self.PETSc = _petsc()
        self.cfg = cfg
        self.comm = petsc_comm(comm)
        self.pc_type = pc or ("hypre" if has_hypre() else "gamg")
        self.ksp = None
        self.mat = None
        self.vecs = None  # (x, b, r) in the matrix's layout
        self.pattern = None  # (row_start, indptr, gcols) of self.mat on this rank
        self.n_global = None
        self.op = None  # the operator: the matrix, or with free bodies A + U G (MATLRC)
        self.dense = None  # the storage of MATLRC's U and V (PETSc does not copy it)
        self.reuse = KeptPreconditioner(cfg)  # the serial solver's reuse policy

    # -- collective helpers -------------------------------------------------------------

    def _anywhere(self, flag: bool) -> bool:
        """``flag`` true on any rank (collective)."""
        if self.comm.size == 1:
            return bool(flag)
        return self.comm.tompi4py().allreduce(int(bool(flag))) > 0

    # -- matrix ----------------------------------------------------------------------------

    def _same_pattern(self, indptr, gcols, row_start):
        if self.pattern is None:
            return False
        start, old_ptr, old_cols = self.pattern
        return (start == row_start and len(old_ptr) == len(indptr)
                and np.array_equal(old_ptr, indptr) and np.array_equal(old_cols, gcols))

    def _same_layout(self, n_local, row_start, n_global):
        if self.mat is None or self.n_global != n_global:
            return False
        lo, hi = self.mat.getOwnershipRange()
        return lo == row_start and hi - lo == n_local

    def _matrix(self, indptr, gcols, data, row_start, n_global):
        """This step's matrix: the values put into the kept ``Mat`` where the layout and the
        pattern are those of the last step on every rank, else a new ``Mat``. Returns
        whether the row layout changed (a new KSP is then needed)."""
        PETSc = self.PETSc
        n_local = len(indptr) - 1
        ptr = np.asarray(indptr, dtype=PETSc.IntType)
        cols = np.asarray(gcols, dtype=PETSc.IntType)
        vals = np.asarray(data, dtype=PETSc.ScalarType)
        new_layout = self._anywhere(not self._same_layout(n_local, row_start, n_global))
        if new_layout or self._anywhere(not self._same_pattern(ptr, cols, row_start)):
            self._new_matrix(ptr, cols, row_start, n_global)
        self.mat.setValuesCSR(ptr, cols, vals)
        self.mat.assemble()
        return new_layout

    def _new_matrix(self, ptr, cols, row_start, n_global):
        PETSc = self.PETSc
        n_local = len(ptr) - 1
        if self.mat is not None:
            self.mat.destroy()
        d_nnz, o_nnz = diagonal_block_counts(ptr, cols, row_start, n_local)
        mat = PETSc.Mat().create(comm=self.comm)
        mat.setSizes(((n_local, n_global), (n_local, n_global)))
        mat.setType(PETSc.Mat.Type.AIJ)
        mat.setPreallocationNNZ((d_nnz.astype(PETSc.IntType), o_nnz.astype(PETSc.IntType)))
        mat.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, True)
        lo, _ = mat.getOwnershipRange()
        if lo != row_start:
            raise ValueError(f"rank {self.comm.rank}: rows start at {row_start}, but the "
                             f"ranks' row counts put them at {lo} (blocks not in rank order)")
        self.mat = mat
        self.vecs = (*mat.createVecs(), mat.createVecLeft())
        self.pattern = (row_start, ptr.copy(), cols.copy())
        self.n_global = n_global

    def _low_rank_operator(self, U, G):
        """``A + U G`` as PETSc's low-rank-correction matrix (``MATLRC``: ``A + U V^T`` with
        ``V = G^T``, both dense with this rank's rows; ``V^T x`` is summed over the ranks)."""
        PETSc = self.PETSc
        n_local, m = U.shape
        sizes = ((n_local, self.n_global), (PETSc.DECIDE, m))
        self.dense = [np.asfortranarray(U, dtype=PETSc.ScalarType),
                      np.asfortranarray(G.T, dtype=PETSc.ScalarType)]  # (PETSc's storage)
        u, v = (PETSc.Mat().createDense(sizes, array=a.ravel(order="F"), comm=self.comm)
                for a in self.dense)
        for mat in (u, v):
            mat.assemble()
        op = PETSc.Mat().createLRC(self.mat, u, None, v)
        op.setUp()
        u.destroy()
        v.destroy()
        return op

    # -- Krylov method and preconditioner ---------------------------------------------------

    def _new_ksp(self):
        PETSc = self.PETSc
        if self.ksp is not None:
            self.ksp.destroy()
        ksp = PETSc.KSP().create(comm=self.comm)
        ksp.setOptionsPrefix(PREFIX)
        ksp.setType(PETSc.KSP.Type.FGMRES)
        ksp.setGMRESRestart(self.cfg.gmres_restart)
        ksp.setPCSide(PETSc.PC.Side.RIGHT)
        ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
        ksp.setTolerances(rtol=self.cfg.rtol, atol=0.0, max_it=self.cfg.maxiter)
        ksp.setInitialGuessNonzero(True)
        self._set_pc(ksp.getPC())
        ksp.setFromOptions()
        self.ksp = ksp

    def _set_pc(self, pc):
        """BoomerAMG (strength threshold ``cfg.strength_theta``, smoother :data:`RELAX`) or
        GAMG with the non-symmetric graph; defaults only where the options database has no
        value."""
        PETSc = self.PETSc
        opts = PETSc.Options()
        if self.pc_type == "hypre":
            pc.setType(PETSc.PC.Type.HYPRE)
            pc.setHYPREType("boomeramg")
            defaults = {"pc_hypre_boomeramg_strong_threshold": self.cfg.strength_theta,
                        "pc_hypre_boomeramg_relax_type_all": RELAX}
        else:
            pc.setType(PETSc.PC.Type.GAMG)
            defaults = {"pc_gamg_sym_graph": "true", "mg_levels_ksp_type": "richardson",
                        "mg_levels_pc_type": "sor"}
        for key, value in defaults.items():
            if not opts.hasName(PREFIX + key):
                opts.setValue(PREFIX + key, value)

    def _needs_rebuild(self, n_global):
        return self.ksp is None or self.n_global != n_global or self.reuse.stale()

    def _setup(self, rebuild, stats):
        """Operators of this step; the preconditioner rebuilt (timed) or kept."""
        pc = self.ksp.getPC()
        pc.setReusePreconditioner(not rebuild)
        self.ksp.setOperators(self.op, self.mat)
        t0 = time.perf_counter()
        self.ksp.setUp()
        if rebuild:
            stats.setup_time += time.perf_counter() - t0
            stats.rebuilt = True
            self.reuse.built()

    def _krylov(self, x, b, bnorm, stats):
        """One KSP solve from ``x``; iterations, true relative residual, time."""
        t0 = time.perf_counter()
        self.ksp.solve(b, x)
        stats.iterations += self.ksp.getIterationNumber()
        r = self.vecs[2]
        self.op.mult(x, r)
        r.aypx(-1.0, b)  # r = b - A x
        stats.residual = r.norm() / bnorm
        stats.solve_time += time.perf_counter() - t0

    # -- the solve ---------------------------------------------------------------------------

    def solve(self, indptr, gcols, data, b, x0, row_start, n_global, low_rank=None):
        """Solve the global PPE; this rank passes its rows ``[row_start, row_start +
        n_local)`` as CSR (``indptr`` of length ``n_local + 1``, GLOBAL column indices
        ``gcols``, values ``data``), its part of the right-hand side ``b`` and of the
        initial guess ``x0``. Returns ``(x_local, PPEStats)`` (``n_unknowns``: the global
        row count). ``low_rank = (U, G)``, this rank's rows of ``U`` and columns of ``G``:
        solve ``(A + U G) x = b`` instead, the preconditioner built on ``A``. Raises
        ``RuntimeError`` (on every rank) when the relative residual is above ``cfg.rtol``
        after ``cfg.maxiter`` iterations."""
        stats = PPEStats(n_unknowns=int(n_global))
        rebuild = self._needs_rebuild(n_global)  # (before _matrix updates n_global)
        if self._matrix(indptr, gcols, data, row_start, n_global) or self.ksp is None:
            self._new_ksp()
            rebuild = True
        if self.op is not None and self.op is not self.mat:
            self.op.destroy()
        self.op = self.mat if low_rank is None else self._low_rank_operator(*low_rank)
        x, bv, _ = self.vecs
        bv.setArray(np.asarray(b, dtype=self.PETSc.ScalarType))
        x.setArray(np.asarray(x0, dtype=self.PETSc.ScalarType))
        bnorm = bv.norm()
        if bnorm == 0.0:
            return np.zeros(len(b)), stats
        self._setup(rebuild, stats)
        self._krylov(x, bv, bnorm, stats)
        if stats.residual > self.cfg.rtol and not stats.rebuilt:
            # a kept preconditioner that no longer works: rebuild and go on from x
            self._setup(True, stats)
            self._krylov(x, bv, bnorm, stats)
        self.reuse.solved(stats, "PPE (PETSc)")
        return x.getArray().copy(), stats

    def destroy(self):
        """Free the PETSc objects (collective)."""
        if self.op is not None and self.op is not self.mat:
            self.op.destroy()
        for obj in (self.ksp, self.mat, *(self.vecs or ())):
            if obj is not None:
                obj.destroy()
        self.ksp = self.mat = self.vecs = self.pattern = self.op = None
        self.n_global = None
