"""Numba kernels of the Drucker-Prager soil (updated-Lagrangian SPH, PHYSICS.md §6).

Conventions
-----------
* Stress is **tension positive** (as in [S] and Bui et al. 2008): a soil at rest under
  gravity has negative ``sigma``. Plane strain: the in-plane stress ``sigma`` is ``(n, 2, 2)``
  (symmetric) and the out-of-plane normal stress ``szz`` is ``(n,)``; ``eps_zz = 0``.
* Particle loops are gather-only: iteration ``i`` (a soil particle, ``i < n``) writes row
  ``i`` only. Neighbours ``j`` index the *combined* arrays ``[soil; wall ghosts]`` of length
  ``n + n_ghost``; rows ``>= n`` are mirror ghosts filled by :func:`fill_ghosts`.
* ``grad_i W_ij = dW/dr (x_i - x_j) / r``.
"""

import math

import numpy as np
from numba import njit

from fsi_sph.sph.kernels import kernel_dw, kernel_w

DET_MIN = 1e-3  # correction matrix with |det| below this (full support ~ 1) -> identity

# wall sides and friction laws (integer codes shared with drucker_prager.py)
BOTTOM = 0
LEFT = 1
RIGHT = 2
TOP = 3
FREE_SLIP = 0
NO_SLIP = 1
COULOMB = 2


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


# ----------------------------------------------------------------------------- walls
@njit(cache=True)
def _wall_distance(side, pos, x0, x1):
    """Signed distance of a point into the soil side of a wall (>= 0 inside)."""
    if side == BOTTOM:
        return x1 - pos
    if side == LEFT:
        return x0 - pos
    if side == RIGHT:
        return pos - x0
    return pos - x1  # TOP


@njit(cache=True)
def _mirror_point(side, pos, x0, x1):
    if side == BOTTOM or side == TOP:
        return x0, 2.0 * pos - x1
    return 2.0 * pos - x0, x1


@njit(cache=True)
def make_ghosts(x, n, wall_side, wall_pos, radius, out_x, out_src, out_wa, out_wb):
    """Mirror ghosts of the soil particles that lie within ``radius`` of a plane wall.

    For every particle ``i < n`` and wall ``a`` with ``0 <= d_a < radius`` one ghost is the
    mirror image of ``i`` in wall ``a``; for two walls ``a < b`` both within reach (a corner)
    a further ghost is mirrored in both. Ghost ``g`` is written to row ``n + g`` of
    ``out_x`` with source ``out_src[g]`` and walls ``out_wa[g]``, ``out_wb[g]`` (-1: none).
    Serial (it appends). Returns the number of ghosts.
    """
    ng = 0
    nw = wall_side.shape[0]
    cap = out_src.shape[0]
    for i in range(n):
        for a in range(nw):
            da = _wall_distance(wall_side[a], wall_pos[a], x[i, 0], x[i, 1])
            if da < 0.0 or da >= radius:
                continue
            if ng < cap:
                g0, g1 = _mirror_point(wall_side[a], wall_pos[a], x[i, 0], x[i, 1])
                out_x[n + ng, 0] = g0
                out_x[n + ng, 1] = g1
                out_src[ng] = i
                out_wa[ng] = a
                out_wb[ng] = -1
            ng += 1
            for b in range(a + 1, nw):
                if (wall_side[a] == BOTTOM or wall_side[a] == TOP) == (
                        wall_side[b] == BOTTOM or wall_side[b] == TOP):
                    continue  # parallel walls: no corner
                db = _wall_distance(wall_side[b], wall_pos[b], x[i, 0], x[i, 1])
                if db < 0.0 or db >= radius:
                    continue
                if ng < cap:
                    g0, g1 = _mirror_point(wall_side[a], wall_pos[a], x[i, 0], x[i, 1])
                    g0, g1 = _mirror_point(wall_side[b], wall_pos[b], g0, g1)
                    out_x[n + ng, 0] = g0
                    out_x[n + ng, 1] = g1
                    out_src[ng] = i
                    out_wa[ng] = a
                    out_wb[ng] = b
                ng += 1
    return ng


