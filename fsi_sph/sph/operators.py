"""Generic SPH operators shared by the fluid, solid and soil loops (gather-only numba).

Numba's cache does not see changes to functions imported from another file: after editing
this module, delete ``__pycache__`` (DESIGN.md §7).
"""

from numba import njit, prange

from fsi_sph.sph.kernels import kernel_dw, pair_offset


@njit(cache=True, parallel=True)
def correction_matrices(x, vol, nbr_start, nbr_j, h, kind, det_min, out_L):
    """Oger's kernel-gradient correction [F 13-14]: ``out_L[i] = (M_i^-1)^T`` with
    ``M_i = sum_j V_j (x_j - x_i) (x) grad W_ij``, so that ``sum_j V_j (phi_j - phi_i) L_i
    grad W_ij`` is exact for linear ``phi``. Identity where ``|det M_i| < det_min``
    (``det M`` is about 1 for a full support)."""
    for i in prange(out_L.shape[0]):
        m00 = 0.0
        m01 = 0.0
        m10 = 0.0
        m11 = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j, d0, d1, r = pair_offset(x, x, nbr_j, i, k)
            if r < 1e-12 * h:
                continue
            dw = kernel_dw(kind, r, h)
            g0 = dw * d0 / r
            g1 = dw * d1 / r
            m00 -= vol[j] * d0 * g0
            m01 -= vol[j] * d0 * g1
            m10 -= vol[j] * d1 * g0
            m11 -= vol[j] * d1 * g1
        det = m00 * m11 - m01 * m10
        if abs(det) < det_min:
            out_L[i, 0, 0] = 1.0
            out_L[i, 0, 1] = 0.0
            out_L[i, 1, 0] = 0.0
            out_L[i, 1, 1] = 1.0
        else:
            out_L[i, 0, 0] = m11 / det
            out_L[i, 0, 1] = -m10 / det
            out_L[i, 1, 0] = -m01 / det
            out_L[i, 1, 1] = m00 / det
