"""Numba particle loops of the incompressible SPH fluid (gather-only: iteration ``i`` writes
only row ``i``).

Index space: the fluid particles come first (``0 .. nf-1``), the wall particles after them
(``nf .. nf+nw-1``); ``x``, ``v``, ``p``, ``vol`` passed to the loops are these stacked arrays.
Neighbour lists are CSR: ``nbr_j[nbr_start[i]:nbr_start[i+1]]`` are the sources of row ``i``
(fluid rows: fluid and wall sources, self excluded; wall rows: fluid sources).

Kernel gradient convention: ``grad W_ij = dW/dr (x_i - x_j) / r`` (gradient at ``x_i``).
Lattice normalisation: on a full, uniform lattice with h = 1.2 dx the discrete moment
``sum_j V_j (x_j - x_i) (x) grad W_ij`` is 0.991 I rather than I and the Morris sum of
``|r_ij|^2`` is 3.92 rather than 4. The callers pass global constants ``grad_scale`` and
``lap_scale`` that remove these lattice errors (one number per run, so pair antisymmetry and
the matrix structure are kept) and make the operators exact on linear (gradient) and
quadratic (Laplacian) fields in the interior of a uniform lattice.
"""

import math

import numpy as np
from numba import njit, prange

from fsi_sph.sph import operators
from fsi_sph.sph.kernels import kernel_dw, kernel_w

INTERIOR = 0
NEAR_SURFACE = 1
SURFACE = 2
SPLASHED = 3

DET_MIN = 0.05  # |det M| below this (full support: ~1) -> no kernel-gradient correction


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
def position_divergence(x, vol, nbr_start, nbr_j, h, kind, out_divr, out_grad_c, out_sigma):
    """Free-surface indicator ``div r_i = - sum_j V_j r_ij . grad W_ij`` (2 inside a full 2D
    support), the colour gradient ``grad C_i = sum_j V_j grad W_ij`` [F 27] (points into
    the fluid; zero inside a full, regular support) and the kernel sum
    ``sigma_i = V_i W(0) + sum_j V_j W_ij`` (the number density times the particle volume)."""
    for i in prange(out_divr.shape[0]):
        s = 0.0
        g0 = 0.0
        g1 = 0.0
        sw = vol[i] * kernel_w(kind, 0.0, h)
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            d0 = x[i, 0] - x[j, 0]
            d1 = x[i, 1] - x[j, 1]
            r = math.sqrt(d0 * d0 + d1 * d1)
            if r < 1e-12 * h:
                continue
            dw = kernel_dw(kind, r, h)
            s -= vol[j] * r * dw
            g0 += vol[j] * dw * d0 / r
            g1 += vol[j] * dw * d1 / r
            sw += vol[j] * kernel_w(kind, r, h)
        out_divr[i] = s
        out_sigma[i] = sw
        out_grad_c[i, 0] = g0
        out_grad_c[i, 1] = g1


@njit(cache=True, parallel=True)
def umbrella_scan(x, candidate, grad_c, nbr_start, nbr_j, nf, h, out_flag):
    """Marrone et al.'s (2010, JCP 229:3652) geometric free-surface test: a candidate row
    ``i`` whose umbrella-shaped region along its outward normal ``n_i = -grad C_i / |grad
    C_i|`` holds no neighbour (fluid or boundary) lies on the free surface. With ``T = x_i +
    h n_i`` and ``d = x_j - x_i`` the region is::

        |d| >= sqrt(2) h  and  |x_j - T| < h,   or
        |d| <  sqrt(2) h  and  |n_perp . d| + |n . (x_j - T)| < h

    (a 90 deg cone from ``x_i`` along ``n_i`` capped by the circle of radius ``h`` about
    ``T``). ``out_flag[i]`` (bool) is True for a candidate with an empty region, False
    otherwise (also for a candidate without a normal). No equation of PHYSICS.md: a
    published detection rule added to the [F 21] divergence flag (free_surface.detect)."""
    r2_cone = 2.0 * h * h
    for i in prange(nf):
        out_flag[i] = False
        if not candidate[i]:
            continue
        g = math.sqrt(grad_c[i, 0] ** 2 + grad_c[i, 1] ** 2)
        if g <= 0.0:
            continue
        n0 = -grad_c[i, 0] / g
        n1 = -grad_c[i, 1] / g
        t0 = x[i, 0] + h * n0
        t1 = x[i, 1] + h * n1
        empty = True
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            d0 = x[j, 0] - x[i, 0]
            d1 = x[j, 1] - x[i, 1]
            e0 = x[j, 0] - t0
            e1 = x[j, 1] - t1
            if d0 * d0 + d1 * d1 >= r2_cone:
                inside = e0 * e0 + e1 * e1 < h * h
            else:
                inside = abs(-n1 * d0 + n0 * d1) + abs(n0 * e0 + n1 * e1) < h
            if inside:
                empty = False
                break
        out_flag[i] = empty


