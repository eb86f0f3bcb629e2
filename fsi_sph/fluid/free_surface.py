"""Free-surface detection by the position divergence, the [F 21] blend and normals.

``div r_i = - sum_j V_j r_ij . grad W_ij`` (fluid and wall neighbours) is 2 inside a full 2D
support and drops towards 1 at a free surface.
"""

from __future__ import annotations

import numba
import numpy as np

from fsi_sph.fluid import _kernels as K

#: [F 21] blend limits and the class threshold chi [F Fig. 2]
DIVR_LOW = 1.4
DIVR_HIGH = 1.6
CHI = 1.4
#: rows with ``div r`` below this are scanned by the umbrella test (full support: ~2)
SCAN_BELOW = 1.95


def blend(divr):
    """Free-surface coefficient [F 21]: 1 for ``div r >= 1.6``, 0 for ``div r <= 1.4`` and
    ``0.5 (1 - cos(pi (div r - 1.4) / 0.2))`` in between.

    >>> blend(np.array([1.0, 1.5, 2.0])).round(3).tolist()
    [0.0, 0.5, 1.0]
    """
    t = np.clip((divr - DIVR_LOW) / (DIVR_HIGH - DIVR_LOW), 0.0, 1.0)
    return 0.5 * (1.0 - np.cos(np.pi * t))


def detect(x, vol, nbr_start, nbr_j, nf, h, kind, out_divr, out_grad_c, out_sigma, out_alpha,
           out_class, out_normal, scan=False, isolated=False, pocket=0, surface=True):
    """Fill the free-surface fields of the fluid rows (arrays of length ``nf``).

    ``x, vol`` are the stacked fluid+wall arrays and ``nbr_*`` the fluid rows' neighbour list.
    A row is on the free surface if ``div r < CHI`` [F 21, Fig. 2]; with ``scan`` also if
    Marrone et al.'s umbrella region along its normal is empty
    (:func:`_kernels.umbrella_scan`, rows with ``div r < SCAN_BELOW``), and such a row is a
    Dirichlet row (``alpha = 0``). The scan catches a particle on the face of a thin front
    whose ``div r`` is raised by neighbours crowded behind it: as a Poisson row among
    surface rows it drew an unbounded pressure (docs/numerics/fluid.md, "Umbrella scan").
    With ``isolated`` a row whose fluid neighbours (``j < nf``) are all surface rows is
    a surface (Dirichlet) row too (:func:`_kernels.isolated_rows`): its Poisson row had
    no support but surface rows and walls that extrapolate their pressure from it, and its
    pressure ran away (30 -> 72 kPa per step at a granular front, hydrostatic there a few
    hundred Pa; docs/numerics/fluid.md, "Isolated Poisson rows"). With ``pocket > 0`` the
    Poisson rows of a connected set of fewer than ``pocket`` Poisson rows with a surface row
    beside it are surface rows too (:func:`_kernels.pocket_rows`): three or four Poisson
    rows inside a thin sheet drew 7 -> 53 kPa in six steps (hydrostatic there a few hundred
    Pa) and threw one of them out of a dam break onto a wedge at dx 6.7 mm
    (docs/numerics/fluid.md, "Pockets of Poisson rows"; a detection rule, not in PHYSICS.md,
    tested against a connected-components oracle in tests/unit/test_pocket_rows.py). Returns
    the number of rows the scan added.

    ``surface=False`` (a confined flow, :attr:`FluidParticles.confined`): ``div r`` and the
    kernel sum only; every row is an interior Poisson row (``alpha = 1``, no normal).
    """
    K.position_divergence(x, vol, nbr_start, nbr_j, h, kind, out_divr, out_grad_c, out_sigma)
    if not surface:
        out_alpha[:] = 1.0
        out_class[:] = K.INTERIOR
        out_normal[:] = 0.0
        return 0
    out_alpha[:] = blend(out_divr)
    n_nbr = np.diff(nbr_start)
    is_surface = (out_divr < CHI) & (n_nbr > 0)
    added = 0
    if scan:
        candidate = ~is_surface & (n_nbr > 0) & (out_divr < SCAN_BELOW)
        hit = np.empty(nf, dtype=np.bool_)
        K.umbrella_scan(x, candidate, out_grad_c, nbr_start, nbr_j, nf, h, hit)
        added = int(hit.sum())
        is_surface |= hit
        out_alpha[hit] = 0.0
    if isolated:
        alone = np.empty(nf, dtype=np.bool_)
        K.isolated_rows(is_surface, nbr_start, nbr_j, nf, alone)
        is_surface |= alone
        out_alpha[alone] = 0.0
    if pocket > 0:
        small = np.empty(nf, dtype=np.bool_)
        found = np.empty((numba.config.NUMBA_NUM_THREADS, pocket), dtype=np.int64)
        K.pocket_rows(is_surface, nbr_start, nbr_j, nf, found, small)
        is_surface |= small
        out_alpha[small] = 0.0
    K.surface_classes(x, is_surface, n_nbr, out_grad_c, nbr_start, nbr_j, nf, h, out_class,
                      out_normal)
    return added
