"""Pressure loops of the fluid: the PPE rows [F 17, F 20-21] straight into CSR, the walls'
floor and the conservative [F 10] and corrected [F 7, F 13] pressure gradients (gather-only)."""

import math

from numba import njit, prange

from fsi_sph.sph.kernels import kernel_dw, kernel_w, pair_offset, pair_offset_sq


@njit(cache=True)
def _sort_row(indices, data, lo, hi):
    """Insertion sort of ``indices[lo:hi]`` (and ``data`` alongside) by column."""
    for a in range(lo + 1, hi):
        c = indices[a]
        d = data[a]
        b = a - 1
        while b >= lo and indices[b] > c:
            indices[b + 1] = indices[b]
            data[b + 1] = data[b]
            b -= 1
        indices[b + 1] = c
        data[b + 1] = d


@njit(cache=True, parallel=True)
def ppe_row_lengths(alpha, f_start, w_start, nf, nw, out_len):
    """Entries per row of the PPE matrix: a fluid row holds its diagonal and, unless it is a
    Dirichlet (``alpha = 0``) row, one entry per neighbour; a wall row its diagonal and one
    entry per fluid neighbour."""
    for i in prange(nf + nw):
        if i < nf:
            n = f_start[i + 1] - f_start[i]
            out_len[i] = 1 + n if alpha[i] > 0.0 else 1
        else:
            w = i - nf
            out_len[i] = 1 + w_start[w + 1] - w_start[w]


@njit(cache=True, parallel=True)
def ppe_fill(x, vol, alpha, source, L, consistent, f_start, f_j, w_start, w_j, nf, nw, h, kind,
             eta2, lap_scale, diag_ref, rho, gb, implicit, pair_w, indptr, out_indices, out_data,
             out_b):
    """Fill the PPE straight into CSR arrays (``indptr`` from :func:`ppe_row_lengths`).

    Fluid row ``i`` [F 17, F 20-21]: the Morris Laplacian [F 11-12] with
    ``c_ij = -2 lap_scale V_j r dW/dr / (r^2 + eta^2)``, made exact for linear fields where
    the support is truncated (free surface, ends of walls) by subtracting its first-moment
    error ``e_i . grad p_i``, ``e_i = sum_j c_ij (x_j - x_i)``, with the corrected gradient
    ``grad p_i = sum_j V_j (p_j - p_i) L_i grad W_ij`` [F 13-14] (a correction of the kind
    of Fatehi & Manzari 2011). It stays on the neighbours of ``i``::

        lap p_i = sum_j a_ij (p_j - p_i),  a_ij = c_ij - V_j e_i . (L_i grad W_ij)

    The correction is applied on rows with ``consistent[i]`` true (the caller's choice: the
    free- and near-surface rows); elsewhere ``a_ij = c_ij``, the plain Morris sum, whose
    matrix is an M-matrix. In the interior of a regular lattice ``e_i = 0`` anyway.
    With ``D_i = sum_j a_ij`` the row is [F 20-21]::

        D_i p_i - alpha_i sum_j a_ij p_j = alpha_i source_i

    which is ``lap p_i = -source_i`` where ``alpha_i = 1`` (``source_i = -rho div u*_i / dt``),
    ``p_i = 0`` where ``alpha_i = 0`` (free surface) and the [F 21] blend in between.
    Dirichlet rows and rows without neighbours get the diagonal ``diag_ref`` and ``b = 0``.

    Boundary row ``w`` (global index ``nf + w``; fixed walls, then moving structure
    particles): Adami's extrapolation (PHYSICS.md §2) from the fluid neighbours ``f``,
    ``gb[w] = g - a_w`` (``g`` for a fixed wall), scaled by ``diag_ref`` so that its size
    matches the fluid rows::

        p_w - sum_f p_f W_wf / sum_f W_wf = rho sum_f (g - a_w) . (x_w - x_f) W_wf / sum_f W_wf

    A structure row with ``implicit[w] = rho c / rho_s > 0`` takes its acceleration
    implicitly, ``a_w = a~_w + f_w(p) / m_w`` with the interface pair force
    ``f_w = -c V_w sum_f V_f (p_w + p_f) grad W_wf`` [F 46-47] (``gb[w] = g - a~_w``: every
    acceleration but the fluid's), so the solve sees the structure's inertia (no added-mass
    instability of the staggered scheme)::

        (1 + sum_f k_wf) p_w + sum_f (k_wf - w_wf) p_f = rho (g - a~_w) . rbar_w,
        k_wf = -implicit[w] V_f (pair_w[f] grad W_wf) . rbar_w,  rbar_w = sum_f w_wf (x_w - x_f)

    (``pair_w[f]``: the pair weights of the interface force, the identity but on the
    waterline rows, ``IncompressibleFluid.interface_weights``). A wall particle with no fluid
    neighbour gets ``p_w = 0``.
    Columns are sorted within each row.
    """
    for i in prange(nf + nw):
        lo = indptr[i]
        if i < nf:
            if alpha[i] <= 0.0 or f_start[i + 1] == f_start[i]:
                out_indices[lo] = i
                out_data[lo] = diag_ref
                out_b[i] = 0.0
                continue
            e0 = 0.0
            e1 = 0.0
            for k in range(f_start[i], f_start[i + 1]):
                if not consistent[i]:
                    break
                j, d0, d1, r2, r = pair_offset_sq(x, x, f_j, i, k)
                if r > 1e-12 * h:
                    c = -2.0 * lap_scale * vol[j] * r * kernel_dw(kind, r, h) / (r2 + eta2)
                    e0 -= c * d0
                    e1 -= c * d1
            # e_i . L_i, so that e_i . (L_i gw) = (e_i L_i) . gw
            l0 = e0 * L[i, 0, 0] + e1 * L[i, 1, 0]
            l1 = e0 * L[i, 0, 1] + e1 * L[i, 1, 1]
            diag = 0.0
            e = lo + 1
            for k in range(f_start[i], f_start[i + 1]):
                j, d0, d1, r2, r = pair_offset_sq(x, x, f_j, i, k)
                a = 0.0
                if r > 1e-12 * h:
                    dw = kernel_dw(kind, r, h)
                    a = -2.0 * lap_scale * vol[j] * r * dw / (r2 + eta2)
                    a -= vol[j] * dw / r * (l0 * d0 + l1 * d1)
                diag += a
                out_indices[e] = j
                out_data[e] = -alpha[i] * a
                e += 1
            out_indices[lo] = i
            out_data[lo] = diag if diag > 0.0 else diag_ref
            out_b[i] = alpha[i] * source[i]
            _sort_row(out_indices, out_data, lo, e)
        else:
            w = i - nf
            sw = 0.0
            for k in range(w_start[w], w_start[w + 1]):
                j = w_j[k]
                d0 = x[i, 0] - x[j, 0]
                d1 = x[i, 1] - x[j, 1]
                sw += kernel_w(kind, math.sqrt(d0 * d0 + d1 * d1), h)
            rb0 = 0.0
            rb1 = 0.0
            if implicit[w] > 0.0 and sw > 0.0:
                for k in range(w_start[w], w_start[w + 1]):
                    j = w_j[k]
                    d0 = x[i, 0] - x[j, 0]
                    d1 = x[i, 1] - x[j, 1]
                    wt = kernel_w(kind, math.sqrt(d0 * d0 + d1 * d1), h) / sw
                    rb0 += wt * d0
                    rb1 += wt * d1
            out_indices[lo] = i
            diag = 1.0
            e = lo + 1
            rhs = 0.0
            for k in range(w_start[w], w_start[w + 1]):
                j, d0, d1, r = pair_offset(x, x, w_j, i, k)
                wt = 0.0
                if sw > 0.0:
                    wt = kernel_w(kind, r, h) / sw
                kwf = 0.0
                if implicit[w] > 0.0 and r > 1e-12 * h:
                    m0 = pair_w[j, 0, 0] * d0 + pair_w[j, 0, 1] * d1
                    m1 = pair_w[j, 1, 0] * d0 + pair_w[j, 1, 1] * d1
                    kwf = -implicit[w] * vol[j] * kernel_dw(kind, r, h) / r * (m0 * rb0 + m1 * rb1)
                diag += kwf
                out_indices[e] = j
                out_data[e] = diag_ref * (kwf - wt)
                rhs += rho * (gb[w, 0] * d0 + gb[w, 1] * d1) * wt
                e += 1
            out_data[lo] = diag_ref * diag
            out_b[i] = diag_ref * rhs
            _sort_row(out_indices, out_data, lo, e)


