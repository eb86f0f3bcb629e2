"""Viscosity laws of a fluid material (PHYSICS.md §2 and §7).

* ``newtonian``: constant kinematic viscosity ``nu``.
* ``smagorinsky``: ``nu + (C_s dx)^2 sqrt(2 S:S)`` [F 3].
* ``mu_i``: the pressure-dependent viscoplastic mu(I) law of dense granular flow [G 31-35],
  with the ISPH pressure as the confining pressure ``p`` (negative pressures count as 0).

All functions are vectorised numpy (O(N), a small cost beside the PPE). The apparent
viscosity ``eta`` is dynamic (Pa s); the solver works with ``nu = eta / rho`` where ``rho``
is the bulk density of the material (``rho0``; ``phi rho_s`` for a granular material),
while the inertial number uses the grain density ``rho_s`` [G 32].
"""

from __future__ import annotations

import math

import numpy as np


def strain_rate(grad_v):
    """``|gammadot| = sqrt(2 S:S)`` with ``S = (grad v + grad v^T) / 2`` (PHYSICS.md §7);
    ``grad_v[i, k, l] = d v_k / d x_l``. Simple shear ``u = k y`` gives ``|k|``."""
    s00 = grad_v[:, 0, 0]
    s11 = grad_v[:, 1, 1]
    s01 = 0.5 * (grad_v[:, 0, 1] + grad_v[:, 1, 0])
    return np.sqrt(2.0 * (s00 * s00 + s11 * s11 + 2.0 * s01 * s01))


def friction(inertial, mu_s, mu_2, i0):
    """Friction coefficient ``mu(I) = mu_s + (mu_2 - mu_s) / (1 + I0 / I)`` [G 31] (the
    Jop et al. form; 0 at I = 0 is the limit mu_s)."""
    inertial = np.asarray(inertial, dtype=np.float64)
    with np.errstate(divide="ignore"):
        return mu_s + (mu_2 - mu_s) * inertial / (inertial + i0)


