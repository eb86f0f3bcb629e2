"""PETSc against the serial solver on one pressure Poisson equation (prints a table; not a
validation): the PPE of the dam break's first step (``cases/dam_break.toml``) at about
163 k unknowns (``case.dx = 0.00355``) and, with ``--sizes 163k,1M``, 1 M
(``case.dx = 0.00143``), solved from a zero initial guess to the case's ``rtol``.

Rows: the serial :class:`fsi_sph.fluid.ppe.PressureSolver` (pyamg Ruge-Stuben hierarchy,
numba V-cycle and FGMRES; with the numba thread count given, and with one thread), and
:class:`fsi_sph.parallel.petsc_ppe.PetscPressureSolver` (FGMRES + BoomerAMG, or GAMG) on
one rank in this process and on ``--ranks`` ranks under ``mpiexec`` (the rows split into
equal contiguous blocks; times are the slowest rank's). Columns: Krylov iterations, the
true relative residual, preconditioner set-up and Krylov solve wall times, and a second
solve with the kept preconditioner (``reuse``, set-up excluded; the serial solver refreshes
its finest level then). Needs petsc4py (the PETSc venv; see README); without it only the
serial rows are printed.

Usage::

    python validation/benchmark_petsc_ppe.py [--sizes 163k,1M] [--ranks 2] [--threads 2]
    python validation/benchmark_petsc_ppe.py --step 300 [--count 8] [--sizes 163k]

With ``--step N`` it compares iterations on the PPEs of a flow under way instead: the
serial run to step ``N + count`` records the PPEs of its last ``--count`` steps with the
iterations its own solver took (hierarchy kept and refreshed, as in a run); PETSc then
solves the same sequence, each from the serial run's initial guess, with its kept
preconditioner and the same rebuild policy, on 1 rank and on ``--ranks``. Printed: the
iterations per step, their means, and PETSc's mean over the serial one (the issue's
target: at most 1.5).

One PETSc solve on the ranks of an MPI job: ``mpiexec -n P python
validation/benchmark_petsc_ppe.py --worker PPE.npz`` (used by the table's runs).
"""

from __future__ import annotations

import os

# one BLAS thread before numpy loads (see fsi_sph.__main__._single_threaded_blas)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "cases" / "dam_break.toml"
#: label -> dx (m) of the 1 x 2 m column (fluid and wall rows together)
SIZES = {"41k": 0.0071, "163k": 0.00355, "1M": 0.00143}


def first_step_ppe(dx):
    """The PPE the dam break's first step passes to :meth:`PressureSolver.solve` (captured
    by wrapping it during one step): ``(A, b, x0, nf, cfg)``, ``cfg`` the case's PPE section."""
    from fsi_sph.config import load_config
    from fsi_sph.fluid.ppe import PressureSolver
    from fsi_sph.simulation import Simulation

    config = load_config(CASE, [f"case.dx={dx}"])
    sim = Simulation(config)
    captured = []
    original = PressureSolver.solve

    def spy(self, A, b, x0, nf=None, low_rank=None):
        if not captured:
            captured.append((A.copy(), b.copy(), np.array(x0, copy=True), nf))
        return original(self, A, b, x0, nf, low_rank)

    PressureSolver.solve = spy
    try:
        sim.step()
    finally:
        PressureSolver.solve = original
    return (*captured[0], config.fluid.ppe)


def run_ppes(dx, first, count):
    """The serial run's PPEs of steps ``first .. first + count - 1`` (counted from 0) as
    ``(A, b, x0)`` and the iterations its own solver took on each; and the PPE section."""
    from fsi_sph.config import load_config
    from fsi_sph.fluid.ppe import PressureSolver
    from fsi_sph.simulation import Simulation

    config = load_config(CASE, [f"case.dx={dx}"])
    sim = Simulation(config)
    ppes, iterations, step = [], [], [0]
    original = PressureSolver.solve

    def spy(self, A, b, x0, nf=None, low_rank=None):
        p, stats = original(self, A, b, x0, nf, low_rank)
        if step[0] >= first:
            ppes.append((A.copy(), b.copy(), np.array(x0, copy=True)))
            iterations.append(stats.iterations)
        return p, stats

    PressureSolver.solve = spy
    try:
        for step[0] in range(first + count):
            sim.step()
    finally:
        PressureSolver.solve = original
    return ppes, iterations, config.fluid.ppe


def petsc_sequence(comm, ppes, cfg):
    """PETSc's iterations on each PPE of the sequence (this rank's equal contiguous block),
    the preconditioner kept under the serial rebuild policy; slowest rank's total times."""
    from fsi_sph.parallel.petsc_ppe import PetscPressureSolver

    solver = PetscPressureSolver(cfg, comm=comm)
    iterations, setup, solve = [], 0.0, 0.0
    for A, b, x0 in ppes:
        n = len(b)
        cuts = np.linspace(0, n, comm.size + 1).astype(int)
        lo, hi = cuts[comm.rank], cuts[comm.rank + 1]
        indptr, cols, vals = block(A, lo, hi)
        _, stats = solver.solve(indptr, cols, vals, b[lo:hi], x0[lo:hi], lo, n)
        iterations.append(stats.iterations)
        setup += stats.setup_time
        solve += stats.solve_time
    solver.destroy()
    return iterations, comm.allreduce(setup, op=_max()), comm.allreduce(solve, op=_max())


