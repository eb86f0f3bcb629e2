"""The pressure Poisson equation of a fluid split over ranks, solved on rank 0.

Each rank assembles the PPE of its own particles and ghosts (the serial assembly,
:func:`fsi_sph.fluid.ppe.assemble`, unchanged) and keeps the rows it owns; their columns are
renumbered to the global rows (:class:`RowNumbering`). Rank 0 gathers the rows, puts them in
the global order and solves with the serial solver (:class:`~fsi_sph.fluid.ppe.PressureSolver`,
its AMG hierarchy kept across steps as in a serial run); every rank gets the pressure of all
its rows back. The global row order is the serial run's own (fluid particles by global id,
then the walls), so rank 0 solves the very matrix of the serial run: a run on P ranks is the
serial run bit for bit (tests/parallel/test_fluid_ranks.py). This is the route without
PETSc; it costs a gather and a broadcast of the matrix's size per step and does not scale
past a few ranks (docs/parallel.md).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numba
import numpy as np
import scipy.sparse as sp

from fsi_sph.errors import SimulationError
from fsi_sph.fluid.ppe import PressureSolver
from fsi_sph.parallel.comm import (
    exchange_arrays,
    node_threads,
    ranks_on_this_node,
    wait_quietly,
)
from fsi_sph.parallel.low_rank import gathered_terms, local_parts


@dataclass
class RowNumbering:
    """Where this rank's stacked rows sit in the global PPE: ``global_row`` (one per stacked
    row, own or ghost), ``owned`` (the stacked rows this rank contributes), ``n_global``
    and ``nf_global`` (the global count of rows and of fluid rows)."""

    global_row: np.ndarray
    owned: np.ndarray
    n_global: int
    nf_global: int


class GatheredPressureSolver:
    """Stands in for the fluid's :class:`PressureSolver` (same ``solve``, ``remap``,
    ``reset``) on several ranks; ``comm`` an mpi4py communicator, ``cfg`` a PPESection."""

    def __init__(self, cfg, comm):
        self.cfg = cfg
        self.comm = comm
        self.serial = PressureSolver(cfg) if comm.rank == 0 else None
        self.rows = None  # RowNumbering, set by the driver after each redistribution
        self.sent_bytes = 0  # bytes of matrix rows this rank sent to rank 0
        self.node_ranks = ranks_on_this_node(comm)

    def remap(self, old_of_new):
        """A rank's stacked rows renumbered: the global rows (and rank 0's hierarchy) are
        not (:meth:`remap_rows` is)."""

    def remap_rows(self, old_of_new):
        """The global rows renumbered (open boundaries: ``old_of_new``, the whole fluid's
        map, on every rank): rank 0's hierarchy follows, as in a serial run."""
        if self.serial is not None:
            self.serial.remap(old_of_new)

    def reset(self):
        """At a snapshot (bit-identical restart): rank 0 drops its hierarchy."""
        if self.serial is not None:
            self.serial.reset()

    def solve(self, A, b, x0, nf=None, low_rank=None):
        """Solve the global PPE of which ``A, b`` (this rank's stacked rows) hold this
        rank's part, and ``low_rank`` the free bodies' terms over them (:mod:`.low_rank`);
        returns ``(p, PPEStats)`` with ``p`` for every stacked row."""
        rows = self.rows
        t0 = time.perf_counter()
        part = owned_rows(A, b, x0, rows)
        if low_rank is not None:
            part = (*part, *local_parts(low_rank, rows))
        self.sent_bytes += sum(a.nbytes for a in part)
        parts = list(zip(*[to_root(self.comm, a) for a in part], strict=True))
        p = np.empty(rows.n_global)
        stats = failure = None
        if self.comm.rank == 0:
            try:
                p[:], stats = self.solve_here(parts, rows)
            except RuntimeError as e:  # every rank fails with it, none waits
                failure = str(e)
        wait_quietly(self.comm.Ibcast(p, root=0))
        stats, failure = self.comm.bcast((stats, failure), root=0)
        if failure is not None:
            raise SimulationError(failure)
        stats.assemble_time = 0.0
        stats.solve_time = time.perf_counter() - t0 - stats.setup_time
        return p[rows.global_row], stats

    def solve_here(self, parts, rows):
        """The global system put together from the ranks' ``parts`` and solved by the
        serial solver, on rank 0 with the numba threads of every rank of this node (they
        wait for the result without spinning: :func:`wait_quietly`)."""
        with node_threads(self.node_ranks):
            A, b, x0 = global_system(parts, rows.n_global)
            low_rank = gathered_terms(parts, rows.n_global) if len(parts[0]) > 6 else None
            return self.serial.solve(A, b, x0, rows.nf_global, low_rank)