@njit(cache=True)
def _mirror_state(side, fric, mu_w, v0, v1, sxx, syy, sxy):
    """Velocity and stress of a mirror ghost across one wall.

    Normal velocity is reversed (no penetration). Tangential velocity is kept for free-slip
    and Coulomb walls and reversed (zero at the wall) for no-slip walls. The ghost's shear
    stress is ``2 tau_w - sigma_nt`` so that the pair sum carries the wall traction ``tau_w``:
    ``tau_w = 0`` (free slip, Coulomb) or ``sigma_nt`` (no-slip). A Coulomb wall's friction is
    applied from its contact force by :func:`coulomb_friction` (``mu_w`` unused here): the
    soil's own stress cannot carry it in a layer only a particle or two thick, whose stress
    the truncated SPH support leaves near zero.
    """
    if side == BOTTOM or side == TOP:
        vn = -v1
        vt = -v0 if fric == NO_SLIP else v0
    else:
        vn = -v0
        vt = -v1 if fric == NO_SLIP else v1
    tau = sxy if fric == NO_SLIP else 0.0
    s_nt = 2.0 * tau - sxy
    if side == BOTTOM or side == TOP:
        return vt, vn, s_nt
    return vn, vt, s_nt


@njit(cache=True)
def fill_ghosts(n, ng, src, wa, wb, wall_side, wall_fric, wall_mu, g0, g1, x, v, sigma, szz,
                rho, m, vk):
    """Copy the state of each ghost's source into rows ``n .. n+ng`` of the combined arrays
    ``v, sigma, szz, rho, m`` and mirror velocity and stress across its wall(s).

    ``vk`` receives the ghost's kinematic velocity, the velocity of the mirror image itself
    (normal component reversed, tangential kept, whatever the wall's friction): the
    continuity uses it (see :func:`velocity_gradient`).

    The wall-normal stress is extrapolated with the body force, as Adami et al. (2012) do for
    the wall pressure: ``sigma_nn,ghost = sigma_nn,i - rho_i g . (x_ghost - x_i)`` (from
    ``d sigma_nn/dn + rho g_n = 0``), so that a soil at rest on a floor feels the full support
    of the wall instead of a zero stress gradient at it.
    """
    for g in range(ng):
        i = src[g]
        row = n + g
        v0 = v[i, 0]
        v1 = v[i, 1]
        sxx = sigma[i, 0, 0]
        syy = sigma[i, 1, 1]
        sxy = sigma[i, 0, 1]
        a = wa[g]
        v0, v1, sxy = _mirror_state(wall_side[a], wall_fric[a], wall_mu[a], v0, v1, sxx, syy, sxy)
        b = wb[g]
        if b >= 0:
            v0, v1, sxy = _mirror_state(wall_side[b], wall_fric[b], wall_mu[b], v0, v1, sxx,
                                        syy, sxy)
        # body-force extrapolation of the normal stress of each wall crossed
        dgx = -rho[i] * g0 * (x[row, 0] - x[i, 0])
        dgy = -rho[i] * g1 * (x[row, 1] - x[i, 1])
        for w in (a, b):
            if w < 0:
                continue
            if wall_side[w] == BOTTOM or wall_side[w] == TOP:
                syy += dgy
            else:
                sxx += dgx
        v[row, 0] = v0
        v[row, 1] = v1
        k0, k1 = v[i, 0], v[i, 1]
        for w in (a, b):
            if w < 0:
                continue
            if wall_side[w] == BOTTOM or wall_side[w] == TOP:
                k1 = -k1
            else:
                k0 = -k0
        vk[row, 0] = k0
        vk[row, 1] = k1
        sigma[row, 0, 0] = sxx
        sigma[row, 1, 1] = syy
        sigma[row, 0, 1] = sxy
        sigma[row, 1, 0] = sxy
        szz[row] = szz[i]
        rho[row] = rho[i]
        m[row] = m[i]