@njit(cache=True)
def correction_matrices(x, vol, nbr_start, nbr_j, h, kind, out_L):
    """Oger's correction [F 13-14] (:func:`fsi_sph.sph.operators.correction_matrices`) with
    the fluid's threshold ``DET_MIN`` (splashed particles fall back to the identity)."""
    operators.correction_matrices(x, vol, nbr_start, nbr_j, h, kind, DET_MIN, out_L)


@njit(cache=True, parallel=True)
def surface_classes(x, is_surface, n_nbr, grad_c, nbr_start, nbr_j, nf, h, out_class,
                    out_normal):
    """Particle classes [F Fig. 2] and free-surface normals [F 27-28].

    ``is_surface[i]``: ``div r_i < chi`` and ``i`` has neighbours. Surface particles get
    ``n_i = -grad C_i / |grad C_i|``; a near-surface particle (not surface, within ``h`` of a
    surface particle) takes the normal of its nearest surface neighbour; particles with no
    neighbour are splashed (zero normal); the rest are interior (zero normal).
    """
    for i in prange(nf):
        out_normal[i, 0] = 0.0
        out_normal[i, 1] = 0.0
        if n_nbr[i] == 0:
            out_class[i] = SPLASHED
            continue
        if is_surface[i]:
            out_class[i] = SURFACE
            g = math.sqrt(grad_c[i, 0] ** 2 + grad_c[i, 1] ** 2)
            if g > 0.0:
                out_normal[i, 0] = -grad_c[i, 0] / g
                out_normal[i, 1] = -grad_c[i, 1] / g
            continue
        best = h * h
        jb = -1
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            if j >= nf or not is_surface[j]:
                continue
            d0 = x[i, 0] - x[j, 0]
            d1 = x[i, 1] - x[j, 1]
            r2 = d0 * d0 + d1 * d1
            if r2 <= best:
                best = r2
                jb = j
        if jb < 0:
            out_class[i] = INTERIOR
        else:
            out_class[i] = NEAR_SURFACE
            g = math.sqrt(grad_c[jb, 0] ** 2 + grad_c[jb, 1] ** 2)
            if g > 0.0:
                out_normal[i, 0] = -grad_c[jb, 0] / g
                out_normal[i, 1] = -grad_c[jb, 1] / g


@njit(cache=True, inline="always")
def corrected_pair_gradient(x, vol, L, i, j, h, kind):
    """``V_j L_i grad_i W_ij`` [F 7, F 13-14], the weight of pair ``(i, j)`` in the corrected
    consistent gradient ``grad phi_i = sum_j (phi_j - phi_i) V_j L_i grad W_ij``; ``(0, 0)``
    for coincident particles."""
    d0 = x[i, 0] - x[j, 0]
    d1 = x[i, 1] - x[j, 1]
    r = math.sqrt(d0 * d0 + d1 * d1)
    if r < 1e-12 * h:
        return 0.0, 0.0
    dw = kernel_dw(kind, r, h)
    w0 = dw * d0 / r
    w1 = dw * d1 / r
    return (vol[j] * (L[i, 0, 0] * w0 + L[i, 0, 1] * w1),
            vol[j] * (L[i, 1, 0] * w0 + L[i, 1, 1] * w1))


