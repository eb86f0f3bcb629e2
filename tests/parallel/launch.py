"""Spawning a script on several MPI ranks from pytest (the tests of tests/parallel)."""

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def run_mpi(nprocs, script, args, timeout):
    """Run ``script args`` on ``nprocs`` ranks from the project's root with the mpiexec of
    mpi4py's MPI library (:func:`fsi_sph.parallel.launch.mpiexec_command`); returns the
    completed process (skips the test without mpi4py or that mpiexec)."""
    if importlib.util.find_spec("mpi4py") is None:
        pytest.skip("mpi4py is not installed (pip install 'fsi_sph[mpi]')")
    from fsi_sph.parallel.launch import launcher_env, mpiexec_command

    mpiexec = mpiexec_command()
    if mpiexec is None:
        pytest.skip("no mpiexec of mpi4py's MPI library next to Python, mpicc or on PATH")
    env = launcher_env()
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), *filter(None, [env.get("PYTHONPATH")])])
    return subprocess.run([*mpiexec, "-n", str(nprocs), sys.executable, str(script), *args],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=timeout)
