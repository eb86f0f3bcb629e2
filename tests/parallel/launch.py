"""Spawning a script on several MPI ranks from pytest (the tests of tests/parallel)."""

import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def find_mpiexec():
    """mpiexec next to this Python (a venv with the mpich wheel), else on PATH."""
    return shutil.which("mpiexec", path=str(Path(sys.executable).parent)) or \
        shutil.which("mpiexec")


def run_mpi(nprocs, script, args, timeout):
    """Run ``script args`` on ``nprocs`` ranks from the project's root; returns the
    completed process (skips the test without mpi4py or mpiexec)."""
    if importlib.util.find_spec("mpi4py") is None:
        pytest.skip("mpi4py is not installed (pip install 'fsi_sph[mpi]')")
    mpiexec = find_mpiexec()
    if mpiexec is None:
        pytest.skip("no mpiexec next to the Python executable nor on PATH")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]))
    return subprocess.run([mpiexec, "-n", str(nprocs), sys.executable, str(script), *args],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=timeout)
