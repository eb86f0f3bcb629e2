"""Natural modes of a TLSPH elastic body and its compliance over one fluid step.

How a structure answers a force held over one fluid step (the sub-cycle) decides how well
the implicit rows of the pressure solve (docs/numerics/coupling.md) state its inertia; this
module measures it (docs/numerics/solid.md § Natural modes). Linearised about
a configuration ``x``, the body is ``M u'' + K u = f`` with ``M`` its lumped masses and
``K = -M d a_int / d x`` the stiffness of the TLSPH internal force [F 36-44] (taken here by
central differences of the internal acceleration). Its modes ``K phi_k = w_k^2 M phi_k``,
``phi_k^T M phi_k = 1``, answer a force ``f`` held over a step ``dt`` from rest with the mean
velocity ``(x(dt) - x(0)) / dt = sum_k phi_k (phi_k . f) dt s_k / 2``,
``s_k = sinc^2(w_k dt / 2) = (sin(w_k dt / 2) / (w_k dt / 2))^2`` (the undamped
single-degree response, integrated twice). A free particle (``w = 0``) has ``s = 1`` and the
mean velocity ``dt f / (2 m)``; a mode much stiffer than the step (``w dt >> 1``) does not
move on average. So the step's compliance ``C(dt) = sum_k s_k phi_k phi_k^T`` lies between
the per-particle ``M^-1`` of the implicit rows (every mode soft) and 0 (every mode stiff).
Not in PHYSICS.md
(linear structural dynamics); tested against the plate's 2D finite-element period and
``M^-1`` (tests/unit/test_modes.py). ``fsi-sph info`` prints each elastic body's lowest
natural frequencies.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg


def stiffness(body, x=None, step=1e-7):
    """``K = -M d a_int / d x`` over the body's free degrees of freedom, symmetrised (the
    TLSPH stress term derives from a strain energy; the hourglass term nearly so:
    tests/unit/test_modes.py). Returns ``(K, dofs)`` (:func:`difference_stiffness`)."""
    Kmat, dofs = difference_stiffness(body, x, step)
    return 0.5 * (Kmat + Kmat.T), dofs


def difference_stiffness(body, x=None, step=1e-7):
    """``K = -M d a_int / d x`` over the body's free degrees of freedom (2 per free particle,
    x then y), by central differences of the body's internal acceleration
    (:meth:`~fsi_sph.solid.tlsph.ElasticBody.internal_acceleration`) with a step of ``step``
    times the particle spacing. Returns ``(K, dofs)``, ``dofs`` the flattened
    indices ``2 i + d`` of the free degrees of freedom."""
    b = body.body
    x = np.array(b["x"] if x is None else x, dtype=np.float64)
    dofs = np.flatnonzero(np.repeat(b["free"], 2))
    eps = step * float(np.sqrt(b["vol"].mean()))
    m = np.repeat(b["m"], 2)[dofs]
    Kmat = np.empty((len(dofs), len(dofs)))
    flat = x.reshape(-1)
    for col, d in enumerate(dofs):
        flat[d] += eps
        up = body.internal_acceleration(x).reshape(-1)[dofs]
        flat[d] -= 2.0 * eps
        down = body.internal_acceleration(x).reshape(-1)[dofs]
        flat[d] += eps
        Kmat[:, col] = -m * (up - down) / (2.0 * eps)
    return Kmat, dofs


class Modes:
    """The natural modes of an elastic body about one configuration (default: its current
    one): ``omega`` (rad/s, ascending; 0 where ``K`` has no stiffness) and ``phi``
    (``2 n x k``, mass-normalised, zero on the clamped particles)."""

    def __init__(self, body, x=None):
        Kmat, dofs = stiffness(body, x)
        m = np.repeat(body.body["m"], 2)[dofs]
        w2, vec = scipy.linalg.eigh(Kmat, np.diag(m))
        self.omega = np.sqrt(np.maximum(w2, 0.0))
        self.phi = np.zeros((2 * body.body.n, len(dofs)))
        self.phi[dofs] = vec

    def weights(self, dt):
        """``s_k = sinc^2(w_k dt / 2)``: each mode's share of the free-particle response over
        a step ``dt`` (module docstring)."""
        return np.sinc(self.omega * dt / (2.0 * np.pi)) ** 2

    def compliance(self, dt):
        """``C(dt) = sum_k s_k phi_k phi_k^T`` (``2 n x 2 n``; ``M^-1`` on the free degrees
        of freedom as ``dt -> 0``)."""
        return (self.phi * self.weights(dt)) @ self.phi.T


def particles_through(x0, dx):
    """How many particles thick a body is: the median over its lattice sites of the shorter
    of the two lattice runs (along x, along y) through each. A flag or a plate gives its
    count through the thickness, a disc or a block its smaller side's. Bending is resolved
    poorly below 4 (the Turek-Hron flag: 32 % too stiff with 2, 4 % too soft with 4;
    docs/numerics/solid.md § Natural modes)."""
    if len(x0) == 0:
        return 0
    ij = np.unique(np.rint((x0 - x0.min(axis=0)) / dx).astype(np.int64), axis=0)
    along_x = _run_lengths(ij[:, 0], ij[:, 1])
    along_y = _run_lengths(ij[:, 1], ij[:, 0])
    return int(np.median(np.minimum(along_x, along_y)))


def _run_lengths(a, line):
    """For each site, the length of the run of consecutive ``a`` on its ``line``."""
    order = np.lexsort((a, line))
    a_s, l_s = a[order], line[order]
    starts = np.ones(len(a), dtype=bool)
    starts[1:] = (l_s[1:] != l_s[:-1]) | (a_s[1:] != a_s[:-1] + 1)
    run = np.cumsum(starts) - 1
    out = np.empty(len(a), dtype=np.int64)
    out[order] = np.bincount(run)[run]
    return out


MAX_MODAL_PARTICLES = 1500  # above: minutes of difference quotients and a dense eigensolve


def natural_frequencies(body, count=3):
    """The ``count`` lowest natural frequencies (Hz) of an elastic body in vacuum about its
    initial configuration, or None for a rigid body, one without a clamp (its lowest modes
    are rigid-body motions at 0 Hz) or one of more than ``MAX_MODAL_PARTICLES`` particles."""
    b = body.body
    if body.rigid or b["free"].all() or b.n > MAX_MODAL_PARTICLES:
        return None
    return Modes(body).omega[:count] / (2.0 * np.pi)