@njit(cache=True, parallel=True)
def gradients(x, p, v, vol, L, nbr_start, nbr_j, nf, h, kind, out_grad_p, out_grad_v,
              jv=-1):
    """Corrected consistent gradients [F 7, F 13]: ``grad phi_i = sum_j V_j (phi_j - phi_i)
    L_i grad W_ij`` of the pressure (``out_grad_p``, (nf, 2)) and of the velocity
    (``out_grad_v[i, k, l] = d v_k / d x_l``, (nf, 2, 2)).

    ``jv >= 0``: sources ``j >= jv`` (walls, structures) enter the velocity gradient with the
    row's own velocity (no difference): a zero normal derivative of the velocity at the
    boundary, the free-slip condition. (Their no-slip velocity would put a spurious shear of
    ``|u| / dx`` into the gradient of every particle sliding along a wall.)"""
    for i in prange(nf):
        gp0 = 0.0
        gp1 = 0.0
        g00 = 0.0
        g01 = 0.0
        g10 = 0.0
        g11 = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            c0, c1 = corrected_pair_gradient(x, vol, L, i, j, h, kind)
            dp = p[j] - p[i]
            gp0 += dp * c0
            gp1 += dp * c1
            if jv >= 0 and j >= jv:
                continue
            du = v[j, 0] - v[i, 0]
            dv = v[j, 1] - v[i, 1]
            g00 += du * c0
            g01 += du * c1
            g10 += dv * c0
            g11 += dv * c1
        out_grad_p[i, 0] = gp0
        out_grad_p[i, 1] = gp1
        out_grad_v[i, 0, 0] = g00
        out_grad_v[i, 0, 1] = g01
        out_grad_v[i, 1, 0] = g10
        out_grad_v[i, 1, 1] = g11


@njit(cache=True, parallel=True)
def smagorinsky(grad_v, cs_dx2, nu0, out_nu):
    """Effective viscosity ``nu0 + (C_s dx)^2 sqrt(2 S:S)`` [F 3], ``S`` the strain rate."""
    for i in prange(grad_v.shape[0]):
        s00 = grad_v[i, 0, 0]
        s11 = grad_v[i, 1, 1]
        s01 = 0.5 * (grad_v[i, 0, 1] + grad_v[i, 1, 0])
        out_nu[i] = nu0 + cs_dx2 * math.sqrt(2.0 * (s00 * s00 + s11 * s11 + 2.0 * s01 * s01))


@njit(cache=True, parallel=True)
def predict_velocity(x, v, vol, nu, nbr_start, nbr_j, nf, h, kind, eta2, g0, g1, dt, out_v):
    """Intermediate velocity [F 16] ``u*_i = u_i + dt ((nu + nu_T) lap u_i + g)`` with the
    Morris viscous term [F 11-12]
    ``sum_j V_j (nu_i + nu_j) (u_i - u_j) (r_ij . grad W_ij) / (r_ij^2 + eta^2)``.
    Wall particles carry their own (zero) velocity: no slip."""
    for i in prange(nf):
        a0 = 0.0
        a1 = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            d0 = x[i, 0] - x[j, 0]
            d1 = x[i, 1] - x[j, 1]
            r2 = d0 * d0 + d1 * d1
            r = math.sqrt(r2)
            if r < 1e-12 * h:
                continue
            f = vol[j] * (nu[i] + nu[j]) * r * kernel_dw(kind, r, h) / (r2 + eta2)
            a0 += f * (v[i, 0] - v[j, 0])
            a1 += f * (v[i, 1] - v[j, 1])
        out_v[i, 0] = v[i, 0] + dt * (a0 + g0)
        out_v[i, 1] = v[i, 1] + dt * (a1 + g1)


@njit(cache=True, parallel=True)
def velocity_divergence(x, v, vol, nbr_start, nbr_j, nf, h, kind, grad_scale, out_div):
    """``div u_i = grad_scale * sum_j V_j (u_j - u_i) . grad W_ij`` [F 7] over fluid and wall
    neighbours (walls with their own velocity)."""
    for i in prange(nf):
        s = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            d0 = x[i, 0] - x[j, 0]
            d1 = x[i, 1] - x[j, 1]
            r = math.sqrt(d0 * d0 + d1 * d1)
            if r < 1e-12 * h:
                continue
            dw = kernel_dw(kind, r, h) / r
            s += vol[j] * ((v[j, 0] - v[i, 0]) * d0 + (v[j, 1] - v[i, 1]) * d1) * dw
        out_div[i] = grad_scale * s


