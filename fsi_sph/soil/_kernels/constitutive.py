"""Drucker-Prager constitutive loops of the soil (conventions in :mod:`fsi_sph.soil._kernels`):
the plane-strain Mohr-Coulomb fit [S 4-40, 4-41], invariants, the return mapping and the
stress-rate update, and the principal stresses."""

import math

import numpy as np
from numba import njit


# ----------------------------------------------------------------------------- scalars
@njit(cache=True)
def dp_parameters(phi, c, psi):
    """Drucker-Prager cone matched to Mohr-Coulomb (``phi``, ``c``) in plane strain *at
    plastic flow with the dilatancy ``psi`` of the flow rule*. Angles in radians. Returns
    ``(alpha_phi, k_c, alpha_psi)`` of ``f = alpha_phi I1 + sqrt(J2) - k_c``,
    ``g = alpha_psi I1 + sqrt(J2)``.

    * ``alpha_psi = tan(psi)/sqrt(9 + 12 tan^2 psi)`` [S 4-40 with psi]: with it the in-plane
      plastic strain rate dilates at exactly ``psi``, ``sin(psi) = 3 alpha_psi/q``,
      ``q = sqrt(1 - 3 alpha_psi^2)``.
    * Plane strain, ``eps_zz^p = 0``, puts the out-of-plane deviator at
      ``s_zz = -2 alpha_psi sqrt(J2)``. With the in-plane Mohr circle (centre ``p``, radius
      ``R``, tension positive) that gives ``sqrt(J2) = R/q`` and
      ``I1 = 3 p - 3 alpha_psi R/q``, so ``f = 0`` is the Mohr-Coulomb line
      ``R = -p sin(phi) + c cos(phi)`` when
      ``alpha_phi = sin(phi)/(3 (q + alpha_psi sin(phi)))``,
      ``k_c = c cos(phi) (1 - 3 alpha_phi alpha_psi)/q``.
    * For associated flow (``psi = phi``) this is [S 4-40, 4-41],
      ``alpha_phi = tan(phi)/sqrt(9 + 12 tan^2 phi)``, ``k_c = 3 c/sqrt(9 + 12 tan^2 phi)``;
      [S] derives that fit for associated flow. With ``psi = 0`` it is
      ``alpha_phi = sin(phi)/3``, ``k_c = c cos(phi)``. Used with ``psi < phi``, the fit
      [S 4-40] makes the soil weaker than Mohr-Coulomb at flow, in-plane
      ``sin(phi_eff) = 3 alpha_phi`` for ``psi = 0``: 19.4 deg for phi = 19.8 deg, but 45 deg
      for phi = 50.8 deg, the friction that a 45 deg cohesionless slope needs under strength
      reduction (tests/unit/test_soil_dp_fit.py, validation/README_soil.md).
    """
    tp = math.tan(psi)
    a_psi = tp / math.sqrt(9.0 + 12.0 * tp * tp)
    q = math.sqrt(1.0 - 3.0 * a_psi * a_psi)
    sp = math.sin(phi)
    alpha = sp / (3.0 * (q + a_psi * sp))
    kc = c * math.cos(phi) * (1.0 - 3.0 * alpha * a_psi) / q
    return alpha, kc, a_psi


@njit(cache=True)
def invariants(sxx, syy, sxy, szz):
    """``(I1, sqrt(J2))`` of the plane-strain stress (``J2 = s:s/2``, ``s_xy`` counted twice)."""
    i1 = sxx + syy + szz
    m = i1 / 3.0
    dxx = sxx - m
    dyy = syy - m
    dzz = szz - m
    j2 = 0.5 * (dxx * dxx + dyy * dyy + dzz * dzz) + sxy * sxy
    return i1, math.sqrt(max(j2, 0.0))


