"""Motion loops of the fluid: the collision model, the shift [F 22-33] and its Taylor
correction's bounds, and the kinematic guard at boundaries (gather-only)."""

import math

from numba import njit, prange

from fsi_sph.fluid._kernels.surface import NEAR_SURFACE, SPLASHED, SURFACE
from fsi_sph.sph.kernels import kernel_dw, kernel_w, pair_offset


@njit(cache=True, parallel=True)
def collision_dv(x, v, m, nbr_start, nbr_j, nf, fluid_of, r_c, restitution, out_dv):
    """Velocity change of the particle collision model (``fluid.collision``): every pair of
    fluid particles closer than ``r_c`` that approach each other, ``w = (u_i - u_j) . n_ij
    < 0`` with ``n_ij = (x_i - x_j) / r``, loses the approach as in a collision with
    restitution ``e``: ``du_i = -(1 + e) m_j / (m_i + m_j) w n_ij`` (equal and opposite
    momentum changes, so momentum is conserved; all pairs from the same ``v``). A numerical
    contact rule with no equation in PHYSICS.md: it acts after the correction [F 18] only on
    pairs closer than any the continuum flow leaves (interior pairs stay > 0.8 dx apart).
    ``fluid_of[j]``: the fluid particle that row ``j`` of the stacked positions is (itself,
    or the original of a periodic image), -1 for boundary rows; ``v`` and ``m`` per fluid
    particle."""
    for i in prange(nf):
        d0 = 0.0
        d1 = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            jf = fluid_of[j]
            if jf < 0 or jf == i:
                continue
            n0 = x[i, 0] - x[j, 0]
            n1 = x[i, 1] - x[j, 1]
            r = math.sqrt(n0 * n0 + n1 * n1)
            if r >= r_c or r < 1e-12 * r_c:
                continue
            n0 /= r
            n1 /= r
            w = (v[i, 0] - v[jf, 0]) * n0 + (v[i, 1] - v[jf, 1]) * n1
            if w < 0.0:
                c = -(1.0 + restitution) * m[jf] / (m[i] + m[jf]) * w
                d0 += c * n0
                d1 += c * n1
        out_dv[i, 0] = d0
        out_dv[i, 1] = d1


@njit(cache=True, parallel=True)
def shift_vectors(x, v, vol, nbr_start, nbr_j, nf, h, kind, model, coef, dt, cap, classes,
                  normals, out_dr):
    """Particle shift [F 22-33].

    ``model = 0`` (Fickian, Lind et al. 2012): ``dr_i = -A h |u_i| dt grad C_i``,
    ``grad C_i = sum_j V_j grad W_ij``; ``model = 2`` (Fickian with a fixed diffusion
    coefficient, ``D = A h^2``): ``dr_i = -A h^2 grad C_i``; ``model = 1`` (centroid, [F 23-25]):
    ``dr_i = eps sum_j V_j r_ij W_ij``. Surface and near-surface particles keep only the
    tangential part ``(I - n n) dr`` [F 31-32]; splashed particles do not shift; ``|dr| <=
    cap`` (m).
    """
    for i in prange(nf):
        out_dr[i, 0] = 0.0
        out_dr[i, 1] = 0.0
        c = classes[i]
        if c == SPLASHED:
            continue
        s0 = 0.0
        s1 = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j, d0, d1, r = pair_offset(x, x, nbr_j, i, k)
            if r < 1e-12 * h:
                continue
            if model != 1:
                f = vol[j] * kernel_dw(kind, r, h) / r
            else:
                f = vol[j] * kernel_w(kind, r, h)
            s0 += f * d0
            s1 += f * d1
        if model == 0:
            speed = math.sqrt(v[i, 0] ** 2 + v[i, 1] ** 2)
            s0 *= -coef * h * speed * dt
            s1 *= -coef * h * speed * dt
        elif model == 2:
            s0 *= -coef * h * h
            s1 *= -coef * h * h
        else:
            s0 *= coef
            s1 *= coef
        if c == SURFACE or c == NEAR_SURFACE:
            n0 = normals[i, 0]
            n1 = normals[i, 1]
            dn = s0 * n0 + s1 * n1
            s0 -= dn * n0
            s1 -= dn * n1
        m = math.sqrt(s0 * s0 + s1 * s1)
        if m > cap:
            s0 *= cap / m
            s1 *= cap / m
        out_dr[i, 0] = s0
        out_dr[i, 1] = s1