@njit(cache=True, parallel=True)
def collision_dv(x, v, m, nbr_start, nbr_j, nf, fluid_of, r_c, restitution, out_dv):
    """Velocity change of the particle collision model (``fluid.collision``): every pair of
    fluid particles closer than ``r_c`` that approach each other, ``w = (u_i - u_j) . n_ij
    < 0`` with ``n_ij = (x_i - x_j) / r``, loses the approach as in a collision with
    restitution ``e``: ``du_i = -(1 + e) m_j / (m_i + m_j) w n_ij`` (equal and opposite
    momentum changes, so momentum is conserved; all pairs from the same ``v``). A numerical
    contact rule with no equation in PHYSICS.md: it acts after the correction [F 18] only on
    pairs closer than any the continuum flow leaves (interior pairs stay > 0.8 dx apart).
    ``fluid_of[j]``: the fluid particle that row ``j`` of the stacked positions is (itself,
    or the original of a periodic image), -1 for boundary rows; ``v`` and ``m`` per fluid
    particle."""
    for i in prange(nf):
        d0 = 0.0
        d1 = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            jf = fluid_of[j]
            if jf < 0 or jf == i:
                continue
            n0 = x[i, 0] - x[j, 0]
            n1 = x[i, 1] - x[j, 1]
            r = math.sqrt(n0 * n0 + n1 * n1)
            if r >= r_c or r < 1e-12 * r_c:
                continue
            n0 /= r
            n1 /= r
            w = (v[i, 0] - v[jf, 0]) * n0 + (v[i, 1] - v[jf, 1]) * n1
            if w < 0.0:
                c = -(1.0 + restitution) * m[jf] / (m[i] + m[jf]) * w
                d0 += c * n0
                d1 += c * n1
        out_dv[i, 0] = d0
        out_dv[i, 1] = d1


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
                j = f_j[k]
                d0 = x[i, 0] - x[j, 0]
                d1 = x[i, 1] - x[j, 1]
                r2 = d0 * d0 + d1 * d1
                r = math.sqrt(r2)
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
                j = f_j[k]
                d0 = x[i, 0] - x[j, 0]
                d1 = x[i, 1] - x[j, 1]
                r2 = d0 * d0 + d1 * d1
                r = math.sqrt(r2)
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
                j = w_j[k]
                d0 = x[i, 0] - x[j, 0]
                d1 = x[i, 1] - x[j, 1]
                r = math.sqrt(d0 * d0 + d1 * d1)
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
        s0 = 0.0
        s1 = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            if j >= jmax:
                continue
            d0 = x[i, 0] - x[j, 0]
            d1 = x[i, 1] - x[j, 1]
            r = math.sqrt(d0 * d0 + d1 * d1)
            if r < 1e-12 * h:
                continue
            pj = p[j]
            if floored[j] and floor_row[i]:
                pj = wall_floor(pj, p[i], -d0, -d1, rg[j, 0], rg[j, 1])
            f = vol[j] * (p[i] + pj) * kernel_dw(kind, r, h) / r
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
        s0 = 0.0
        s1 = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            if j >= jmax:
                continue
            d0 = x[i, 0] - x[j, 0]
            d1 = x[i, 1] - x[j, 1]
            r = math.sqrt(d0 * d0 + d1 * d1)
            if r < 1e-12 * h:
                continue
            pj = p[j]
            if floored[j] and floor_row[i]:
                pj = wall_floor(pj, p[i], -d0, -d1, rg[j, 0], rg[j, 1])
            f = vol[j] * (pj - p[i]) * kernel_dw(kind, r, h) / r
            s0 += f * d0
            s1 += f * d1
        out_grad[i, 0] = L[i, 0, 0] * s0 + L[i, 0, 1] * s1
        out_grad[i, 1] = L[i, 1, 0] * s0 + L[i, 1, 1] * s1


