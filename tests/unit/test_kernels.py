"""Smoothing kernels [F 5]: normalisation, moments, support, sign of dW/dr."""

import math

import numpy as np
import pytest

from fsi_sph.sph.kernels import KERNELS, SUPPORT, kernel_dw, kernel_w
from tests.reference_impl import cubic_dw, cubic_w


def _grid(h, n=401):
    s = np.linspace(-SUPPORT * h, SUPPORT * h, n)
    X, Y = np.meshgrid(s, s, indexing="ij")
    return X, Y, (s[1] - s[0]) ** 2


@pytest.mark.parametrize("name", sorted(KERNELS))
def test_normalised_and_moments(name):
    """int W = 1, int r W = 0, int r (x) grad W = -I (2D)."""
    kind = KERNELS[name]
    h = 0.7
    X, Y, dA = _grid(h)
    R = np.hypot(X, Y)
    W = np.vectorize(lambda r: kernel_w(kind, r, h))(R)
    dW = np.vectorize(lambda r: kernel_dw(kind, r, h))(R)
    Rs = np.where(R > 0, R, 1.0)
    gx, gy = dW * X / Rs, dW * Y / Rs
    assert abs(W.sum() * dA - 1.0) < 2e-4
    assert abs((X * W).sum() * dA) < 1e-10
    m = np.array([[(X * gx).sum(), (X * gy).sum()], [(Y * gx).sum(), (Y * gy).sum()]]) * dA
    np.testing.assert_allclose(m, -np.eye(2), atol=2e-3)


@pytest.mark.parametrize("name", sorted(KERNELS))
def test_compact_support_and_sign(name):
    kind = KERNELS[name]
    h = 1.3
    r = np.linspace(1e-6, 3 * h, 500)
    w = np.array([kernel_w(kind, ri, h) for ri in r])
    dw = np.array([kernel_dw(kind, ri, h) for ri in r])
    assert np.all(w[r >= SUPPORT * h] == 0.0) and np.all(dw[r >= SUPPORT * h] == 0.0)
    assert np.all(w[r < SUPPORT * h] > 0.0)
    assert np.all(dw[r < SUPPORT * h] < 0.0)
    # dW/dr is the derivative of W
    fd = np.gradient(w, r)
    inner = (r > 0.05 * h) & (r < 1.95 * h)
    np.testing.assert_allclose(dw[inner], fd[inner], rtol=1e-2, atol=1e-3 / h**3)


def test_cubic_matches_formula():
    """The numba cubic spline equals the formula of [F 5] (a_d = 15 / (7 pi h^2))."""
    h = 0.37
    r = np.linspace(0, 2.5 * h, 97)
    np.testing.assert_allclose([kernel_w(0, ri, h) for ri in r], cubic_w(r, h), rtol=1e-14)
    np.testing.assert_allclose([kernel_dw(0, ri, h) for ri in r], cubic_dw(r, h), rtol=1e-14,
                               atol=1e-14)
    assert math.isclose(kernel_w(0, 0.0, h), 15 / (7 * math.pi * h * h) * 2 / 3)
