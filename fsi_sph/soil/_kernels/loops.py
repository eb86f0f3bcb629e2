"""Particle loops of the soil (conventions in :mod:`fsi_sph.soil._kernels`): artificial
stress, momentum, velocity gradient and density rate, XSPH, Shepard stress, time integration."""

import math

from numba import njit

from fsi_sph.sph.kernels import kernel_dw, kernel_w, pair_offset

DET_MIN = 1e-3  # correction matrix with |det| below this (full support ~ 1) -> identity


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
            j, d0, d1, r = pair_offset(x, x, nbr_j, i, k)
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
