"""Numba loops of the fluid-structure interface (gather-only: iteration ``i`` writes row ``i``).

The interface force between a fluid particle ``f`` and a structure particle ``s`` is the
conservative pressure-gradient pair term [F 46-47]::

    F_{s<-f} = -c V_s V_f (p_s + p_f) grad_s W_sf,    F_{f<-s} = -F_{s<-f}

with ``c`` the fluid's gradient normalisation (1 for a plain SPH sum). Both sides are
gathered separately (structure rows over fluid neighbours, fluid rows over structure
neighbours); because ``grad_f W_fs = -grad_s W_sf`` the two sums cancel pair by pair, so the
momentum exchanged sums to zero to round-off.
"""

import math

from numba import njit, prange

from fsi_sph.sph.kernels import kernel_dw


@njit(cache=True, parallel=True)
def pair_pressure_forces(xd, pd, vold, xs, ps, vols, nbr_start, nbr_j, h, kind, scale, out_f):
    """Force on each destination particle ``i`` from its source neighbours ``j`` [F 46-47]:
    ``out_f[i] = -scale sum_j V_i V_j (p_i + p_j) grad_i W_ij`` (N per metre of depth)."""
    for i in prange(xd.shape[0]):
        f0 = 0.0
        f1 = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            d0 = xd[i, 0] - xs[j, 0]
            d1 = xd[i, 1] - xs[j, 1]
            r = math.sqrt(d0 * d0 + d1 * d1)
            if r < 1e-12 * h:
                continue
            c = vols[j] * (pd[i] + ps[j]) * kernel_dw(kind, r, h) / r
            f0 += c * d0
            f1 += c * d1
        out_f[i, 0] = -scale * vold[i] * f0
        out_f[i, 1] = -scale * vold[i] * f1