@njit(cache=True)
def coulomb_friction(n, v, aw, wall_side, wall_fric, wall_mu, dt):
    """Coulomb friction of the walls with ``friction = coulomb`` (tan delta = ``wall_mu``):
    with ``a_n = aw[i, w] . n_w > 0`` the contact acceleration pushing particle ``i`` off
    wall ``w``, the tangential velocity is reduced by ``min(tan(delta) a_n dt, |v_t|)``
    (kinetic friction, which may stop but never reverse the sliding)."""
    for i in range(n):
        for w in range(wall_side.shape[0]):
            if wall_fric[w] != COULOMB:
                continue
            s = wall_side[w]
            if s == BOTTOM:
                an = aw[i, w, 1]
                k = 0
            elif s == TOP:
                an = -aw[i, w, 1]
                k = 0
            elif s == LEFT:
                an = aw[i, w, 0]
                k = 1
            else:
                an = -aw[i, w, 0]
                k = 1
            if an <= 0.0:
                continue
            vt = v[i, k]
            dv = min(wall_mu[w] * an * dt, abs(vt))
            v[i, k] = vt - dv if vt > 0.0 else vt + dv


@njit(cache=True)
def enforce_walls(x, v, wall_side, wall_pos, wall_fric, wall_mu, eps):
    """A particle that crossed a wall is put back ``eps`` inside it and its normal velocity
    into the wall is removed (a safety net; the ghosts normally keep particles out).

    On a Coulomb wall that removed normal velocity ``dv_n`` is a contact impulse like any
    other, so it also brings its friction: the tangential velocity is reduced by
    ``min(tan(delta) dv_n, |v_t|)`` (as in :func:`coulomb_friction`). Without it a particle
    lying on the wall line (where its own mirror ghost coincides with it, grad W(0) = 0, and
    the ghosts' contact force vanishes) is held up by this clamp alone and slid on without
    friction: a particle put on a 20 deg Coulomb floor at y = 1e-3 dx with 0.5 m/s slid
    0.15 m in 0.3 s and kept 0.49 m/s, instead of stopping after the sliding block's 0.035 m
    (tests/consistency/test_soil_wall_friction.py)."""
    for i in range(x.shape[0]):
        for a in range(wall_side.shape[0]):
            s = wall_side[a]
            p = wall_pos[a]
            k = -1  # tangential component of a clamped particle
            dvn = 0.0
            if s == BOTTOM and x[i, 1] < p + eps:
                x[i, 1] = p + eps
                dvn = max(-v[i, 1], 0.0)
                v[i, 1] = max(v[i, 1], 0.0)
                k = 0
            elif s == TOP and x[i, 1] > p - eps:
                x[i, 1] = p - eps
                dvn = max(v[i, 1], 0.0)
                v[i, 1] = min(v[i, 1], 0.0)
                k = 0
            elif s == LEFT and x[i, 0] < p + eps:
                x[i, 0] = p + eps
                dvn = max(-v[i, 0], 0.0)
                v[i, 0] = max(v[i, 0], 0.0)
                k = 1
            elif s == RIGHT and x[i, 0] > p - eps:
                x[i, 0] = p - eps
                dvn = max(v[i, 0], 0.0)
                v[i, 0] = min(v[i, 0], 0.0)
                k = 1
            if k >= 0 and wall_fric[a] == COULOMB and dvn > 0.0:
                vt = v[i, k]
                dv = min(wall_mu[a] * dvn, abs(vt))
                v[i, k] = vt - dv if vt > 0.0 else vt + dv


