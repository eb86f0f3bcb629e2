"""Smoothing kernels in 2D, support radius 2h.

Each kernel is a pair of scalar ``@njit`` functions ``w(r, h)`` and ``dw_dr(r, h)``.
Particle loops receive an integer kernel id (``KERNELS[name]``) and call
:func:`kernel_w` / :func:`kernel_dw`, so no function objects cross the numba boundary.
"""

import math

from numba import njit

CUBIC_SPLINE = 0
WENDLAND_C2 = 1

#: registry: case-file name -> kernel id
KERNELS = {"cubic_spline": CUBIC_SPLINE, "wendland_c2": WENDLAND_C2}

SUPPORT = 2.0  # support radius in units of h, for both kernels


@njit(cache=True)
def cubic_w(r, h):
    """Cubic B-spline [F 5]: a_d {2/3 - q^2 + q^3/2; (2-q)^3/6; 0}, a_d = 15/(7 pi h^2)."""
    q = r / h
    a_d = 15.0 / (7.0 * math.pi * h * h)
    if q < 1.0:
        return a_d * (2.0 / 3.0 - q * q + 0.5 * q * q * q)
    if q < 2.0:
        t = 2.0 - q
        return a_d * t * t * t / 6.0
    return 0.0


@njit(cache=True)
def cubic_dw(r, h):
    """dW/dr of the cubic B-spline [F 5]."""
    q = r / h
    a_d = 15.0 / (7.0 * math.pi * h * h)
    if q < 1.0:
        return a_d * (-2.0 * q + 1.5 * q * q) / h
    if q < 2.0:
        t = 2.0 - q
        return -a_d * 0.5 * t * t / h
    return 0.0


@njit(cache=True)
def wendland_w(r, h):
    """Wendland C2 in 2D, support 2h: a_d (1 - q/2)^4 (2q + 1), a_d = 7/(4 pi h^2)."""
    q = r / h
    if q >= 2.0:
        return 0.0
    t = 1.0 - 0.5 * q
    return 7.0 / (4.0 * math.pi * h * h) * t * t * t * t * (2.0 * q + 1.0)


@njit(cache=True)
def wendland_dw(r, h):
    """dW/dr of the Wendland C2 kernel: a_d (-5 q)(1 - q/2)^3 / h."""
    q = r / h
    if q >= 2.0:
        return 0.0
    t = 1.0 - 0.5 * q
    return 7.0 / (4.0 * math.pi * h * h) * (-5.0 * q) * t * t * t / h


@njit(cache=True)
def kernel_w(kind, r, h):
    """W(r, h) of the kernel with id ``kind``."""
    if kind == WENDLAND_C2:
        return wendland_w(r, h)
    return cubic_w(r, h)


@njit(cache=True)
def kernel_dw(kind, r, h):
    """dW/dr(r, h) of the kernel with id ``kind``."""
    if kind == WENDLAND_C2:
        return wendland_dw(r, h)
    return cubic_dw(r, h)


@njit(cache=True, inline="always")
def pair_offset(xd, xs, nbr_j, i, k):
    """Entry ``k`` of row ``i`` of a CSR neighbour list: the source ``j = nbr_j[k]``, the
    offset ``x_i - x_j`` (destination points ``xd``, sources ``xs``) and its length ``r``
    (the kernel gradient convention: ``grad W_ij = dW/dr (x_i - x_j) / r``). The pair loops
    of every body share it."""
    j, d0, d1, _, r = pair_offset_sq(xd, xs, nbr_j, i, k)
    return j, d0, d1, r


@njit(cache=True, inline="always")
def pair_offset_sq(xd, xs, nbr_j, i, k):
    """:func:`pair_offset` with the squared length as well: ``(j, d0, d1, r^2, r)`` (the
    Morris terms divide by ``r^2 + eta^2``)."""
    j = nbr_j[k]
    d0 = xd[i, 0] - xs[j, 0]
    d1 = xd[i, 1] - xs[j, 1]
    r2 = d0 * d0 + d1 * d1
    return j, d0, d1, r2, math.sqrt(r2)
