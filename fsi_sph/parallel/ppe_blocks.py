"""The pressure Poisson equation of a fluid split over ranks, solved by PETSc over them.

PETSc wants each rank to own one contiguous block of global rows. Here rank r's block is
its own fluid particles (in global-id order) and then the boundary rows in its strip (the
walls, then the structure particles; :func:`block_rows`); a ghost's row is the one its
owner gave it (sent with the ghosts). Each rank assembles its rows with the serial assembly,
renumbers their columns (:func:`fsi_sph.parallel.ppe_gather.owned_rows`) and the blocks are
solved together by :class:`~fsi_sph.parallel.petsc_ppe.PetscPressureSolver`; the ghosts'
pressures come back from their owners through the halo and the boundary rows' from an
all-gather. The answer is the serial one within the solver's tolerance, not bit for bit
(another preconditioner).
"""

from __future__ import annotations

import time

import numpy as np

from fsi_sph.parallel.low_rank import block_terms
from fsi_sph.parallel.ppe_gather import RowNumbering, owned_rows


def block_rows(comm, n_own, wall_owner):
    """Where each rank's block starts, and the global row of every boundary row (walls,
    then structures): ``(start of each rank's block, their rows)``; a rank's block is
    ``n_own`` fluid rows, then its boundary rows (``wall_owner``: the rank of each boundary
    row, the same on every rank). Collective."""
    n_fluid = np.array(comm.allgather(int(n_own)), dtype=np.int64)
    n_walls = np.bincount(wall_owner, minlength=comm.size).astype(np.int64)
    start = np.concatenate([[0], np.cumsum(n_fluid + n_walls)])
    order = np.argsort(wall_owner, kind="stable")
    rank_of = wall_owner[order]
    first = np.concatenate([[0], np.cumsum(n_walls)])[rank_of]
    rows = np.empty(len(wall_owner), dtype=np.int64)
    rows[order] = start[rank_of] + n_fluid[rank_of] + np.arange(len(order)) - first
    return start, rows


class BlockPressureSolver:
    """Stands in for the fluid's :class:`PressureSolver` on ranks with PETSc (same
    ``solve``, ``remap``, ``reset``); ``ranks`` the :class:`FluidOnRanks` whose halo brings
    the ghosts' pressures back."""

    def __init__(self, cfg, comm, ranks):
        from fsi_sph.parallel.petsc_ppe import PetscPressureSolver

        self.comm = comm
        self.ranks = ranks
        self.petsc = PetscPressureSolver(cfg, comm)
        self.rows = None  # RowNumbering in PETSc's block order, set by the driver
        self.row_start = 0
        self.sent_bytes = 0

    def remap(self, old_of_new):
        """Rows renumbered: PETSc keeps what it can (its own checks)."""

    def remap_rows(self, old_of_new):
        """The global rows renumbered (open boundaries): PETSc keeps what it can."""

    def reset(self):
        """At a snapshot: the preconditioner is built anew at the next solve."""
        self.petsc.reuse.age = self.petsc.cfg.rebuild_every

    def solve(self, A, b, x0, nf=None, low_rank=None):
        """Solve the global PPE (with the free bodies' terms ``low_rank``, a
        :class:`~fsi_sph.fluid.boundary.RigidTerms`); returns ``(p, PPEStats)`` with ``p``
        for every stacked row of this rank."""
        t0 = time.perf_counter()
        _, lengths, cols, data, b_own, x0_own = owned_rows(A, b, x0, self.rows)
        indptr = np.zeros(len(lengths) + 1, dtype=np.int64)
        np.cumsum(lengths, out=indptr[1:])
        if low_rank is not None:
            low_rank = block_terms(self.comm, low_rank, self.rows, self.row_start,
                                   len(lengths))
        x, stats = self.petsc.solve(indptr, cols, data, b_own, x0_own, self.row_start,
                                    self.rows.n_global, low_rank)
        p = self.ranks.spread(x)
        stats.assemble_time = 0.0
        stats.solve_time = time.perf_counter() - t0 - stats.setup_time
        return p, stats


def petsc_numbering(comm, own_gid, wall_owner):
    """Block numbering of this step (:func:`block_rows`): the PETSc row of each own
    particle, in the order of ``own_gid`` (to be sent with the ghosts), the walls' rows and
    this rank's block start."""
    start, wall_rows = block_rows(comm, len(own_gid), wall_owner)
    rank_in_block = np.empty(len(own_gid), dtype=np.int64)
    rank_in_block[np.argsort(own_gid, kind="stable")] = np.arange(len(own_gid))
    return start[comm.rank] + rank_in_block, wall_rows, int(start[comm.rank]), int(start[-1])


def numbering(prow_local, wall_rows, is_own, wall_own, n_global, nf_global):
    """The :class:`RowNumbering` of the stacked rows ``[fluid (own and ghosts) | walls]``
    in PETSc's block order: owned fluid rows (their rows increase with the stacked order),
    then the owned walls."""
    global_row = np.concatenate([prow_local, wall_rows])
    owned = np.concatenate([np.flatnonzero(is_own), len(is_own) + np.flatnonzero(wall_own)])
    return RowNumbering(global_row, owned, n_global, nf_global)
