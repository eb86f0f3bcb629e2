"""The free bodies' rigid-body terms of the PPE on several ranks.

A scene with free bodies solves ``(A + U G) p = b`` (:class:`fsi_sph.fluid.boundary.RigidTerms`):
``G`` (3 rows per body) sums the pressures of each body's interface pairs into its force and
torque, ``U`` puts the body's rigid acceleration into its rows. On a rank only the structure
rows it owns have pairs (their fluid neighbours are its own particles or exact ghosts) and
only its owned rows of ``U`` are its to give. The ranks' pairs are put together in the
serial order (by structure row, each row's pairs in its neighbour order, which is the serial
one because the rows are in global-id order), so ``G`` is summed as in the serial run: with
the gathered solve, a scene with free bodies on P ranks is the serial run bit for bit.
"""

from __future__ import annotations

import numpy as np

from fsi_sph.fluid.boundary import RigidTerms
from fsi_sph.sph.interface import add_pair_terms


def local_parts(terms, rows):
    """This rank's share of ``terms`` (over its stacked rows; ``rows`` a
    :class:`~fsi_sph.parallel.ppe_gather.RowNumbering`): ``U``'s owned rows in the order of
    ``rows.owned``, and its pairs with global rows ``(structure row, fluid row, body,
    coefficients)``."""
    g = rows.global_row.astype(np.int64)
    return (np.ascontiguousarray(terms.U[rows.owned]), g[terms.pair_row], g[terms.pair_fluid],
            terms.pair_body.astype(np.int64), terms.pair)


def global_pairs(row_parts, fluid_parts, body_parts, pair_parts, U):
    """The ranks' pairs (lists in rank order) in the serial order, as :class:`RigidTerms`
    with ``U`` (global rows)."""
    row = np.concatenate(row_parts)
    order = np.argsort(row, kind="stable")
    return RigidTerms(U, row[order], np.concatenate(fluid_parts)[order],
                      np.concatenate(body_parts)[order], np.concatenate(pair_parts)[order])


def gathered_terms(parts, n_global):
    """The global :class:`RigidTerms` on rank 0 from every rank's :func:`owned_rows` (six
    arrays, the first its global rows) and :func:`local_parts` (five more)."""
    U = np.zeros((n_global, parts[0][6].shape[1]))
    U[np.concatenate([p[0] for p in parts]).astype(np.int64)] = np.concatenate(
        [p[6] for p in parts])
    return global_pairs(*([p[k] for p in parts] for k in range(7, 11)), U)


def block_terms(comm, terms, rows, row_start, n_local):
    """This rank's block of the global ``(U, G)`` for PETSc: ``U``'s owned rows (the
    block's rows in order) and ``G``'s columns of the block (``n_local`` from
    ``row_start``), from every rank's pairs (an all-gather: they are few); collective."""
    U, *pairs = local_parts(terms, rows)
    every = comm.allgather(pairs)
    whole = global_pairs(*([p[k] for p in every] for k in range(4)), U)
    # the block's columns, and one more that takes every other column's terms
    def column(c):
        inside = (c >= row_start) & (c < row_start + n_local)
        return np.where(inside, c - row_start, n_local)
    G = np.zeros((U.shape[1], n_local + 1))
    add_pair_terms(whole.pair_body, column(whole.pair_row), column(whole.pair_fluid),
                   whole.pair, G)
    return U, np.ascontiguousarray(G[:, :n_local])
