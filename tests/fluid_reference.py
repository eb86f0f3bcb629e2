"""Slow dense numpy oracles (O(N^2), all pairs) for the fluid's numba loops."""

import numpy as np

from fsi_sph.sph.kernels import kernel_dw, kernel_w

KIND = 0  # cubic spline


def pairs(x, h, nrows):
    """(i, j, dx_ij, r_ij) for all i < nrows, j != i with r < 2h."""
    out = []
    for i in range(nrows):
        d = x[i] - x
        r = np.hypot(d[:, 0], d[:, 1])
        for j in np.flatnonzero((r < 2 * h) & (r > 0)):
            out.append((i, j, d[j], r[j]))
    return out


def grad_w(d, r, h):
    return kernel_dw(KIND, r, h) * d / r


def position_divergence(x, vol, h, nrows):
    divr = np.zeros(nrows)
    gc = np.zeros((nrows, 2))
    for i, j, d, r in pairs(x, h, nrows):
        divr[i] -= vol[j] * r * kernel_dw(KIND, r, h)
        gc[i] += vol[j] * grad_w(d, r, h)
    return divr, gc


def velocity_divergence(x, v, vol, h, nrows, scale):
    out = np.zeros(nrows)
    for i, j, d, r in pairs(x, h, nrows):
        out[i] += vol[j] * (v[j] - v[i]) @ grad_w(d, r, h)
    return scale * out


def conservative_gradient(x, p, vol, h, nrows, scale):
    out = np.zeros((nrows, 2))
    for i, j, d, r in pairs(x, h, nrows):
        out[i] += vol[j] * (p[i] + p[j]) * grad_w(d, r, h)
    return scale * out


def correction(x, vol, h, nrows):
    L = np.zeros((nrows, 2, 2))
    M = np.zeros((nrows, 2, 2))
    for i, j, d, r in pairs(x, h, nrows):
        M[i] += vol[j] * np.outer(-d, grad_w(d, r, h))
    for i in range(nrows):
        L[i] = np.eye(2) if abs(np.linalg.det(M[i])) < 0.05 else np.linalg.inv(M[i]).T
    return L


def corrected_gradient(x, p, vol, h, nrows):
    L = correction(x, vol, h, nrows)
    out = np.zeros((nrows, 2))
    for i, j, d, r in pairs(x, h, nrows):
        out[i] += vol[j] * (p[j] - p[i]) * L[i] @ grad_w(d, r, h)
    return out


def predict_velocity(x, v, vol, nu, h, nrows, eta2, g, dt):
    a = np.zeros((nrows, 2))
    for i, j, _, r in pairs(x, h, nrows):
        f = vol[j] * (nu[i] + nu[j]) * r * kernel_dw(KIND, r, h) / (r * r + eta2)
        a[i] += f * (v[i] - v[j])
    return v[:nrows] + dt * (a + g)


def ppe_dense(x, vol, alpha, source, consistent, nf, h, eta2, lap_scale, diag_ref, rho, g):
    """Dense PPE matrix and right-hand side, as documented in ``_kernels.ppe_fill``."""
    n = len(x)
    A = np.zeros((n, n))
    b = np.zeros(n)
    L = correction(x, vol, h, nf)
    nb = {i: [] for i in range(n)}
    for i, j, d, r in pairs(x, h, n):
        nb[i].append((j, d, r))
    for i in range(nf):
        fl = [(j, d, r) for j, d, r in nb[i]]
        if alpha[i] <= 0 or not fl:
            A[i, i] = diag_ref
            continue
        c = {j: -2 * lap_scale * vol[j] * r * kernel_dw(KIND, r, h) / (r * r + eta2)
             for j, d, r in fl}
        e = sum(c[j] * (-d) for j, d, r in fl) if consistent[i] else np.zeros(2)
        for j, d, r in fl:
            a = c[j] - vol[j] * e @ (L[i] @ grad_w(d, r, h))
            A[i, i] += a
            A[i, j] -= alpha[i] * a
        b[i] = alpha[i] * source[i]
    for w in range(nf, n):
        fl = [(j, d, r) for j, d, r in nb[w] if j < nf]
        A[w, w] = diag_ref
        sw = sum(kernel_w(KIND, r, h) for j, d, r in fl)
        for j, d, r in fl:
            wt = kernel_w(KIND, r, h) / sw
            A[w, j] -= diag_ref * wt
            b[w] += diag_ref * rho * (g @ d) * wt
    return A, b


def umbrella_scan(x, candidate, grad_c, h, nrows):
    """Marrone et al. (2010): the candidate rows whose umbrella region (a 90 deg cone along
    the outward normal -grad C / |grad C| up to sqrt(2) h, capped by the circle of radius h
    about x_i + h n) holds no other particle within 2 h; one row at a time, all pairs."""
    out = np.zeros(nrows, dtype=bool)
    for i in range(nrows):
        g = np.linalg.norm(grad_c[i])
        if not candidate[i] or g == 0.0:
            continue
        n = -grad_c[i] / g
        t = x[i] + h * n
        d = x - x[i]
        r = np.linalg.norm(d, axis=1)
        near = (r > 0.0) & (r < 2.0 * h)
        e = x - t
        cap = np.linalg.norm(e, axis=1) < h
        cone = np.abs(-n[1] * d[:, 0] + n[0] * d[:, 1]) + np.abs(e @ n) < h
        inside = np.where(r >= np.sqrt(2.0) * h, cap, cone)
        out[i] = not np.any(inside & near)
    return out