@njit(cache=True, parallel=True)
def shift_vectors(x, v, vol, nbr_start, nbr_j, nf, h, kind, model, coef, dt, cap, classes,
                  normals, out_dr):
    """Particle shift [F 22-33].

    ``model = 0`` (Fickian, Lind et al. 2012): ``dr_i = -A h |u_i| dt grad C_i``,
    ``grad C_i = sum_j V_j grad W_ij``; ``model = 2`` (Fickian with a fixed diffusion
    coefficient, ``D = A h^2``): ``dr_i = -A h^2 grad C_i``; ``model = 1`` (centroid, [F 23-25]):
    ``dr_i = eps sum_j V_j r_ij W_ij``. Surface and near-surface particles keep only the
    tangential part ``(I - n n) dr`` [F 31-32]; splashed particles do not shift; ``|dr| <=
    cap`` (m).
    """
    for i in prange(nf):
        out_dr[i, 0] = 0.0
        out_dr[i, 1] = 0.0
        c = classes[i]
        if c == SPLASHED:
            continue
        s0 = 0.0
        s1 = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            d0 = x[i, 0] - x[j, 0]
            d1 = x[i, 1] - x[j, 1]
            r = math.sqrt(d0 * d0 + d1 * d1)
            if r < 1e-12 * h:
                continue
            if model != 1:
                f = vol[j] * kernel_dw(kind, r, h) / r
            else:
                f = vol[j] * kernel_w(kind, r, h)
            s0 += f * d0
            s1 += f * d1
        if model == 0:
            speed = math.sqrt(v[i, 0] ** 2 + v[i, 1] ** 2)
            s0 *= -coef * h * speed * dt
            s1 *= -coef * h * speed * dt
        elif model == 2:
            s0 *= -coef * h * h
            s1 *= -coef * h * h
        else:
            s0 *= coef
            s1 *= coef
        if c == SURFACE or c == NEAR_SURFACE:
            n0 = normals[i, 0]
            n1 = normals[i, 1]
            dn = s0 * n0 + s1 * n1
            s0 -= dn * n0
            s1 -= dn * n1
        m = math.sqrt(s0 * s0 + s1 * s1)
        if m > cap:
            s0 *= cap / m
            s1 *= cap / m
        out_dr[i, 0] = s0
        out_dr[i, 1] = s1


@njit(cache=True, parallel=True)
def neighbour_bounds(p, v, nbr_start, nbr_j, nf, jv, out_lo, out_hi):
    """Smallest and largest ``(u, v, p)`` over row ``i`` and its neighbours (``out_lo``,
    ``out_hi``: (nf, 3)); the velocity over sources ``j < jv`` only when ``jv >= 0`` (the
    boundary rows of a free-slip wall carry no velocity of their own)."""
    for i in prange(nf):
        lo0, lo1, lo2 = v[i, 0], v[i, 1], p[i]
        hi0, hi1, hi2 = lo0, lo1, lo2
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            lo2 = min(lo2, p[j])
            hi2 = max(hi2, p[j])
            if jv >= 0 and j >= jv:
                continue
            lo0 = min(lo0, v[j, 0])
            hi0 = max(hi0, v[j, 0])
            lo1 = min(lo1, v[j, 1])
            hi1 = max(hi1, v[j, 1])
        out_lo[i, 0] = lo0
        out_lo[i, 1] = lo1
        out_lo[i, 2] = lo2
        out_hi[i, 0] = hi0
        out_hi[i, 1] = hi1
        out_hi[i, 2] = hi2


