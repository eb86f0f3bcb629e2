"""Krylov solvers for the fluid's linear systems, applied with an AMG preconditioner
(:mod:`fsi_sph.fluid.amg`): right-preconditioned BiCGStab and flexible GMRES, with numba
loops for the Gram-Schmidt projections, and the counts of their work."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from fsi_sph.fluid.amg import PARALLEL_ROWS


class Counts:
    """Work of one Krylov solve: preconditioner applications and products with ``A``
    (residual evaluations included); counts that do not depend on the machine's load."""

    def __init__(self):
        self.precond = 0
        self.matvecs = 0


def bicgstab(A, b, x0, precond, rtol, maxiter, counts=None):
    """Right-preconditioned BiCGStab (van der Vorst 1992) for ``A x = b``.

    ``A`` is a CSR operator (:func:`fsi_sph.fluid.amg.as_csr`), ``precond`` a callable
    ``z = M r``. Stops when the true relative residual ``||b - A x|| / ||b||`` is at most
    ``rtol`` (the recurrence residual is checked first and then confirmed), or after
    ``maxiter`` iterations. Returns
    ``(x, iterations, relative residual)``. Each iteration applies ``precond`` and ``A``
    twice; ``counts`` (a :class:`Counts`), if given, is incremented by what was done.
    """
    counts = Counts() if counts is None else counts
    A = _Counted(A, counts)
    precond = _CountedPrecond(precond, counts)
    bnorm = float(np.linalg.norm(b))
    x = np.array(x0, dtype=np.float64)
    r = np.empty_like(b)
    A.residual(x, b, r)
    rel = float(np.linalg.norm(r)) / bnorm
    if rel <= rtol:
        return x, 0, rel
    rhat = r.copy()
    p = r.copy()
    rho = float(rhat @ r)
    v = np.empty_like(b)
    t = np.empty_like(b)
    it = 0
    while it < maxiter:
        it += 1
        y = precond(p)
        A.matvec(y, v)
        alpha = rho / float(rhat @ v)
        s = r - alpha * v
        if float(np.linalg.norm(s)) / bnorm <= rtol:
            x += alpha * y
            A.residual(x, b, r)
            rel = float(np.linalg.norm(r)) / bnorm
            if rel <= rtol:
                return x, it, rel
            rhat = r.copy()  # recurrence drifted: restart from the true residual
            p = r.copy()
            rho = float(rhat @ r)
            continue
        z = precond(s)
        A.matvec(z, t)
        tt = float(t @ t)
        omega = float(t @ s) / tt if tt > 0.0 else 0.0
        x += alpha * y + omega * z
        r = s - omega * t
        rel = float(np.linalg.norm(r)) / bnorm
        if rel <= rtol:
            A.residual(x, b, r)
            rel = float(np.linalg.norm(r)) / bnorm
            if rel <= rtol:
                return x, it, rel
            rhat = r.copy()
            p = r.copy()
            rho = float(rhat @ r)
            continue
        rho_new = float(rhat @ r)
        if rho == 0.0 or omega == 0.0:
            break  # breakdown; the caller sees the residual
        beta = (rho_new / rho) * (alpha / omega)
        rho = rho_new
        p = r + beta * (p - omega * v)
    A.residual(x, b, r)
    return x, it, float(np.linalg.norm(r)) / bnorm


class _Counted:
    """A CSR operator (:func:`fsi_sph.fluid.amg.as_csr`) whose products are counted."""

    def __init__(self, A, counts):
        self._A = A
        self._counts = counts
        self.shape = A.shape

    def matvec(self, x, out=None):
        self._counts.matvecs += 1
        return self._A.matvec(x, out)

    def residual(self, x, b, out):
        self._counts.matvecs += 1
        return self._A.residual(x, b, out)


class _CountedPrecond:
    def __init__(self, precond, counts):
        self._precond = precond
        self._counts = counts

    def __call__(self, r):
        self._counts.precond += 1
        return self._precond(r)