# ----------------------------------------------------------------------------- particle loops
@njit(cache=True)
def artificial_stress(n, sigma, rho, eps, out_R):
    """Monaghan/Gray artificial stress for tensile instability (Gray, Monaghan & Swift 2001):
    in the principal frame ``R' = -eps sigma'/rho^2`` for each tensile principal stress
    ``sigma' > 0`` (tension positive), 0 otherwise, rotated back. Rows ``i < n``."""
    for i in range(n):
        sxx = sigma[i, 0, 0]
        syy = sigma[i, 1, 1]
        sxy = sigma[i, 0, 1]
        th = 0.5 * math.atan2(2.0 * sxy, sxx - syy)
        c = math.cos(th)
        s = math.sin(th)
        s1 = c * c * sxx + 2.0 * c * s * sxy + s * s * syy
        s2 = s * s * sxx - 2.0 * c * s * sxy + c * c * syy
        r2 = rho[i] * rho[i]
        r1 = -eps * s1 / r2 if s1 > 0.0 else 0.0
        rr2 = -eps * s2 / r2 if s2 > 0.0 else 0.0
        out_R[i, 0, 0] = c * c * r1 + s * s * rr2
        out_R[i, 1, 1] = s * s * r1 + c * c * rr2
        out_R[i, 0, 1] = c * s * (r1 - rr2)
        out_R[i, 1, 0] = c * s * (r1 - rr2)


@njit(cache=True)
def momentum(n, x, v, rho, m, sigma, R, nbr_start, nbr_j, h, kind, c0, av_alpha, av_beta,
             as_n, w_dx, ghost_wall, out_a, out_aw):
    """Internal acceleration [S 4-9, 4-10] of soil particles ``i < n``:
    ``dv_i/dt = sum_j m_j (sigma_i/rho_i^2 + sigma_j/rho_j^2 - Pi_ij I
    + (R_i + R_j) f_ij^n) grad_i W_ij`` (gravity and damping added by the caller).

    Monaghan artificial viscosity for approaching pairs: ``mu = h v_ij.x_ij/(r^2 + 0.01 h^2)``,
    ``Pi_ij = (-alpha c0 mu + beta mu^2)/rhobar``. Artificial stress (if ``R`` is not
    ``None``-like, i.e. ``as_n > 0``): ``f_ij = W_ij / W(dx)``; ghost rows of ``R`` are zero
    (the artificial stress acts between soil particles only).

    ``out_aw[i, w]`` receives the part of ``out_a[i]`` due to the ghosts of wall ``w``
    (``ghost_wall[g]``, -1 for corner ghosts, which are left out): the wall's contact
    acceleration, used by :func:`coulomb_friction`.
    """
    for i in range(n):
        a0 = 0.0
        a1 = 0.0
        for w in range(out_aw.shape[1]):
            out_aw[i, w, 0] = 0.0
            out_aw[i, w, 1] = 0.0
        ri2 = rho[i] * rho[i]
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            d0 = x[i, 0] - x[j, 0]
            d1 = x[i, 1] - x[j, 1]
            r2 = d0 * d0 + d1 * d1
            if r2 == 0.0:  # coincident pair (e.g. two particles put into a wall corner)
                continue  # grad W(0) = 0: no force, and no 0/0
            r = math.sqrt(r2)
            dw = kernel_dw(kind, r, h)
            g0 = dw * d0 / r
            g1 = dw * d1 / r
            rj2 = rho[j] * rho[j]
            t00 = sigma[i, 0, 0] / ri2 + sigma[j, 0, 0] / rj2
            t01 = sigma[i, 0, 1] / ri2 + sigma[j, 0, 1] / rj2
            t11 = sigma[i, 1, 1] / ri2 + sigma[j, 1, 1] / rj2
            if av_alpha > 0.0 or av_beta > 0.0:
                vdotx = (v[i, 0] - v[j, 0]) * d0 + (v[i, 1] - v[j, 1]) * d1
                if vdotx < 0.0:
                    mu = h * vdotx / (r2 + 0.01 * h * h)
                    pi = (-av_alpha * c0 * mu + av_beta * mu * mu) / (0.5 * (rho[i] + rho[j]))
                    t00 -= pi
                    t11 -= pi
            if as_n > 0.0:
                f = (kernel_w(kind, r, h) / w_dx) ** as_n
                t00 += (R[i, 0, 0] + R[j, 0, 0]) * f
                t01 += (R[i, 0, 1] + R[j, 0, 1]) * f
                t11 += (R[i, 1, 1] + R[j, 1, 1]) * f
            c0_ = m[j] * (t00 * g0 + t01 * g1)
            c1_ = m[j] * (t01 * g0 + t11 * g1)
            a0 += c0_
            a1 += c1_
            if j >= n:
                w = ghost_wall[j - n]
                if w >= 0:
                    out_aw[i, w, 0] += c0_
                    out_aw[i, w, 1] += c1_
        out_a[i, 0] = a0
        out_a[i, 1] = a1


