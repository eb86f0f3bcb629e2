"""Checks of fsi_sph.parallel.petsc_ppe on several ranks:
``mpiexec -n P python tests/parallel/petsc_checks.py PPE.npz``.

``PPE.npz`` holds one PPE (``indptr``, ``indices``, ``data``, ``b``: the whole matrix in CSR,
see :func:`first_step_ppe`); its rows are split into P contiguous blocks of unequal size.
Rank 0 solves the whole system alone (``COMM_SELF``) as the reference; then all ranks solve
it together and the gathered solution must be the one-rank one within ``AGREE * rtol``
(relative 2-norm), its residual (scipy, on rank 0) at most rtol. Then the kept
preconditioner: a second solve with the same rows (values changed) must reuse it, a
different pattern on one rank only must still reuse it (new Mat on every rank), and a
different split of the same rows must rebuild it. A failure prints the traceback and aborts
the whole job (non-zero exit); success prints ``petsc_checks OK`` on rank 0.
"""

from __future__ import annotations

import sys
import traceback
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # (run as a script)
from validation.benchmark_petsc_ppe import block, first_step_ppe  # noqa: E402, F401

CASE = Path(__file__).resolve().parents[2] / "cases" / "dam_break.toml"
#: solutions of the same system by different rank counts agree within AGREE * rtol
AGREE = 10.0


def save_ppe(path, A, b):
    np.savez(path, indptr=A.indptr, indices=A.indices, data=A.data, b=b)


def load_ppe(path):
    import scipy.sparse as sp

    d = np.load(path)
    n = len(d["b"])
    return sp.csr_array((d["data"], d["indices"], d["indptr"]), shape=(n, n)), d["b"]


def split(n, size, weights=None):
    """Row offsets of ``size`` contiguous blocks of ``n`` rows, sized by ``weights``."""
    w = np.ones(size) if weights is None else np.asarray(weights, dtype=float)
    return np.concatenate([[0], np.round(np.cumsum(w) / w.sum() * n).astype(int)])


def solve_rows(solver, A, b, cuts, rank):
    lo, hi = cuts[rank], cuts[rank + 1]
    return solver.solve(*block(A, lo, hi), b[lo:hi], np.zeros(hi - lo), lo, A.shape[0])


def check_split(comm, A, b, cfg):
    """The solution on all ranks is the one-rank solution."""
    from fsi_sph.parallel.petsc_ppe import PetscPressureSolver

    ref = None
    if comm.rank == 0:
        ref, _ = solve_rows(PetscPressureSolver(cfg, comm=comm.Split(0, 0)), A, b,
                            [0, A.shape[0]], 0)
    else:
        comm.Split(1, 0)  # (Split is collective)
    cuts = split(A.shape[0], comm.size, weights=np.arange(comm.size) + 2.0)
    solver = PetscPressureSolver(cfg, comm=comm)
    x, stats = solve_rows(solver, A, b, cuts, comm.rank)
    assert len(x) == cuts[comm.rank + 1] - cuts[comm.rank]
    assert stats.rebuilt and stats.residual <= cfg.rtol, stats
    parts = comm.gather(x, root=0)
    if comm.rank == 0:
        xs = np.concatenate(parts)
        res = np.linalg.norm(b - A @ xs) / np.linalg.norm(b)
        diff = np.linalg.norm(xs - ref) / np.linalg.norm(ref)
        print(f"split {list(cuts)}: {stats.iterations} iterations, residual {res:.3g}, "
              f"relative difference to one rank {diff:.3g}", flush=True)
        assert res <= cfg.rtol * 1.01, res
        assert diff <= AGREE * cfg.rtol, diff
    return solver, cuts


def check_reuse(comm, solver, cuts, A, b, cfg):
    """Kept preconditioner: same rows, then a new pattern on rank 0 only, then a new split."""
    import scipy.sparse as sp

    x, stats = solve_rows(solver, A * 1.01, b, cuts, comm.rank)
    assert not stats.rebuilt and stats.residual <= cfg.rtol, stats
    mat = solver.mat
    n = A.shape[0]
    extra = sp.csr_array(([1e-9 * abs(A.data).max()], ([0], [n - 1])), shape=A.shape)
    B = (A + extra).tocsr()
    B.sort_indices()
    x, stats = solve_rows(solver, B, b, cuts, comm.rank)
    assert not stats.rebuilt and stats.residual <= cfg.rtol, stats
    assert solver.mat is not mat, "a new pattern needs a new Mat on every rank"
    other = split(n, comm.size)  # equal blocks: another layout, same global size
    x, stats = solve_rows(solver, A, b, other, comm.rank)
    assert stats.rebuilt and stats.residual <= cfg.rtol, stats
    if comm.rank == 0:
        print("reuse: kept, kept with a new pattern, rebuilt for a new split", flush=True)


def main(argv):
    from mpi4py import MPI

    from fsi_sph.config.fluid import PPESection

    comm = MPI.COMM_WORLD
    try:
        assert comm.size > 1, "run under mpiexec -n 2 (or more)"
        A, b = load_ppe(argv[0])
        cfg = PPESection()
        solver, cuts = check_split(comm, A, b, cfg)
        check_reuse(comm, solver, cuts, A, b, cfg)
        solver.destroy()
    except Exception:
        traceback.print_exc()
        sys.stdout.flush()
        sys.stderr.flush()
        comm.Abort(1)
    if comm.rank == 0:
        print("petsc_checks OK", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