@njit(cache=True, inline="always")
def wall_floor(p_w, p_i, r0, r1, rg0, rg1):
    """A wall that cannot pull (``fluid.wall_suction = false``): the wall particle's pressure as
    fluid particle ``i`` sees it is at least ``i``'s own, carried hydrostatically to the wall
    particle at ``r = x_w - x_i`` (``rg = rho g``; 0 for a pressure increment). Adami's wall
    pressure is a kernel average over the wall's fluid neighbours; at the tip of a granular
    front, where those are free-surface particles at p = 0, it fell below the pressure of the
    one particle pressed against the wall, whose gradient then pushed it into the wall, and
    the growing compression raised its pressure 2.5-fold per step (to 0.6 MPa in 8 steps).
    It changes only the wall terms of the correction's gradient [F 7, F 13] / [F 10]; the
    floor itself has no equation in PHYSICS.md, and a hydrostatic wall pressure is its own
    floor (a tank at rest is unchanged)."""
    return max(p_w, p_i + rg0 * r0 + rg1 * r1)


@njit(cache=True, inline="always")
def _pressure_pair_sum(x, p, vol, nbr_start, nbr_j, i, h, kind, jmax, floored, floor_row, rg,
                       own):
    """``sum_j V_j (p_j + own p_i) grad W_ij`` over row ``i``'s sources ``j < jmax`` (``own``
    +1: the conservative pair sum [F 10], -1: the difference form [F 7]), the sources with
    ``floored[j]`` on a row with ``floor_row[i]`` taken at :func:`wall_floor`."""
    s0 = 0.0
    s1 = 0.0
    for k in range(nbr_start[i], nbr_start[i + 1]):
        j, d0, d1, r = pair_offset(x, x, nbr_j, i, k)
        if j >= jmax or r < 1e-12 * h:
            continue
        pj = p[j]
        if floored[j] and floor_row[i]:
            pj = wall_floor(pj, p[i], -d0, -d1, rg[j, 0], rg[j, 1])
        f = vol[j] * (pj + own * p[i]) * kernel_dw(kind, r, h) / r
        s0 += f * d0
        s1 += f * d1
    return s0, s1


