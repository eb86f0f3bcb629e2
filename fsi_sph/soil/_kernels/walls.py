"""The soil's walls (conventions in :mod:`fsi_sph.soil._kernels`): mirror ghosts and their
state, Coulomb wall friction and the walls' kinematic constraint."""

from numba import njit

# wall sides and friction laws (integer codes shared with drucker_prager.py)
BOTTOM = 0
LEFT = 1
RIGHT = 2
TOP = 3
FREE_SLIP = 0
NO_SLIP = 1
COULOMB = 2


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
