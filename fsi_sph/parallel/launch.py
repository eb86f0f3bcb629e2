"""Launching a command on several MPI ranks (tests, benchmarks): the ``mpiexec`` of the MPI
library mpi4py uses here, and a clean environment for it."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path


def _mpi_family(text):
    text = text.lower()
    if "open mpi" in text or "openrte" in text:
        return "openmpi"
    return "mpich" if "mpich" in text or "hydra" in text else None


def mpiexec_command():
    """``[mpiexec, flags...]`` of the MPI library that mpi4py (and so PETSc) uses in this
    Python, or None: the ``mpiexec`` next to the Python executable, next to mpi4py's
    ``mpicc`` or on PATH, whichever reports the same MPI (Debian's petsc4py: Open MPI,
    ``/usr/bin/mpiexec``; the main venv's mpich wheel: its own). Open MPI gets
    ``--oversubscribe`` and, as root, ``--allow-run-as-root``. Initialises MPI."""
    import mpi4py
    from mpi4py import MPI

    family = _mpi_family(MPI.Get_library_version())
    mpicc = mpi4py.get_config().get("mpicc")
    dirs = [Path(sys.executable).parent] + ([Path(mpicc).parent] if mpicc else [])
    found = [shutil.which("mpiexec", path=str(d)) for d in dirs] + [shutil.which("mpiexec")]
    for exe in filter(None, found):
        out = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=30,
                             env=launcher_env())
        if family is not None and _mpi_family(out.stdout + out.stderr) == family:
            if family != "openmpi":
                return [exe]
            root = ["--allow-run-as-root"] if os.geteuid() == 0 else []
            return [exe, "--oversubscribe", *root]
    return None


def launcher_env():
    """The environment for a child ``mpiexec``: this process's, without the variables of an
    MPI launcher or of the singleton MPI this process may have started (importing PETSc
    initialises MPI; Open MPI's singleton sets ``OMPI_*``/``PMIX_*`` in the C environment,
    which a child inherits by default, and ``mpiexec`` then exits 1 without a word)."""
    launcher = ("OMPI_", "PMIX_", "PMI_", "HYDRA_")
    return {k: v for k, v in os.environ.items() if not k.startswith(launcher)}