def save_sequence(path, ppes, cfg):
    arrays = {}
    for i, (A, b, x0) in enumerate(ppes):
        arrays.update({f"indptr{i}": A.indptr, f"indices{i}": A.indices, f"data{i}": A.data,
                       f"b{i}": b, f"x0{i}": x0})
    np.savez(path, count=len(ppes), cfg=json.dumps(cfg.model_dump()), **arrays)


def load_sequence(path):
    import scipy.sparse as sp

    from fsi_sph.config.fluid import PPESection

    d = np.load(path)
    ppes = []
    for i in range(int(d["count"])):
        n = len(d[f"b{i}"])
        A = sp.csr_array((d[f"data{i}"], d[f"indices{i}"], d[f"indptr{i}"]), shape=(n, n))
        ppes.append((A, d[f"b{i}"], d[f"x0{i}"]))
    return ppes, PPESection(**json.loads(str(d["cfg"])))


def sequence_worker(path):
    """``--worker-sequence SEQ.npz`` under mpiexec: one JSON line on rank 0."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    its, setup, solve = petsc_sequence(comm, *load_sequence(path))
    if comm.rank == 0:
        print(json.dumps({"iterations": its, "setup_s": setup, "solve_s": solve}), flush=True)


def one_sequence(label, first, count, ranks):
    """The iterations table of one size on the run's PPEs of steps ``first ..``."""
    from fsi_sph.parallel import petsc_ppe

    t0 = time.perf_counter()
    ppes, serial, cfg = run_ppes(SIZES[label], first, count)
    print(f"{label}: {ppes[0][0].shape[0]} unknowns at step {first}; the serial run to step "
          f"{first + count} took {time.perf_counter() - t0:.0f} s", flush=True)
    rows = [("pyamg serial (in the run)", serial, float("nan"), float("nan"))]
    if petsc_ppe.available():
        from petsc4py import PETSc

        its, setup, solve = petsc_sequence(PETSc.COMM_SELF.tompi4py(), ppes, cfg)
        rows.append((f"{petsc_ppe.engine()}, 1 rank", its, setup, solve))
        if ranks > 1:
            with tempfile.TemporaryDirectory() as tmp:
                path = Path(tmp) / "sequence.npz"
                save_sequence(path, ppes, cfg)
                out = run_worker(["--worker-sequence", str(path)], ranks)
            if out is not None:
                rows.append((f"{petsc_ppe.engine()}, {ranks} ranks", out["iterations"],
                             out["setup_s"], out["solve_s"]))
    mean0 = np.mean(serial)
    print(f"{'size':>5} {'solver':<44} {'mean its':>8} {'/ serial':>8} {'setup s':>8} "
          f"{'solve s':>8}  iterations per step")
    for name, its, setup, solve in rows:
        print(f"{label:>5} {name:<44} {np.mean(its):>8.2f} {np.mean(its) / mean0:>8.2f} "
              f"{setup:>8.3f} {solve:>8.3f}  {' '.join(str(i) for i in its)}")


def row(name, stats, reuse):
    return {"solver": name, "iterations": stats.iterations, "residual": stats.residual,
            "setup_s": stats.setup_time, "solve_s": stats.solve_time,
            "reuse_iterations": reuse.iterations, "reuse_solve_s": reuse.solve_time}


def serial_row(A, b, nf, cfg, threads):
    """The serial solver twice (the second with the kept hierarchy), ``threads`` numba
    threads."""
    import numba

    from fsi_sph.fluid.ppe import PressureSolver

    numba.set_num_threads(threads)
    solver = PressureSolver(cfg)
    zero = np.zeros_like(b)
    _, first = solver.solve(A, b, zero, nf)
    _, again = solver.solve(A, b, zero, nf)
    return row(f"pyamg serial, {threads} thread{'s' * (threads > 1)}", first, again)


def petsc_rows_solve(comm, A_rows, b, n_global, row_start, cfg):
    """Two PETSc solves of this rank's rows from zero (the second with the kept
    preconditioner); the slowest rank's times."""
    from fsi_sph.parallel.petsc_ppe import PetscPressureSolver

    indptr, cols, vals = A_rows
    solver = PetscPressureSolver(cfg, comm=comm)
    zero = np.zeros(len(indptr) - 1)
    _, first = solver.solve(indptr, cols, vals, b, zero, row_start, n_global)
    _, again = solver.solve(indptr, cols, vals, b, zero, row_start, n_global)
    solver.destroy()
    for stats in (first, again):
        stats.setup_time = comm.allreduce(stats.setup_time, op=_max())
        stats.solve_time = comm.allreduce(stats.solve_time, op=_max())
    return first, again