def to_root(comm, a):
    """``a`` from every rank to rank 0 (one :func:`exchange_arrays`: the other ranks
    receive nothing); on rank 0 the list of the ranks' arrays."""
    return exchange_arrays(comm, [a if r == 0 else a[:0] for r in range(comm.size)])


def owned_rows(A, b, x0, rows: RowNumbering):
    """This rank's rows of the system in global numbering: ``(global rows, row lengths,
    global columns, data, b, x0)``. The map from stacked to global rows is increasing over
    the stacked rows (the driver orders them so), so each row's columns stay sorted."""
    A = sp.csr_array(A)
    index = np.int32 if rows.n_global < 2**31 else np.int64
    g = rows.global_row.astype(index)
    lengths = (A.indptr[rows.owned + 1] - A.indptr[rows.owned]).astype(np.int64)
    starts = np.zeros(len(lengths) + 1, dtype=np.int64)
    np.cumsum(lengths, out=starts[1:])
    cols = np.empty(starts[-1], dtype=index)
    data = np.empty(starts[-1])
    _take_rows(A.indptr, A.indices, A.data, rows.owned, g, starts, cols, data)
    return g[rows.owned], lengths, cols, data, b[rows.owned], x0[rows.owned]


def global_system(parts, n_global):
    """The global matrix, right-hand side and initial guess from every rank's
    :func:`owned_rows`, rows in global order; each global row must come exactly once."""
    g_rows = np.concatenate([p[0] for p in parts]).astype(np.int64)
    seen = np.bincount(g_rows, minlength=n_global) if len(g_rows) else np.zeros(n_global)
    if len(g_rows) != n_global or len(seen) != n_global or np.any(seen != 1):
        raise RuntimeError(f"PPE on ranks: {len(g_rows)} rows gathered for {n_global} "
                           "(a row missing or owned twice)")
    A = global_matrix(g_rows, *(np.concatenate([p[k] for p in parts]) for k in (1, 2, 3)),
                      n_global)
    A.has_sorted_indices = True
    b = np.empty(n_global)
    x0 = np.empty(n_global)
    b[g_rows] = np.concatenate([p[4] for p in parts])
    x0[g_rows] = np.concatenate([p[5] for p in parts])
    return A, b, x0


def global_matrix(g_rows, lengths, cols, vals, n):
    """The ``n x n`` CSR matrix of packed rows (``lengths`` entries each, global columns
    ``cols``) placed at their global rows ``g_rows``, each row's entries in their order."""
    g_rows = np.asarray(g_rows, dtype=np.int64)
    src = np.zeros(len(lengths) + 1, dtype=np.int64)
    np.cumsum(lengths, out=src[1:])
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(g_rows, weights=lengths, minlength=n).astype(np.int64),
              out=indptr[1:])
    indices = np.empty(indptr[-1], dtype=np.int32)
    data = np.empty(indptr[-1])
    place_rows(cols, vals, src, g_rows, indptr, indices, data)
    return sp.csr_array((data, indices, indptr.astype(np.int32)), shape=(n, n))


@numba.njit(cache=True, parallel=True)
def _take_rows(indptr, indices, data, rows, global_row, starts, out_cols, out_data):
    """Rows ``rows`` of a CSR matrix, columns renumbered by ``global_row``, packed at
    ``starts``."""
    for k in numba.prange(len(rows)):
        a = indptr[rows[k]]
        for m in range(starts[k + 1] - starts[k]):
            out_cols[starts[k] + m] = global_row[indices[a + m]]
            out_data[starts[k] + m] = data[a + m]


@numba.njit(cache=True, parallel=True)
def place_rows(cols, vals, src, g_rows, indptr, out_indices, out_data):
    """Packed rows (``src`` their starts) copied to their global rows ``g_rows``."""
    for k in numba.prange(len(g_rows)):
        a, at = src[k], indptr[g_rows[k]]
        for m in range(src[k + 1] - a):
            out_indices[at + m] = cols[a + m]
            out_data[at + m] = vals[a + m]