@njit(cache=True, parallel=True)
def pressure_gradient(x, p, vol, nbr_start, nbr_j, nf, h, kind, grad_scale, jmax, floored,
                      floor_row, rg, out_grad):
    """Conservative pressure gradient [F 8, F 10]
    ``grad p_i = grad_scale sum_j V_j (p_i + p_j) grad W_ij``: the pair force
    ``-V_i V_j (p_i + p_j) grad W_ij`` is antisymmetric, so momentum is conserved.
    Sources ``j >= jmax`` (structure particles) are left to the coupling's pair force;
    sources with ``floored[j]`` on rows with ``floor_row[i]`` as in
    :func:`corrected_pressure_gradient`."""
    for i in prange(nf):
        s0, s1 = _pressure_pair_sum(x, p, vol, nbr_start, nbr_j, i, h, kind, jmax, floored,
                                    floor_row, rg, 1.0)
        out_grad[i, 0] = grad_scale * s0
        out_grad[i, 1] = grad_scale * s1


@njit(cache=True, parallel=True)
def structure_row_pressure_gradient(x, p, vol, nbr_start, nbr_j, nf, h, kind, grad_scale,
                                    jmax, floored, floor_row, rg, level_free, rows, out_grad):
    """The rows beside a coupled structure (``rows[i]``; the others untouched), the
    structure's own pair terms ``V_s (p_i + p_s) grad W_is`` [F 46-47] being added by the
    coupling. ``level_free`` False: the pair form [F 10]
    ``grad_scale sum_{j < jmax} V_j (p_i + p_j) grad W_ij``, which with the coupling's terms
    balances the interface force pair by pair. ``level_free`` True (a confined flow):
    ``grad_scale [sum_{j < jmax} V_j (p_j - p_i) grad W_ij - 2 p_i sum_{j >= jmax} V_j
    grad W_ij]``, so that with the coupling's terms the row's gradient is
    ``grad_scale sum_j V_j (p_j - p_i) grad W_ij`` over its whole support, structure
    included (the difference form [F 7] without its correction matrix): the pair form less
    its self-term ``2 p_i sum_j V_j grad W_ij``, by which a uniform pressure pushes a row of
    an irregular support; the structure keeps the pair form's reaction (the absolute
    pressure on its surface). Floors as in :func:`corrected_pressure_gradient`."""
    own = -1.0 if level_free else 1.0
    for i in prange(nf):
        if not rows[i]:
            continue
        s0, s1 = _pressure_pair_sum(x, p, vol, nbr_start, nbr_j, i, h, kind, jmax, floored,
                                    floor_row, rg, own)
        if level_free:  # the self-term of the structure's pairs
            for k in range(nbr_start[i], nbr_start[i + 1]):
                j, d0, d1, r = pair_offset(x, x, nbr_j, i, k)
                if j < jmax or r < 1e-12 * h:
                    continue
                f = -2.0 * p[i] * vol[j] * kernel_dw(kind, r, h) / r
                s0 += f * d0
                s1 += f * d1
        out_grad[i, 0] = grad_scale * s0
        out_grad[i, 1] = grad_scale * s1


@njit(cache=True, parallel=True)
def corrected_pressure_gradient(x, p, vol, L, nbr_start, nbr_j, nf, h, kind, jmax, floored,
                                floor_row, rg, out_grad):
    """Consistent, corrected pressure gradient [F 7, F 13-14]
    ``grad p_i = sum_j V_j (p_j - p_i) L_i grad W_ij``: exact for linear ``p`` also where the
    support is truncated (free surface), but the pair forces are not antisymmetric.
    Sources ``j >= jmax`` (structure particles) are left to the coupling's pair force.
    Sources with ``floored[j]`` (walls that cannot pull, :func:`wall_floor`) enter the rows
    with ``floor_row[i]`` as ``max(p_j, p_i + rho g_j . (x_j - x_i))`` (``rg[j] = rho g_j``,
    the body force of wall row ``j``'s pressure extrapolation); ``floored`` and ``rg`` have
    one entry per stacked row, ``floor_row`` one per fluid row (``floored`` all False: no
    floor)."""
    for i in prange(nf):
        s0, s1 = _pressure_pair_sum(x, p, vol, nbr_start, nbr_j, i, h, kind, jmax, floored,
                                    floor_row, rg, -1.0)
        out_grad[i, 0] = L[i, 0, 0] * s0 + L[i, 0, 1] * s1
        out_grad[i, 1] = L[i, 1, 0] * s0 + L[i, 1, 1] * s1