@njit(cache=True, parallel=True)
def apply_shift(dr, grad_p, grad_v, taylor, lo, hi, x, p, v, energy_cap=False):
    """``x += dr`` and, with ``taylor``, ``phi += dr . grad phi`` for p and u [F 33], each
    result clamped to ``[lo, hi]`` (:func:`neighbour_bounds`: the range of the neighbourhood,
    a monotonicity limiter). Without the clamp a particle whose velocity stands out from its
    neighbours' is extrapolated further out whenever it shifts away from them: the gradient
    is its own difference to them (seen: a particle at 12 m/s among neighbours at 1 m/s
    gained 2 m/s per step in the gate's outflow). ``energy_cap``: the corrected velocity is
    scaled back to the particle's speed before the shift where it would be faster (the shift
    moves particles, it makes no kinetic energy: without it the dam break's spray gained
    energy without bound, +56 % of the column's by 3 s; with it the energy falls, session
    notes 2026-12-01f)."""
    for i in prange(dr.shape[0]):
        d0 = dr[i, 0]
        d1 = dr[i, 1]
        x[i, 0] += d0
        x[i, 1] += d1
        if taylor:
            pn = p[i] + d0 * grad_p[i, 0] + d1 * grad_p[i, 1]
            v0 = v[i, 0] + grad_v[i, 0, 0] * d0 + grad_v[i, 0, 1] * d1
            v1 = v[i, 1] + grad_v[i, 1, 0] * d0 + grad_v[i, 1, 1] * d1
            p[i] = min(max(pn, lo[i, 2]), hi[i, 2])
            v0 = min(max(v0, lo[i, 0]), hi[i, 0])
            v1 = min(max(v1, lo[i, 1]), hi[i, 1])
            if energy_cap:
                s_old = v[i, 0] * v[i, 0] + v[i, 1] * v[i, 1]
                s_new = v0 * v0 + v1 * v1
                if s_new > s_old:
                    c = math.sqrt(s_old / s_new)
                    v0 *= c
                    v1 *= c
            v[i, 0] = v0
            v[i, 1] = v1


@njit(cache=True, parallel=True)
def wall_normals(xw, vol, nbr_start, nbr_j, h, kind, out_n):
    """Outward unit normals of wall particles, ``-grad C / |grad C|`` over the wall set
    (``grad C_w = sum_v V_v grad W_wv``, pointing into the wall). Zero where undefined."""
    for i in prange(xw.shape[0]):
        g0 = 0.0
        g1 = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            d0 = xw[i, 0] - xw[j, 0]
            d1 = xw[i, 1] - xw[j, 1]
            r = math.sqrt(d0 * d0 + d1 * d1)
            if r < 1e-12 * h:
                continue
            dw = kernel_dw(kind, r, h) / r
            g0 += vol[j] * dw * d0
            g1 += vol[j] * dw * d1
        g = math.sqrt(g0 * g0 + g1 * g1)
        if g > 1e-3 / h:
            out_n[i, 0] = -g0 / g
            out_n[i, 1] = -g1 / g
        else:
            out_n[i, 0] = 0.0
            out_n[i, 1] = 0.0


@njit(cache=True)
def nearest_source(x, nbr_start, nbr_j, i, j_lo, j_hi, normals):
    """The neighbour ``j_lo <= j < j_hi`` of row ``i`` nearest to it among those with a
    surface normal (``normals[j - j_lo] != 0``; -1 if none). Interior boundary particles
    (zero normal) are passed over: a fluid particle that has come closer to one of them than
    to the surface layer is still guarded by the surface layer's normal."""
    best = 1e300
    jb = -1
    for k in range(nbr_start[i], nbr_start[i + 1]):
        j = nbr_j[k]
        if j < j_lo or j >= j_hi:
            continue
        if normals[j - j_lo, 0] == 0.0 and normals[j - j_lo, 1] == 0.0:
            continue
        d0 = x[i, 0] - x[j, 0]
        d1 = x[i, 1] - x[j, 1]
        r2 = d0 * d0 + d1 * d1
        if r2 < best:
            best = r2
            jb = j
    return jb