def _max():
    from mpi4py import MPI

    return MPI.MAX


def block(A, lo, hi):
    s, e = A.indptr[lo], A.indptr[hi]
    return A.indptr[lo:hi + 1] - s, A.indices[s:e], A.data[s:e]


def worker(path):
    """``--worker PPE.npz`` under mpiexec: equal contiguous blocks, one JSON line on rank 0."""
    import scipy.sparse as sp
    from mpi4py import MPI

    from fsi_sph.config.fluid import PPESection
    from fsi_sph.parallel.petsc_ppe import engine

    comm = MPI.COMM_WORLD
    d = np.load(path)
    n = len(d["b"])
    A = sp.csr_array((d["data"], d["indices"], d["indptr"]), shape=(n, n))
    cfg = PPESection(**json.loads(str(d["cfg"])))
    cuts = np.linspace(0, n, comm.size + 1).astype(int)
    lo, hi = cuts[comm.rank], cuts[comm.rank + 1]
    first, again = petsc_rows_solve(comm, block(A, lo, hi), d["b"][lo:hi], n, lo, cfg)
    if comm.rank == 0:
        print(json.dumps(row(f"{engine()}, {comm.size} ranks", first, again)), flush=True)


def run_worker(args, ranks):
    """This script with ``args`` on ``ranks`` ranks under mpiexec: its last JSON line."""
    from fsi_sph.parallel.launch import launcher_env, mpiexec_command

    mpiexec, env = mpiexec_command(), launcher_env()
    if mpiexec is None:
        return None
    cmd = [*mpiexec, "-n", str(ranks), sys.executable, __file__, *args]
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, env=env,
                          timeout=3600)
    if done.returncode != 0:
        print(done.stdout, done.stderr, file=sys.stderr)
        return None
    return json.loads(done.stdout.strip().splitlines()[-1])


def mpi_row(A, b, cfg, ranks, tmp):
    path = Path(tmp) / "ppe.npz"
    np.savez(path, indptr=A.indptr, indices=A.indices, data=A.data, b=b,
             cfg=json.dumps(cfg.model_dump()))
    return run_worker(["--worker", str(path)], ranks)


def one_size(label, ranks, threads):
    """All rows of one size."""
    from fsi_sph.parallel import petsc_ppe

    t0 = time.perf_counter()
    A, b, _, nf, cfg = first_step_ppe(SIZES[label])
    print(f"{label}: {A.shape[0]} unknowns ({nf} fluid), {A.nnz} nonzeros, rtol {cfg.rtol:g}; "
          f"scene and first step {time.perf_counter() - t0:.1f} s", flush=True)
    rows = [serial_row(A, b, nf, cfg, threads)]
    if threads > 1:
        rows.append(serial_row(A, b, nf, cfg, 1))
    if not petsc_ppe.available():
        return rows
    from petsc4py import PETSc

    first, again = petsc_rows_solve(PETSc.COMM_SELF.tompi4py(), (A.indptr, A.indices, A.data),
                                    b, A.shape[0], 0, cfg)
    rows.append(row(f"{petsc_ppe.engine()}, 1 rank", first, again))
    if ranks > 1:
        with tempfile.TemporaryDirectory() as tmp:
            mpi = mpi_row(A, b, cfg, ranks, tmp)
        if mpi is not None:
            rows.append(mpi)
    return rows


def print_table(label, rows):
    head = (f"{'size':>5} {'solver':<44} {'its':>4} {'residual':>9} {'setup s':>8} "
            f"{'solve s':>8} {'reuse its':>9} {'reuse s':>8}")
    print(head)
    for r in rows:
        print(f"{label:>5} {r['solver']:<44} {r['iterations']:>4} {r['residual']:>9.2e} "
              f"{r['setup_s']:>8.3f} {r['solve_s']:>8.3f} {r['reuse_iterations']:>9} "
              f"{r['reuse_solve_s']:>8.3f}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="163k", help=f"comma-separated, of {list(SIZES)}")
    ap.add_argument("--ranks", type=int, default=2, help="ranks of the mpiexec row (1: none)")
    ap.add_argument("--threads", type=int, default=2, help="numba threads of the serial row")
    ap.add_argument("--step", type=int, default=None,
                    help="compare iterations on the run's PPEs from this step on")
    ap.add_argument("--count", type=int, default=8, help="PPEs of the --step sequence")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    ap.add_argument("--worker-sequence", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        return worker(args.worker)
    if args.worker_sequence:
        return sequence_worker(args.worker_sequence)
    load0 = os.getloadavg()
    for label in args.sizes.split(","):
        if args.step is not None:
            one_sequence(label, args.step, args.count, args.ranks)
        else:
            print_table(label, one_size(label, args.ranks, args.threads))
    print(f"{os.cpu_count()} cores, load average {load0} -> {os.getloadavg()}")


if __name__ == "__main__":
    main()