def inertial_number(gdot, p, d, rho_s):
    """Inertial number ``I = |gammadot| d / sqrt(p / rho_s)`` [G 32] (inf where p <= 0)."""
    p = np.maximum(np.asarray(p, dtype=np.float64), 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(p > 0.0, np.asarray(gdot) * d / np.sqrt(p / rho_s), np.inf)


def apparent_viscosity(gdot, p, mu_s, mu_2, i0, d, rho_s, eta_max, alpha_r=0.01):
    """Regularised apparent viscosity of the mu(I) law (Pa s) [G 33-35]::

        eta = mu_s p (1 - exp(-|gammadot| / alpha_r)) / |gammadot|
              + (mu_2 - mu_s) p / (xi sqrt(p) + |gammadot| + alpha_r),
        xi = I0 / (d sqrt(rho_s)),

    capped at ``eta_max``. Unregularised (``alpha_r -> 0``) it is ``mu(I) p / |gammadot|``
    with ``mu(I)`` of [G 31] and ``I`` of [G 32]; at ``|gammadot| = 0`` the first term
    is its limit ``mu_s p / alpha_r``. ``p`` below 0 (tension) counts as 0.
    """
    gdot = np.asarray(gdot, dtype=np.float64)
    p = np.maximum(np.asarray(p, dtype=np.float64), 0.0)
    xi = i0 / (d * math.sqrt(rho_s))  # [G 35]
    # (1 - exp(-g/a)) / g, written with expm1 so that it is exact near g = 0 -> 1/a
    small = gdot < 1e-12 * alpha_r
    with np.errstate(divide="ignore", invalid="ignore"):
        f1 = np.where(small, 1.0 / alpha_r, -np.expm1(-gdot / alpha_r) / gdot)
    eta = mu_s * p * f1 + (mu_2 - mu_s) * p / (xi * np.sqrt(p) + gdot + alpha_r)  # [G 35]
    return np.minimum(eta, eta_max)


def i0_from_beta(beta, l_over_d, phi, theta):
    """``I0 = (5/2) beta / ((L/d) sqrt(phi cos theta))`` [G 41] (theta in radians)."""
    return 2.5 * beta / (l_over_d * math.sqrt(phi * math.cos(theta)))


def bagnold_inertial_number(theta, mu_s, mu_2, i0):
    """Uniform inertial number of steady flow down a slope: ``tan theta = mu(I)`` [G 31]
    solved for ``I = I0 (tan theta - mu_s) / (mu_2 - tan theta)`` (PHYSICS.md §7); needs
    ``mu_s < tan theta < mu_2``."""
    t = math.tan(theta)
    if not mu_s < t < mu_2:
        raise ValueError(f"tan(theta) = {t:.4f} outside (mu_s, mu_2) = ({mu_s}, {mu_2}): "
                         "no steady flow")
    return i0 * (t - mu_s) / (mu_2 - t)


def bagnold_profile(y, depth, theta, d, phi, inertial, g):
    """Bagnold velocity profile [G 36-37] of a layer of thickness ``depth`` on a no-slip bed
    at ``y = 0``::

        U(y) / sqrt(g d) = (2/3) I sqrt(phi cos theta) (H^{3/2} - (H - y)^{3/2}) / d^{3/2}
    """
    y = np.clip(np.asarray(y, dtype=np.float64), 0.0, depth)
    return (math.sqrt(g * d) * (2.0 / 3.0) * inertial * math.sqrt(phi * math.cos(theta))
            * (depth ** 1.5 - (depth - y) ** 1.5) / d ** 1.5)


class ViscosityLaw:
    """The viscosity law of a ``FluidSection``: fills the fluid's kinematic viscosity ``nu``
    from the velocity gradient and the pressure (:meth:`update`)."""

    def __init__(self, fluid_cfg, dx, gravity=(0.0, 0.0)):
        mat = fluid_cfg.material
        self.kind = mat.viscosity
        self.rho = mat.rho0
        self.nu0 = mat.nu
        self.params = mat.mu_i
        cs = fluid_cfg.smagorinsky.cs if fluid_cfg.smagorinsky is not None else 0.12
        self.cs_dx2 = (cs * dx) ** 2
        self.smagorinsky = self.kind == "smagorinsky" or fluid_cfg.smagorinsky is not None
        # Confining pressure of the mu(I) law. The PPE puts p = 0 at the centres of the
        # free-surface particles, half a spacing below the real surface
        # (docs/numerics/granular.md, "Pressure offset"), so
        # the ISPH pressure is short of the hydrostatic one by rho |g| dx / 2 everywhere
        # under a free surface. For a pressure-proportional friction this matters near the
        # surface: two rows down the pressure is half the real one, the friction needed
        # to hold the rows above exceeds mu_2 and the surface layer runs away. With
        # pressure_offset = "half_spacing" the law sees p + rho |g_y| dx / 2: the head of
        # half a spacing under a free surface normal to y of the case frame (exact for the
        # inclined layer with tilted gravity; for a surface inclined by beta in the frame the
        # head is short by the factor cos beta, a second-order part of a small correction).
        # The inertial number is sensitive to it: near mu_s, dI/I ~ 9 dp/p (Bagnold case).
        self.p_offset = 0.0
        if self.params is not None and self.params.pressure_offset == "half_spacing":
            self.p_offset = 0.5 * self.rho * abs(float(gravity[1])) * dx

    @property
    def needs_gradients(self):
        return self.kind == "mu_i" or self.smagorinsky

    def update(self, grad_v, p, out_nu):
        """Kinematic viscosity of every fluid particle into ``out_nu``."""
        if self.kind == "mu_i":
            self.gdot = strain_rate(grad_v)
            out_nu[:] = self.mu_i_nu(self.gdot, p)
        elif self.smagorinsky:
            out_nu[:] = self.nu0 + self.cs_dx2 * strain_rate(grad_v)  # [F 3]
        else:
            out_nu[:] = self.nu0

    def mu_i_nu(self, gdot, p):
        """Kinematic viscosity ``eta / rho`` of the mu(I) law [G 35] at strain rate ``gdot``
        and ISPH pressure ``p`` (plus the surface offset)."""
        q = self.params
        return apparent_viscosity(gdot, p + self.p_offset, q.mu_s, q.mu_2, q.I0, q.d,
                                  q.rho_s, q.eta_max, q.alpha_r) / self.rho