@njit(cache=True, parallel=True)
def boundary_guard(x, nbr_start, nbr_j, nf, j_lo, j_hi, normals, v_b, gap, dt, v_old, v,
                   out_dv, out_row, stop=False, w_new=0.5):
    """Kinematic guard at a boundary (sources ``j_lo <= j < j_hi``: the walls, or the moving
    structures; ``normals`` and boundary velocities ``v_b`` indexed from ``j_lo``).

    A fluid particle closer than ``gap`` (along the normal) to its nearest boundary particle
    loses the part of its velocity relative to that particle that points into the boundary
    (in ``v_old`` and ``v``). A particle farther out whose step
    ``dt ((1 - w_new) v_old + w_new v)`` (the fluid's position update: 0.5 for the
    trapezoid [F 19], 1.5 for the damped one) would
    end closer than ``gap`` has both normal parts scaled so that it ends at ``gap`` (the
    step is swept: a particle cannot jump over the guard's band in one long step). A
    free-surface particle has a Dirichlet PPE row, which imposes no continuity constraint,
    so nothing else stops a thin jet from sinking into a wall or running into a structure;
    elsewhere the boundary pressure keeps the particles away and this does nothing. The
    change of ``v`` and the boundary row go to ``out_dv`` and ``out_row`` (-1: none), so
    that a moving boundary can get the opposite impulse. For a displacement (the shift)
    pass it as ``v`` and ``v_old`` alike (copies) with ``dt = 1``. ``stop``: a particle whose
    step would reach the band loses its whole velocity into the boundary (an inelastic
    contact within the step) instead of the share that takes it past the band's edge."""
    for i in prange(nf):
        out_dv[i, 0] = 0.0
        out_dv[i, 1] = 0.0
        out_row[i] = -1
        jb = nearest_source(x, nbr_start, nbr_j, i, j_lo, j_hi, normals)
        if jb < 0:
            continue
        b = jb - j_lo
        n0 = normals[b, 0]
        n1 = normals[b, 1]
        dn = (x[i, 0] - x[jb, 0]) * n0 + (x[i, 1] - x[jb, 1]) * n1
        un = (v[i, 0] - v_b[b, 0]) * n0 + (v[i, 1] - v_b[b, 1]) * n1
        un_old = (v_old[i, 0] - v_b[b, 0]) * n0 + (v_old[i, 1] - v_b[b, 1]) * n1
        if dn >= gap:
            step = dt * (w_new * un + (1.0 - w_new) * un_old)
            if dn + step >= gap:
                continue
            cut = 1.0 if stop else 1.0 - (gap - dn) / step  # step < gap - dn <= 0
            un *= cut
            un_old *= cut
        else:
            un = min(un, 0.0)
            un_old = min(un_old, 0.0)
        if un != 0.0:
            out_dv[i, 0] = -un * n0
            out_dv[i, 1] = -un * n1
            v[i, 0] -= un * n0
            v[i, 1] -= un * n1
            out_row[i] = b
        v_old[i, 0] -= un_old * n0
        v_old[i, 1] -= un_old * n1


@njit(cache=True)
def shepard_at(points, x, p, nbr_start, nbr_j, h, kind, out):
    """Shepard interpolation ``sum_j p_j W / sum_j W`` at ``points`` (NaN where empty)."""
    for i in range(points.shape[0]):
        sw = 0.0
        sp = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            d0 = points[i, 0] - x[j, 0]
            d1 = points[i, 1] - x[j, 1]
            w = kernel_w(kind, math.sqrt(d0 * d0 + d1 * d1), h)
            sw += w
            sp += w * p[j]
        out[i] = sp / sw if sw > 0.0 else np.nan


@njit(cache=True)
def fluid_sublists(nbr_start, nbr_j, fluid_of, rows, out_start):
    """The pair lists restricted to the rows with ``rows[i]`` true and to fluid neighbours
    (``fluid_of[j] >= 0``); other rows get empty lists. Returns the new ``nbr_j`` (same
    order); ``out_start`` (n + 1) is filled."""
    n = out_start.shape[0] - 1
    out_start[0] = 0
    for i in range(n):
        k = 0
        if rows[i]:
            for s in range(nbr_start[i], nbr_start[i + 1]):
                if fluid_of[nbr_j[s]] >= 0:
                    k += 1
        out_start[i + 1] = out_start[i] + k
    out_j = np.empty(out_start[n], dtype=np.int64)
    for i in range(n):
        if rows[i]:
            k = out_start[i]
            for s in range(nbr_start[i], nbr_start[i + 1]):
                if fluid_of[nbr_j[s]] >= 0:
                    out_j[k] = nbr_j[s]
                    k += 1
    return out_j


@njit(cache=True)
def isolated_rows(is_surface, nbr_start, nbr_j, nf, out):
    """``out[i]``: row ``i`` is not a surface row, has neighbours, and every one of its fluid
    neighbours (``j < nf``; walls and periodic images are not looked at) is a surface row:
    a Poisson row with no Poisson row beside it (:func:`free_surface.detect`)."""
    for i in range(nf):
        out[i] = False
        if is_surface[i] or nbr_start[i + 1] == nbr_start[i]:
            continue
        alone = True
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            if j < nf and not is_surface[j]:
                alone = False
                break
        out[i] = alone
