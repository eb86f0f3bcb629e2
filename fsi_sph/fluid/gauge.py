"""A confined flow's pressure level, taken out of the interface's pair terms.

The pair form of the pressure gradient [F 10] and the interface force [F 46-47],
``sum_j (p_i + p_j) V_j grad W_ij``, do not vanish under a uniform pressure where the
support is irregular, and a structure's particles are not on the fluid's lattice. In a
confined flow (no free surface: ``IncompressibleFluid.fills_its_channel``) the whole
channel's pressure level moves by kilopascals from step to step, because the column between
the inflow and the outflow answers any net volume error of the step; through the pair terms
that level pushed the rows beside a structure and the structure itself. The Turek-Hron flag
clamped everywhere (a fixed flag, coupled) blew up in 10 steps (0.11 s), while the same
flag as a wall runs; with the level taken out it runs 3 s (docs/numerics/coupling.md
§ Pressure level of a confined flow). With fluid on every side of every body a uniform
pressure does no net work, so the pair terms take the pressures relative to the level
``p_gauge = m . p``: the mean pressure of the fluid rows beside a structure, of the same
solve. The implicit rows of the solve see the force the structure then receives through a
rank-one term (and the free bodies' rigid rows through their own ``G``); a force probe takes
the level beside its own body (:func:`level_beside`). A free surface fixes the level (p = 0
there, and a gate wetted on one side feels the whole pressure): no gauge.
Not in PHYSICS.md; tests/unit/test_interface_gauge.py.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class LevelTerms:
    """``U G`` terms of the solve (:class:`~fsi_sph.fluid.amg.LowRank`), as the free
    bodies' :class:`~fsi_sph.fluid.boundary.RigidTerms` give them."""

    U: np.ndarray
    Gm: np.ndarray

    def G(self, n=None):
        return self.Gm if n is None else self.Gm[:, :n]


def level_weights(ps, rows):
    """``m`` with ``p_gauge = m . p`` over the stacked rows: ``1 / k`` on the ``k`` fluid
    rows with a coupled structure particle among their neighbours, 0 elsewhere; None where
    no gauge applies (a flow with a free surface, no structure, or no such row)."""
    if not (ps.confined and ps.ns):
        return None
    near = rows.structure_rows(ps.nf + ps.nw - ps.ns)
    if not near.any():
        return None
    m = np.zeros(len(ps.p_all))
    m[:ps.nf][near] = 1.0 / np.count_nonzero(near)
    return m


def gauged_terms(A, ps, m, rigid=None):
    """The solve's extra terms with the level ``m . p`` out of the interface's pair terms.

    An implicit structure row ``w`` is ``diag_ref ((1 + sum_f k_wf) p_w + sum_f (k_wf -
    w_wf) p_f)`` with ``sum_f k_wf (p_w + p_f)`` its particle's pair force as the solve sees
    it (``_kernels.ppe_fill``); relative to the level that is ``sum_f k_wf (p_w + p_f - 2 m .
    p)``: the rank-one term ``-2 diag_ref sum_f k_wf (m . p)``, and ``diag_ref (1 + sum_f
    k_wf)`` is the row's diagonal (0 for walls, clamped particles and the explicit rows).
    The rigid rows' generalised force ``G p`` becomes ``G (p - (m . p) 1)``."""
    nb0 = ps.nf + ps.n_walls
    u = np.zeros((A.shape[0], 1))
    u[nb0:, 0] = -2.0 * (A.diagonal()[nb0:] - ps.diag_ref)
    if rigid is None:
        return LevelTerms(u, m[None, :])
    G = rigid.G()
    G = G - np.outer(G.sum(axis=1), m)
    return LevelTerms(np.hstack([rigid.U, u]), np.vstack([G, m[None, :]]))


def level_beside(ps, boundary_rows):
    """The mean pressure of the fluid rows beside the boundary rows ``boundary_rows`` (a
    body's particles after the fluid's; their fluid neighbour lists ``wf``): the level a
    force probe on a closed body takes the pressures relative to in a confined flow (0
    without fluid neighbours)."""
    start, j = ps.wf_start, ps.wf_j
    nb = np.concatenate([j[start[b]:start[b + 1]] for b in boundary_rows] or [j[:0]])
    nb = np.unique(nb[nb < ps.nf])
    return float(ps.p_all[nb].mean()) if len(nb) else 0.0