# Dot products of the Gram-Schmidt step: the vector is cut into a fixed number of chunks
# whose partial sums are added in chunk order, so the result does not depend on the number
# of threads (a prange reduction's would); the chunks are processed in parallel.
_CHUNKS = 64


@njit(cache=True)
def _chunk(n, c):
    return c * n // _CHUNKS, (c + 1) * n // _CHUNKS


@njit(cache=True)
def _project_chunk(V, k, w, h, lo, hi, part):
    """On ``w[lo:hi]``: the partial sums of ``V[i] . w`` (``part[i]``, ``i < k``) and of
    ``w . w`` (``part[k]``); when ``h`` is not empty, first ``w -= V[:k].T h`` and then only
    ``w . w`` (``part[:k]`` stay 0)."""
    for i in range(k + 1):
        part[i] = 0.0
    if h.shape[0] > 0:
        for t in range(lo, hi):
            wt = w[t]
            for i in range(k):
                wt -= V[i, t] * h[i]
            w[t] = wt
            part[k] += wt * wt
    else:
        for t in range(lo, hi):
            wt = w[t]
            for i in range(k):
                part[i] += V[i, t] * wt
            part[k] += wt * wt


@njit(cache=True)
def _sum_parts(parts, k, out):
    """``out[i] = sum_c parts[c, i]`` in a fixed order (deterministic for any thread
    count)."""
    for i in range(k + 1):
        s = 0.0
        for c in range(_CHUNKS):
            s += parts[c, i]
        out[i] = s


@njit(cache=True, parallel=True)
def _project_par(V, k, w, h, out):
    n = w.shape[0]
    parts = np.empty((_CHUNKS, k + 1))
    for c in prange(_CHUNKS):
        lo, hi = _chunk(n, c)
        _project_chunk(V, k, w, h, lo, hi, parts[c])
    _sum_parts(parts, k, out)


@njit(cache=True)
def _project_ser(V, k, w, h, out):
    n = w.shape[0]
    parts = np.empty((_CHUNKS, k + 1))
    for c in range(_CHUNKS):
        lo, hi = _chunk(n, c)
        _project_chunk(V, k, w, h, lo, hi, parts[c])
    _sum_parts(parts, k, out)


@njit(cache=True, parallel=True)
def _combine_par(Z, y, k, x):
    """``x += Z[:k].T y``."""
    for t in prange(x.shape[0]):
        s = x[t]
        for i in range(k):
            s += Z[i, t] * y[i]
        x[t] = s


@njit(cache=True)
def _combine_ser(Z, y, k, x):
    for t in range(x.shape[0]):
        s = x[t]
        for i in range(k):
            s += Z[i, t] * y[i]
        x[t] = s


_NO_H = np.empty(0)


def _project(V, k, w, h=None):
    """``(V[:k] w, w . w)`` in one pass; with ``h``: ``w -= V[:k].T h``, then ``w . w``
    (returned as ``(None, w . w)``), also one pass."""
    out = np.empty(k + 1)
    f = _project_par if w.shape[0] >= PARALLEL_ROWS else _project_ser
    f(V, k, w, _NO_H if h is None else h, out)
    return (out[:k] if h is None else None), float(out[k])