@njit(cache=True, parallel=True)
def neighbour_bounds(p, v, nbr_start, nbr_j, nf, jv, out_lo, out_hi):
    """Smallest and largest ``(u, v, p)`` over row ``i`` and its neighbours (``out_lo``,
    ``out_hi``: (nf, 3)); the velocity over sources ``j < jv`` only when ``jv >= 0`` (the
    boundary rows of a free-slip wall carry no velocity of their own)."""
    for i in prange(nf):
        lo0, lo1, lo2 = v[i, 0], v[i, 1], p[i]
        hi0, hi1, hi2 = lo0, lo1, lo2
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            lo2 = min(lo2, p[j])
            hi2 = max(hi2, p[j])
            if jv >= 0 and j >= jv:
                continue
            lo0 = min(lo0, v[j, 0])
            hi0 = max(hi0, v[j, 0])
            lo1 = min(lo1, v[j, 1])
            hi1 = max(hi1, v[j, 1])
        out_lo[i, 0] = lo0
        out_lo[i, 1] = lo1
        out_lo[i, 2] = lo2
        out_hi[i, 0] = hi0
        out_hi[i, 1] = hi1
        out_hi[i, 2] = hi2


@njit(cache=True, parallel=True)
def apply_shift(dr, grad_p, grad_v, taylor, lo, hi, x, p, v, energy_cap=False):
    """``x += dr`` and, with ``taylor``, ``phi += dr . grad phi`` for p and u [F 33], each
    result clamped to ``[lo, hi]`` (:func:`neighbour_bounds`: the range of the neighbourhood,
    a monotonicity limiter). Without the clamp a particle whose velocity stands out from its
    neighbours' is extrapolated further out whenever it shifts away from them: the gradient
    is its own difference to them (seen: a particle at 12 m/s among neighbours at 1 m/s
    gained 2 m/s per step in the gate's outflow). ``energy_cap``: the corrected velocity is
    scaled back to the particle's speed before the shift where it would be faster (the shift
    moves particles, it makes no kinetic energy: without it the dam break's spray gained
    energy without bound, +56 % of the column's by 3 s; with it the energy falls,
    docs/numerics/fluid.md, "Energy cap")."""
    for i in prange(dr.shape[0]):
        d0 = dr[i, 0]
        d1 = dr[i, 1]
        x[i, 0] += d0
        x[i, 1] += d1
        if taylor:
            pn = p[i] + d0 * grad_p[i, 0] + d1 * grad_p[i, 1]
            v0 = v[i, 0] + grad_v[i, 0, 0] * d0 + grad_v[i, 0, 1] * d1
            v1 = v[i, 1] + grad_v[i, 1, 0] * d0 + grad_v[i, 1, 1] * d1
            p[i] = min(max(pn, lo[i, 2]), hi[i, 2])
            v0 = min(max(v0, lo[i, 0]), hi[i, 0])
            v1 = min(max(v1, lo[i, 1]), hi[i, 1])
            if energy_cap:
                s_old = v[i, 0] * v[i, 0] + v[i, 1] * v[i, 1]
                s_new = v0 * v0 + v1 * v1
                if s_new > s_old:
                    c = math.sqrt(s_old / s_new)
                    v0 *= c
                    v1 *= c
            v[i, 0] = v0
            v[i, 1] = v1


@njit(cache=True)
def nearest_source(x, nbr_start, nbr_j, i, j_lo, j_hi, normals):
    """The neighbour ``j_lo <= j < j_hi`` of row ``i`` nearest to it among those with a
    surface normal (``normals[j - j_lo] != 0``; -1 if none). Interior boundary particles
    (zero normal) are passed over: a fluid particle that has come closer to one of them than
    to the surface layer is still guarded by the surface layer's normal."""
    best = 1e300
    jb = -1
    for k in range(nbr_start[i], nbr_start[i + 1]):
        j = nbr_j[k]
        if j < j_lo or j >= j_hi:
            continue
        if normals[j - j_lo, 0] == 0.0 and normals[j - j_lo, 1] == 0.0:
            continue
        d0 = x[i, 0] - x[j, 0]
        d1 = x[i, 1] - x[j, 1]
        r2 = d0 * d0 + d1 * d1
        if r2 < best:
            best = r2
            jb = j
    return jb