@njit(cache=True)
def return_map(sxx, syy, sxy, szz, alpha, kc, alpha_psi, G, K):
    """Return a trial stress to the Drucker-Prager cone ``f = alpha I1 + sqrt(J2) - k_c``
    [S 4-36 to 4-41]; non-associated flow with ``g = alpha_psi I1 + sqrt(J2)``.

    1. Tension apex (tension cracking, Bui et al. 2008): if the hydrostatic stress lies
       beyond the apex, ``I1 > k_c/alpha``, it is moved back to the apex,
       ``sigma_ii -= (I1 - k_c/alpha)/3``, and the deviator is scaled by
       ``(k_c - alpha I1)/sqrt(J2) = 0``: the stress is the apex, whatever ``psi``.
    2. If ``f > 0``: closed-form radial return of the elastic predictor
       ``dlam = f/(G + 9 K alpha alpha_psi)``, ``s <- s (1 - G dlam/sqrt(J2))``,
       ``I1 <- I1 - 9 K alpha_psi dlam``. For ``psi = 0`` this is exactly the deviatoric
       scaling ``s <- s (k_c - alpha I1)/sqrt(J2)`` of [S]. If the return would overshoot
       the cone axis (``G dlam > sqrt(J2)``) the stress goes to the apex,
       ``s = 0``, ``I1 = k_c/alpha``.

    Returns ``(sxx, syy, sxy, szz, d_eps_p)`` with ``d_eps_p`` the equivalent deviatoric
    plastic strain increment ``sqrt(2/3 de_p:de_p)``, ``de_p = (s_trial - s_new)/(2G)``.
    """
    i1, sj2 = invariants(sxx, syy, sxy, szz)
    m = i1 / 3.0
    dxx = sxx - m
    dyy = syy - m
    dzz = szz - m
    dxy = sxy
    # --- 1. tension apex
    clipped = False
    if alpha > 0.0:
        apex = kc / alpha
        if i1 > apex:
            i1 = apex
            clipped = True
    else:  # von Mises / Tresca-like limit: no apex
        apex = math.inf
    f = alpha * i1 + sj2 - kc
    if f <= 0.0 and not clipped:  # elastic: untouched
        return sxx, syy, sxy, szz, 0.0
    scale = 1.0
    if clipped:
        # tension cracking (PHYSICS §6, Bui et al. 2008): at the apex the deviator is scaled
        # by (k_c - alpha I1)/sqrt(J2) = 0. The dilatant return below must not be applied
        # after the clip: with psi > 0 it would add the compression -9 K alpha_psi dlam to a
        # particle being pulled apart (a stress that pushes it further apart, which blew up
        # an associated-flow column collapse); for psi = 0 both give the apex.
        scale = 0.0
    elif f > 0.0:
        dlam = f / (G + 9.0 * K * alpha * alpha_psi)
        if G * dlam >= sj2 or sj2 == 0.0:  # return lands beyond the axis -> apex
            scale = 0.0
            i1 = apex if alpha > 0.0 else i1
        else:
            scale = 1.0 - G * dlam / sj2
            i1 = i1 - 9.0 * K * alpha_psi * dlam
    m = i1 / 3.0
    # deviatoric plastic strain increment (s_trial - s_new)/(2G)
    fac = (1.0 - scale) / (2.0 * G)
    ep = fac * math.sqrt(dxx * dxx + dyy * dyy + dzz * dzz + 2.0 * dxy * dxy)
    d_eps_p = math.sqrt(2.0 / 3.0) * ep
    return (m + scale * dxx, m + scale * dyy, scale * dxy, m + scale * dzz, d_eps_p)


@njit(cache=True)
def stress_update(n, L, sigma, szz, eps_p, dt, G, K, alpha, kc, alpha_psi):
    """Jaumann stress rate [S 4-42 to 4-57] and return mapping, rows ``i < n``.

    ``eps_dot = (L + L^T)/2`` (``eps_zz = 0``), ``omega = (L - L^T)/2``;
    elastic trial ``sigma += dt (2 G e_dot + K tr(eps_dot) I + omega sigma - sigma omega)``
    (``e_dot`` deviatoric, 3-D), e.g. [S 4-49] ``sigma_xx += dt (... + 2 omega_xy sigma_xy)``;
    then :func:`return_map`; ``eps_p`` accumulates the equivalent plastic strain.
    """
    for i in range(n):
        exx = L[i, 0, 0]
        eyy = L[i, 1, 1]
        exy = 0.5 * (L[i, 0, 1] + L[i, 1, 0])
        wxy = 0.5 * (L[i, 0, 1] - L[i, 1, 0])
        tr = exx + eyy
        sxx = sigma[i, 0, 0]
        syy = sigma[i, 1, 1]
        sxy = sigma[i, 0, 1]
        tx = sxx + dt * (2.0 * G * (exx - tr / 3.0) + K * tr + 2.0 * wxy * sxy)
        ty = syy + dt * (2.0 * G * (eyy - tr / 3.0) + K * tr - 2.0 * wxy * sxy)
        txy = sxy + dt * (2.0 * G * exy + wxy * (syy - sxx))
        tz = szz[i] + dt * (2.0 * G * (-tr / 3.0) + K * tr)
        nx, ny, nxy, nz, dep = return_map(tx, ty, txy, tz, alpha, kc, alpha_psi, G, K)
        sigma[i, 0, 0] = nx
        sigma[i, 1, 1] = ny
        sigma[i, 0, 1] = nxy
        sigma[i, 1, 0] = nxy
        szz[i] = nz
        eps_p[i] += dep


def principal_in_plane(sigma):
    """In-plane principal stresses (numpy, output only): ``(s1 >= s2)``."""
    c = 0.5 * (sigma[:, 0, 0] + sigma[:, 1, 1])
    r = np.sqrt(0.25 * (sigma[:, 0, 0] - sigma[:, 1, 1]) ** 2 + sigma[:, 0, 1] ** 2)
    return c + r, c - r
