"""The implicit viscous step of a fluid split over ranks, solved on rank 0.

The implicit step (``fluid.viscous_step = "implicit"``, the mu(I) scenes' default) solves a
global system for the fluid's intermediate velocities: the Morris matrix ``A`` per
component, or with the stress operator the coupled ``(blockdiag(A, A) - dt B) U = b`` with
``B = Dv diag(nu) G`` kept as its factors (:class:`~fsi_sph.fluid.viscous_operators
.TransposeTerm`). Each rank assembles them over its particles and ghosts with the serial
code, and its own rows are exact (the deep halo); the rows go to rank 0 in global-id order,
which solves with the serial solver (:func:`~fsi_sph.fluid.viscous_solvers.solve_implicit`,
the same matrices and factors as the serial run's, so the same answer bit for bit) and
sends the velocities back. Like the gathered PPE (:mod:`.ppe_gather`), rank 0 solves with
the numba threads of its node while the other ranks wait without spinning.
"""

from __future__ import annotations

import numpy as np

from fsi_sph.fluid.viscous_operators import TransposeTerm
from fsi_sph.fluid.viscous_solvers import solve_implicit
from fsi_sph.parallel.comm import (
    gather_rows_to_root,
    node_threads,
    ranks_on_this_node,
    wait_quietly,
)
from fsi_sph.parallel.ppe_gather import RowNumbering, global_matrix, owned_rows, to_root


def gathered_matrix(comm, M, rows):
    """The matrix whose rows are every rank's ``rows.owned`` of ``M`` (columns renumbered by
    ``rows.global_row``), in global order on rank 0 (its entries in each row in the order
    the owner holds them); None on the other ranks. Collective."""
    zero = np.zeros(M.shape[0])
    part = owned_rows(M, zero, zero, rows)[:4]
    parts = [to_root(comm, a) for a in part]
    if comm.rank != 0:
        return None
    return global_matrix(*(np.concatenate(p) for p in parts), rows.n_global)


class GatheredViscousSolve:
    """Stands in for :func:`solve_implicit` (same call) on the ranks of ``comm``; ``ranks``
    the :class:`~fsi_sph.parallel.ranks.FluidOnRanks` whose rows it gathers."""

    def __init__(self, comm, ranks):
        self.comm = comm
        self.ranks = ranks
        self.node_ranks = ranks_on_this_node(comm)

    def rows(self):
        """The fluid rows' global numbering: their global ids, the own ones owned."""
        r = self.ranks
        return RowNumbering(r.gid, np.flatnonzero(r.is_own), r.nf_global, r.nf_global)

    def vector(self, a):
        """Every rank's own rows of ``a`` (fluid rows x 2) on rank 0, in global-id order."""
        own = self.ranks.is_own
        return gather_rows_to_root(self.comm, self.ranks.gid[own], a[own],
                                   self.ranks.nf_global)

    def __call__(self, A, rhs, x0, rtol, coupled=None, pre=None):
        """The global solve; returns this rank's rows of ``u`` (own and ghosts) and the
        solve's statistics. Collective."""
        rows = self.rows()
        whole = [gathered_matrix(self.comm, A, rows), self.vector(rhs), self.vector(x0)]
        if coupled is not None:
            B, b, dt = coupled
            factors = [gathered_matrix(self.comm, M, rows) for M in (*B.G, *B.Dv)]
            nu = gather_rows_to_root(self.comm, self.ranks.gid[self.ranks.is_own],
                                     B.nu[self.ranks.is_own], self.ranks.nf_global)
            b = self.vector(b)
            if self.comm.rank == 0:
                coupled = (TransposeTerm(factors[:2], factors[2:], nu), b, dt)
        u = np.empty((self.ranks.nf_global, 2))
        stats = None
        if self.comm.rank == 0:
            u[:], stats = self.solve_here(*whole, rtol, coupled, pre)
        wait_quietly(self.comm.Ibcast(u, root=0))
        stats = self.comm.bcast(stats, root=0)
        return u[self.ranks.gid], stats

    def solve_here(self, A, rhs, x0, rtol, coupled, pre):
        """The serial solve on rank 0 with the numba threads of every rank of its node."""
        with node_threads(self.node_ranks):
            return solve_implicit(A, rhs, x0, rtol, coupled, pre)