@njit(cache=True)
def _guard_row(i, x, nbr_start, nbr_j, j_lo, j_hi, normals, v_b, gap, dt, v_old, v, out_dv,
               out_row, stop, w_new):
    """:func:`boundary_guard` on row ``i``."""
    out_dv[i, 0] = 0.0
    out_dv[i, 1] = 0.0
    out_row[i] = -1
    jb = nearest_source(x, nbr_start, nbr_j, i, j_lo, j_hi, normals)
    if jb < 0:
        return
    b = jb - j_lo
    n0 = normals[b, 0]
    n1 = normals[b, 1]
    dn = (x[i, 0] - x[jb, 0]) * n0 + (x[i, 1] - x[jb, 1]) * n1
    un = (v[i, 0] - v_b[b, 0]) * n0 + (v[i, 1] - v_b[b, 1]) * n1
    un_old = (v_old[i, 0] - v_b[b, 0]) * n0 + (v_old[i, 1] - v_b[b, 1]) * n1
    if dn >= gap:
        step = dt * (w_new * un + (1.0 - w_new) * un_old)
        if dn + step >= gap:
            return
        cut = 1.0 if stop else 1.0 - (gap - dn) / step  # step < gap - dn <= 0
        un *= cut
        un_old *= cut
    else:
        un = min(un, 0.0)
        un_old = min(un_old, 0.0)
    if un != 0.0:
        out_dv[i, 0] = -un * n0
        out_dv[i, 1] = -un * n1
        v[i, 0] -= un * n0
        v[i, 1] -= un * n1
        out_row[i] = b
    v_old[i, 0] -= un_old * n0
    v_old[i, 1] -= un_old * n1


@njit(cache=True, parallel=True)
def boundary_guard(x, nbr_start, nbr_j, nf, j_lo, j_hi, normals, v_b, gap, dt, v_old, v,
                   out_dv, out_row, stop=False, w_new=0.5):
    """Kinematic guard at a boundary (sources ``j_lo <= j < j_hi``: the walls, or the moving
    structures; ``normals`` and boundary velocities ``v_b`` indexed from ``j_lo``).

    A fluid particle closer than ``gap`` (along the normal) to its nearest boundary particle
    loses the part of its velocity relative to that particle that points into the boundary
    (in ``v_old`` and ``v``). A particle farther out whose step
    ``dt ((1 - w_new) v_old + w_new v)`` (the fluid's position update: 0.5 for the
    trapezoid [F 19], 1.5 for the damped one) would
    end closer than ``gap`` has both normal parts scaled so that it ends at ``gap`` (the
    step is swept: a particle cannot jump over the guard's band in one long step). A
    free-surface particle has a Dirichlet PPE row, which imposes no continuity constraint,
    so nothing else stops a thin jet from sinking into a wall or running into a structure;
    elsewhere the boundary pressure keeps the particles away and this does nothing. The
    change of ``v`` and the boundary row go to ``out_dv`` and ``out_row`` (-1: none), so
    that a moving boundary can get the opposite impulse. For a displacement (the shift)
    pass it as ``v`` and ``v_old`` alike (copies) with ``dt = 1``. ``stop``: a particle whose
    step would reach the band loses its whole velocity into the boundary (an inelastic
    contact within the step) instead of the share that takes it past the band's edge."""
    for i in prange(nf):
        _guard_row(i, x, nbr_start, nbr_j, j_lo, j_hi, normals, v_b, gap, dt, v_old, v, out_dv,
                   out_row, stop, w_new)


@njit(cache=True, parallel=True)
def boundary_guard_rows(rows, x, nbr_start, nbr_j, j_lo, j_hi, normals, v_b, gap, dt, v_old, v,
                        out_dv, out_row, stop=False, w_new=0.5):
    """:func:`boundary_guard` on the fluid rows ``rows`` only (the others untouched)."""
    for k in prange(len(rows)):
        _guard_row(rows[k], x, nbr_start, nbr_j, j_lo, j_hi, normals, v_b, gap, dt, v_old, v,
                   out_dv, out_row, stop, w_new)
