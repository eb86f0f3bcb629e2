"""fsi_sph.parallel.petsc_ppe: the PPE solved by PETSc against the serial PressureSolver, on
one rank and (petsc_checks.py under mpiexec) on two. Skipped without petsc4py (Debian:
``apt-get install python3-petsc4py``; the PETSc venv of README)."""

from pathlib import Path

import numpy as np
import pytest

from fsi_sph.parallel import launch, petsc_ppe
from tests.parallel.launch import run_mpi

ROOT = Path(__file__).resolve().parents[2]
CHECKS = Path(__file__).with_name("petsc_checks.py")
MPI_TIMEOUT = 180
#: solutions by PETSc and by the serial solver agree within AGREE * rtol (relative 2-norm)
AGREE = 10.0

needs_petsc = pytest.mark.skipif(not petsc_ppe.available(),
                                 reason="petsc4py not installed (apt-get install "
                                 "python3-petsc4py, in a venv with --system-site-packages)")


# ---------------------------------------------------------------- without PETSc


def test_module_imports_and_names_its_engine():
    name = petsc_ppe.engine()
    if petsc_ppe.available():
        assert name.startswith("PETSc ") and "fgmres" in name
    else:
        assert name == "pyamg (petsc4py not installed)"


def test_diagonal_block_counts():
    # rows 10..12 of a 20-row matrix; columns inside [10, 13) are this rank's
    indptr = np.array([0, 3, 3, 6])
    gcols = np.array([9, 10, 12, 0, 11, 13])
    d, o = petsc_ppe.diagonal_block_counts(indptr, gcols, 10, 3)
    assert d.tolist() == [2, 0, 1] and o.tolist() == [1, 0, 2]


# ---------------------------------------------------------------- with PETSc


@pytest.fixture(scope="module")
def ppe():
    """The dam break's first-step PPE at dx = 0.04 (about 2 k rows)."""
    from tests.parallel.petsc_checks import first_step_ppe

    return first_step_ppe(0.04)


def petsc_solve(solver, A, b, x0):
    return solver.solve(A.indptr, A.indices, A.data, b, x0, 0, A.shape[0])


def relative(u, v):
    return float(np.linalg.norm(u - v) / np.linalg.norm(v))


@needs_petsc
@pytest.mark.parametrize("pc", [None, "gamg"])
def test_one_rank_matches_serial_solver(ppe, pc):
    from fsi_sph.fluid.ppe import PressureSolver

    A, b, x0, nf, cfg = ppe
    x_ser, s_ser = PressureSolver(cfg).solve(A, b, x0, nf)
    solver = petsc_ppe.PetscPressureSolver(cfg, pc=pc)
    x, stats = petsc_solve(solver, A, b, x0)
    assert stats.n_unknowns == A.shape[0] and stats.rebuilt and stats.setup_time > 0.0
    assert 0 < stats.iterations <= cfg.maxiter
    assert stats.residual <= cfg.rtol and s_ser.residual <= cfg.rtol
    assert np.linalg.norm(b - A @ x) / np.linalg.norm(b) == pytest.approx(stats.residual,
                                                                   rel=1e-6)
    # BoomerAMG: about the serial solver's iterations; GAMG's residual ends nearer rtol
    assert relative(x, x_ser) <= (AGREE if pc is None else 5 * AGREE) * cfg.rtol
    solver.destroy()


@needs_petsc
def test_preconditioner_kept_then_rebuilt(ppe):
    A, b, x0, nf, cfg = ppe
    cfg = cfg.model_copy(update={"rebuild_every": 3})
    solver = petsc_ppe.PetscPressureSolver(cfg)
    rebuilt = []
    for k in range(5):
        x, stats = petsc_solve(solver, A * (1.0 + 0.02 * k), b, x0)
        assert stats.residual <= cfg.rtol
        assert (stats.setup_time > 0.0) == stats.rebuilt
        rebuilt.append(stats.rebuilt)
    assert rebuilt == [True, False, False, True, False]
    mat = solver.mat
    x, stats = petsc_solve(solver, A * 1.08, b, x)  # from the solution: no iteration
    assert solver.mat is mat and stats.iterations == 0 and not stats.rebuilt
    # another global size: a new matrix and preconditioner
    n = A.shape[0] - 1
    x, stats = petsc_solve(solver, A[:n, :n].tocsr(), b[:n], x0[:n])
    assert stats.rebuilt and stats.n_unknowns == n and stats.residual <= cfg.rtol
    solver.destroy()


@needs_petsc
def test_iteration_growth_rebuilds(ppe):
    A, b, x0, nf, cfg = ppe
    solver = petsc_ppe.PetscPressureSolver(cfg)
    solver.solve(A.indptr, A.indices, A.data, b, x0, 0, A.shape[0])
    solver.reuse.last_iterations = solver.reuse.base_iterations + 3  # as if it had grown
    x, stats = petsc_solve(solver, A, b, x0)
    assert stats.rebuilt
    solver.destroy()


@needs_petsc
def test_no_convergence_raises(ppe):
    A, b, x0, nf, cfg = ppe
    solver = petsc_ppe.PetscPressureSolver(cfg.model_copy(update={"maxiter": 1}))
    with pytest.raises(RuntimeError, match="no convergence in 1 iterations"):
        petsc_solve(solver, A, b, x0)
    solver.destroy()


@needs_petsc
def test_zero_rhs_gives_zero(ppe):
    A, b, x0, nf, cfg = ppe
    x, stats = petsc_solve(petsc_ppe.PetscPressureSolver(cfg), A, np.zeros_like(b), x0 + 1.0)
    assert not x.any() and stats.iterations == 0


@needs_petsc
def test_two_ranks_match_one_rank(ppe, tmp_path):
    from tests.parallel.petsc_checks import save_ppe

    A, b, x0, nf, cfg = ppe
    path = tmp_path / "ppe.npz"
    save_ppe(path, A, b)
    done = run_mpi(2, CHECKS, [str(path)], MPI_TIMEOUT)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "petsc_checks OK" in done.stdout


def test_launcher_env_drops_mpi_variables(monkeypatch):
    monkeypatch.setenv("OMPI_COMM_WORLD_RANK", "1")
    monkeypatch.setenv("PMIX_RANK", "1")
    env = launch.launcher_env()
    assert "OMPI_COMM_WORLD_RANK" not in env and "PMIX_RANK" not in env and "PATH" in env
