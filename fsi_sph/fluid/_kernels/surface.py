"""Free-surface loops of the fluid: ``div r`` and the colour gradient, the umbrella scan, the
particle classes, the isolated rows (gather-only; conventions in :mod:`fsi_sph.fluid._kernels`)."""

import math

from numba import get_thread_id, njit, prange

from fsi_sph.sph.kernels import kernel_dw, kernel_w, pair_offset

INTERIOR = 0
NEAR_SURFACE = 1
SURFACE = 2
SPLASHED = 3


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
            j, d0, d1, r = pair_offset(x, x, nbr_j, i, k)
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


@njit(cache=True, parallel=True)
def pocket_rows(is_surface, nbr_start, nbr_j, nf, found, out):
    """``out[i]``: row ``i`` is a Poisson row (not a surface row, with neighbours) of a
    connected set of Poisson rows (joined through fluid neighbours ``j < nf``) with fewer than
    ``nmin`` rows and a surface row beside one of them: a pocket among surface rows
    (:func:`free_surface.detect`). A breadth-first search from each Poisson row with a
    surface neighbour, stopped at ``nmin`` rows; a pocket's rows are all marked (the same
    value from every search that finds them). ``found``: the searches' scratch, one row of
    ``nmin`` entries per numba thread (``numba.config.NUMBA_NUM_THREADS`` rows: no allocation
    in the loop)."""
    nmin = found.shape[1]
    for i in prange(nf):
        out[i] = False
    for i in prange(nf):
        if is_surface[i] or nbr_start[i + 1] == nbr_start[i]:
            continue
        edge = False
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            if j < nf and is_surface[j]:
                edge = True
                break
        if not edge:
            continue
        seen_rows = found[get_thread_id()]
        seen_rows[0] = i
        n = 1
        head = 0
        while head < n and n < nmin:
            a = seen_rows[head]
            head += 1
            for k in range(nbr_start[a], nbr_start[a + 1]):
                j = nbr_j[k]
                if j >= nf or is_surface[j] or nbr_start[j + 1] == nbr_start[j]:
                    continue
                seen = False
                for q in range(n):
                    if seen_rows[q] == j:
                        seen = True
                        break
                if not seen:
                    seen_rows[n] = j
                    n += 1
                    if n == nmin:
                        break
        if n < nmin:
            for q in range(n):
                out[seen_rows[q]] = True
