"""Constants of a full, uniform square lattice of particles (the reference state the
operators are normalised on) and the kernel-support thresholds derived from it."""

from __future__ import annotations

import math

import numpy as np

from fsi_sph.sph.kernels import SUPPORT, kernel_dw, kernel_w

ETA = 0.1  # Morris regularisation eta = 0.1 h [F 11]
DIVR_FULL = 1.95  # div r below this: the kernel support is taken as truncated (full: ~2)


def lattice_offsets(dx, h):
    """Offsets ``(x_j - x_i)`` (m) of the neighbours of a particle of a full, uniform square
    lattice of spacing ``dx`` within the support ``2h`` (self excluded): 20 for h = 1.2 dx."""
    m = int(math.ceil(SUPPORT * h / dx)) + 1
    ix, iy = np.meshgrid(np.arange(-m, m + 1), np.arange(-m, m + 1), indexing="ij")
    d = np.column_stack([ix.ravel(), iy.ravel()]) * dx
    r = np.hypot(d[:, 0], d[:, 1])
    return d[(r > 0) & (r < SUPPORT * h)]


def lattice_scales(dx, h, kind):
    """Lattice constants of a full, uniform square lattice of spacing ``dx``.

    Returns ``(grad_scale, lap_scale, diag)``: ``1 / M_xx`` with the gradient moment
    ``M = sum_j V_j (x_j - x_i) (x) grad W_ij``; ``4 / sum_j c_ij r_ij^2`` for the Morris
    coefficients ``c_ij``; and the diagonal ``sum_j c_ij`` of an interior PPE row (with
    ``lap_scale`` applied).
    """
    d = lattice_offsets(dx, h)
    r = np.hypot(d[:, 0], d[:, 1])
    dw = np.array([kernel_dw(kind, ri, h) for ri in r])
    vol = dx * dx
    mxx = -np.sum(vol * d[:, 0] ** 2 * dw / r)
    c = -2.0 * vol * r * dw / (r * r + (ETA * h) ** 2)
    lap_scale = 4.0 / np.sum(c * r * r)
    return 1.0 / mxx, lap_scale, lap_scale * np.sum(c)


def lattice_sigma(dx, h, kind):
    """Kernel sum ``sum_j V_j W_ij`` (self included) on a full square lattice."""
    m = int(math.ceil(SUPPORT * h / dx)) + 1
    ix, iy = np.meshgrid(np.arange(-m, m + 1), np.arange(-m, m + 1), indexing="ij")
    r = np.hypot(ix.ravel(), iy.ravel()) * dx
    return float(sum(dx * dx * kernel_w(kind, ri, h) for ri in r))