def fgmres(A, b, x0, precond, rtol, maxiter, restart=20, counts=None):
    """Right-preconditioned flexible GMRES(``restart``) (Saad 1993) for ``A x = b``.

    One application of ``precond`` and one product with ``A`` per iteration (BiCGStab needs
    two of each). The preconditioned vectors ``z_j = M v_j`` are kept, so the update
    ``x += Z y`` needs no further application (and a preconditioner that is not exactly
    linear would do). Classical Gram-Schmidt (two passes over the basis: the dot products,
    then the subtraction with the new norm), repeated once when the subtraction leaves less
    than 1e-3 of the vector's norm (a cancellation of 1e3 costs about 1e-13 of
    orthogonality; with a good preconditioner ``A M v_j`` is close to ``v_j``, so a
    cancellation of ~10 is the rule and harmless); the dot products are fixed-order
    chunked sums, so the result does not depend on the thread count. The Givens-rotation
    residual estimate ends a cycle; the solve stops only when the true relative residual
    ``||b - A x|| / ||b||`` is at most ``rtol`` (otherwise it restarts from it), or after
    ``maxiter`` iterations. Returns ``(x, iterations, relative residual)``; ``counts`` as
    in :func:`bicgstab`.
    """
    counts = Counts() if counts is None else counts
    n = b.shape[0]
    m = max(1, min(restart, maxiter))
    bnorm = float(np.linalg.norm(b))
    x = np.array(x0, dtype=np.float64)
    r = np.empty(n)
    A.residual(x, b, r)
    counts.matvecs += 1
    V0 = r[None, :]
    beta = float(np.sqrt(_project(V0, 0, r)[1]))
    rel = beta / bnorm
    if rel <= rtol:
        return x, 0, rel
    V = np.empty((m + 1, n))
    Z = np.empty((m, n))
    H = np.zeros((m + 1, m))
    cs = np.zeros(m)
    sn = np.zeros(m)
    g = np.zeros(m + 1)
    it = 0
    while it < maxiter and beta > 0.0:
        np.divide(r, beta, out=V[0])
        g[:] = 0.0
        g[0] = beta
        k = 0  # columns of this cycle
        for j in range(m):
            it += 1
            counts.precond += 1
            Z[j] = precond(V[j])
            w = V[j + 1]
            A.matvec(Z[j], w)
            counts.matvecs += 1
            h, ww0 = _project(V, j + 1, w)
            _, ww = _project(V, j + 1, w, h)
            if ww < 1e-6 * ww0:  # cancellation: orthogonalise once more
                h2, _ = _project(V, j + 1, w)
                _, ww = _project(V, j + 1, w, h2)
                h = h + h2
            hn = float(np.sqrt(ww))
            col = np.empty(j + 2)
            col[:j + 1] = h
            col[j + 1] = hn
            for i in range(j):  # previous rotations
                t = cs[i] * col[i] + sn[i] * col[i + 1]
                col[i + 1] = -sn[i] * col[i] + cs[i] * col[i + 1]
                col[i] = t
            d = float(np.hypot(col[j], col[j + 1]))
            cs[j] = col[j] / d if d > 0.0 else 1.0
            sn[j] = col[j + 1] / d if d > 0.0 else 0.0
            col[j] = d
            H[:j + 1, j] = col[:j + 1]
            g[j + 1] = -sn[j] * g[j]
            g[j] = cs[j] * g[j]
            k = j + 1
            if hn > 0.0:
                w /= hn
            if abs(g[j + 1]) <= rtol * bnorm or hn == 0.0 or it >= maxiter:
                break
        # y from the k x k triangular system, then x += Z y
        y = np.zeros(k)
        for i in range(k - 1, -1, -1):
            y[i] = (g[i] - H[i, i + 1:k] @ y[i + 1:k]) / H[i, i] if H[i, i] != 0.0 else 0.0
        _combine(Z, y, k, x)
        A.residual(x, b, r)  # the true residual decides
        counts.matvecs += 1
        beta = float(np.sqrt(_project(V0, 0, r)[1]))
        rel = beta / bnorm
        if rel <= rtol:
            break
    return x, it, rel


def _combine(Z, y, k, x):
    """``x += Z[:k].T y``."""
    f = _combine_par if x.shape[0] >= PARALLEL_ROWS else _combine_ser
    f(Z, np.ascontiguousarray(y, dtype=np.float64), k, x)


def warm_up():
    """Compile the loops on a tiny system."""
    x = np.zeros(2)
    out = np.empty(2)
    V = np.ones((2, 2))
    for f in (_project_par, _project_ser):
        f(V, 1, x, _NO_H, out)
        f(V, 1, x, np.ones(1), out)
    _combine_par(V, np.ones(1), 1, x)
    _combine_ser(V, np.ones(1), 1, x)