@njit(cache=True)
def velocity_gradient(n, x, v, vk, rho, m, nbr_start, nbr_j, h, kind, out_L, out_drho):
    """Velocity gradient and continuity for soil particles ``i < n``.

    ``out_L[i][a, b] = dv_a/dx_b = (sum_j V_j (v_j - v_i)_a grad_b W_ij) . M_i^-1`` with the
    correction ``M_i = sum_j V_j (x_j - x_i) (x) grad W_ij`` [F 13-14] (exact for linear
    velocity fields; identity where ``|det M| < DET_MIN``), ``V_j = m_j/rho_j``.
    Continuity [S 4-5]: ``out_drho[i] = sum_j m_j (vk_i - vk_j) . grad_i W_ij`` with ``vk`` the
    kinematic velocity (``vk = v`` for soil rows; for ghosts the velocity of the mirror image,
    :func:`fill_ghosts`), so that the density follows the actual motion of the mirrored
    configuration. A no-slip ghost's reversed tangential velocity (the device of Morris et al.
    1997, [S 4-72], for the shear rate at the wall, kept in ``L``) is not a motion: in the
    continuity it made a spurious divergence wherever the neighbourhood is one-sided (a front
    sliding on the floor), and the density drifted to negative values.
    """
    for i in range(n):
        l00 = 0.0
        l01 = 0.0
        l10 = 0.0
        l11 = 0.0
        m00 = 0.0
        m01 = 0.0
        m10 = 0.0
        m11 = 0.0
        drho = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            d0 = x[i, 0] - x[j, 0]
            d1 = x[i, 1] - x[j, 1]
            r = math.sqrt(d0 * d0 + d1 * d1)
            if r == 0.0:  # coincident pair: grad W(0) = 0
                continue
            dw = kernel_dw(kind, r, h)
            g0 = dw * d0 / r
            g1 = dw * d1 / r
            vol = m[j] / rho[j]
            u0 = v[j, 0] - v[i, 0]
            u1 = v[j, 1] - v[i, 1]
            l00 += vol * u0 * g0
            l01 += vol * u0 * g1
            l10 += vol * u1 * g0
            l11 += vol * u1 * g1
            m00 -= vol * d0 * g0
            m01 -= vol * d0 * g1
            m10 -= vol * d1 * g0
            m11 -= vol * d1 * g1
            drho -= m[j] * ((vk[j, 0] - vk[i, 0]) * g0 + (vk[j, 1] - vk[i, 1]) * g1)
        det = m00 * m11 - m01 * m10
        if abs(det) < DET_MIN:
            out_L[i, 0, 0] = l00
            out_L[i, 0, 1] = l01
            out_L[i, 1, 0] = l10
            out_L[i, 1, 1] = l11
        else:  # L . M^-1
            i00 = m11 / det
            i01 = -m01 / det
            i10 = -m10 / det
            i11 = m00 / det
            out_L[i, 0, 0] = l00 * i00 + l01 * i10
            out_L[i, 0, 1] = l00 * i01 + l01 * i11
            out_L[i, 1, 0] = l10 * i00 + l11 * i10
            out_L[i, 1, 1] = l10 * i01 + l11 * i11
        out_drho[i] = drho


