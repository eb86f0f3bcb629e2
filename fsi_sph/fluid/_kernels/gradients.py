"""Gradient loops of the fluid: correction matrices [F 13-14], corrected gradients [F 7],
the Smagorinsky viscosity, the explicit predictor [F 16], the velocity divergence, wall
normals, Shepard averages and fluid-only sublists (gather-only)."""

import math

import numpy as np
from numba import njit, prange

from fsi_sph.sph import operators
from fsi_sph.sph.kernels import kernel_dw, kernel_w, pair_offset, pair_offset_sq

DET_MIN = 0.05  # |det M| below this (full support: ~1) -> no kernel-gradient correction


@njit(cache=True)
def correction_matrices(x, vol, nbr_start, nbr_j, h, kind, out_L):
    """Oger's correction [F 13-14] (:func:`fsi_sph.sph.operators.correction_matrices`) with
    the fluid's threshold ``DET_MIN`` (splashed particles fall back to the identity)."""
    operators.correction_matrices(x, vol, nbr_start, nbr_j, h, kind, DET_MIN, out_L)


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
            j, d0, d1, r2, r = pair_offset_sq(x, x, nbr_j, i, k)
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
            j, d0, d1, r = pair_offset(x, x, nbr_j, i, k)
            if r < 1e-12 * h:
                continue
            dw = kernel_dw(kind, r, h) / r
            s += vol[j] * ((v[j, 0] - v[i, 0]) * d0 + (v[j, 1] - v[i, 1]) * d1) * dw
        out_div[i] = grad_scale * s


@njit(cache=True, parallel=True)
def wall_normals(xw, vol, nbr_start, nbr_j, h, kind, out_n):
    """Outward unit normals of wall particles, ``-grad C / |grad C|`` over the wall set
    (``grad C_w = sum_v V_v grad W_wv``, pointing into the wall). Zero where undefined."""
    for i in prange(xw.shape[0]):
        g0 = 0.0
        g1 = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j, d0, d1, r = pair_offset(xw, xw, nbr_j, i, k)
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


@njit(cache=True, inline="always")
def _fluid_count(nbr_start, nbr_j, fluid_of, i):
    """Number of fluid neighbours (``fluid_of[j] >= 0``) of row ``i``."""
    k = 0
    for s in range(nbr_start[i], nbr_start[i + 1]):
        if fluid_of[nbr_j[s]] >= 0:
            k += 1
    return k


@njit(cache=True, parallel=True)
def fluid_neighbour_counts(nbr_start, nbr_j, fluid_of, out_count):
    """Number of fluid neighbours (``fluid_of[j] >= 0``) of each row ``i < len(out_count)``."""
    for i in prange(out_count.shape[0]):
        out_count[i] = _fluid_count(nbr_start, nbr_j, fluid_of, i)


@njit(cache=True)
def fluid_sublists(nbr_start, nbr_j, fluid_of, rows, out_start):
    """The pair lists restricted to the rows with ``rows[i]`` true and to fluid neighbours
    (``fluid_of[j] >= 0``); other rows get empty lists. Returns the new ``nbr_j`` (same
    order); ``out_start`` (n + 1) is filled."""
    n = out_start.shape[0] - 1
    out_start[0] = 0
    for i in range(n):
        k = _fluid_count(nbr_start, nbr_j, fluid_of, i) if rows[i] else 0
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