@njit(cache=True)
def xsph(n, x, v, rho, m, nbr_start, nbr_j, h, kind, eps, out_v):
    """XSPH transport velocity [S 4-71]:
    ``out_v[i] = v_i + eps sum_j m_j/rhobar_ij (v_j - v_i) W_ij``."""
    for i in range(n):
        s0 = 0.0
        s1 = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            d0 = x[i, 0] - x[j, 0]
            d1 = x[i, 1] - x[j, 1]
            w = kernel_w(kind, math.sqrt(d0 * d0 + d1 * d1), h)
            f = m[j] / (0.5 * (rho[i] + rho[j])) * w
            s0 += f * (v[j, 0] - v[i, 0])
            s1 += f * (v[j, 1] - v[i, 1])
        out_v[i, 0] = v[i, 0] + eps * s0
        out_v[i, 1] = v[i, 1] + eps * s1


@njit(cache=True)
def shepard_stress(n, x, rho, m, sigma, szz, nbr_start, nbr_j, h, kind, out_sigma, out_szz):
    """Stress regularisation by a Shepard filter (Nguyen et al. 2017, for granular flows):
    ``out_i = (V_i W_ii sigma_i + sum_j V_j W_ij sigma_j) / (V_i W_ii + sum_j V_j W_ij)``,
    ghosts included with their mirrored stress. A convex combination of states inside the
    (convex) Drucker-Prager cone stays inside it, so no return mapping is needed after it."""
    w0 = kernel_w(kind, 0.0, h)
    for i in range(n):
        vi = m[i] / rho[i] * w0
        s00 = vi * sigma[i, 0, 0]
        s01 = vi * sigma[i, 0, 1]
        s11 = vi * sigma[i, 1, 1]
        sz = vi * szz[i]
        den = vi
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            d0 = x[i, 0] - x[j, 0]
            d1 = x[i, 1] - x[j, 1]
            wv = m[j] / rho[j] * kernel_w(kind, math.sqrt(d0 * d0 + d1 * d1), h)
            s00 += wv * sigma[j, 0, 0]
            s01 += wv * sigma[j, 0, 1]
            s11 += wv * sigma[j, 1, 1]
            sz += wv * szz[j]
            den += wv
        out_sigma[i, 0, 0] = s00 / den
        out_sigma[i, 0, 1] = s01 / den
        out_sigma[i, 1, 0] = s01 / den
        out_sigma[i, 1, 1] = s11 / den
        out_szz[i] = sz / den


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


@njit(cache=True)
def integrate(n, x, v, vhat, a, rho, drho, g0, g1, damping, dt, kick_only):
    """Symplectic Euler: ``v += dt (a + g - xi v)`` (kick_only) or ``x += dt vhat``,
    ``rho += dt drho`` (drift)."""
    for i in range(n):
        if kick_only:
            v[i, 0] += dt * (a[i, 0] + g0 - damping * v[i, 0])
            v[i, 1] += dt * (a[i, 1] + g1 - damping * v[i, 1])
        else:
            x[i, 0] += dt * vhat[i, 0]
            x[i, 1] += dt * vhat[i, 1]
            rho[i] += dt * drho[i]


def principal_in_plane(sigma):
    """In-plane principal stresses (numpy, output only): ``(s1 >= s2)``."""
    c = 0.5 * (sigma[:, 0, 0] + sigma[:, 1, 1])
    r = np.sqrt(0.25 * (sigma[:, 0, 0] - sigma[:, 1, 1]) ** 2 + sigma[:, 0, 1] ** 2)
    return c + r, c - r
