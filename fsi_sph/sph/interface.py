"""Numba loops of the fluid-structure interface (gather-only: iteration ``i`` writes row ``i``).

The interface force between a fluid particle ``f`` and a structure particle ``s`` is the
conservative pressure-gradient pair term [F 46-47]::

    F_{s<-f} = -c V_s V_f (p_s + p_f) grad_s W_sf,    F_{f<-s} = -F_{s<-f}

with ``c`` the fluid's gradient normalisation (1 for a plain SPH sum). Both sides are
gathered separately (structure rows over fluid neighbours, fluid rows over structure
neighbours); because ``grad_f W_fs = -grad_s W_sf`` the two sums cancel pair by pair, so the
momentum exchanged sums to zero to round-off.
"""

from numba import njit, prange

from fsi_sph.sph.kernels import kernel_dw, kernel_w, pair_offset


@njit(cache=True, parallel=True)
def pair_pressure_forces(xd, pd, vold, xs, ps, vols, nbr_start, nbr_j, h, kind, scale, M,
                         m_on_dest, out_f):
    """Force on each destination particle ``i`` from its source neighbours ``j`` [F 46-47],
    the pair's gradient weighted by the matrix ``M`` of its fluid particle:
    ``out_f[i] = -scale sum_j V_i V_j (p_i + p_j) M_f grad_i W_ij`` (N per metre of depth),
    ``f = i`` when ``m_on_dest`` (destinations are the fluid rows) else ``f = j``. ``M_f = I``
    gives the plain pair term; ``scale M_f = L_f`` [F 13-14] the corrected one of the
    waterline rows (``IncompressibleFluid.interface_weights``). The same matrix on both sides
    of a pair keeps action equal to reaction."""
    for i in prange(xd.shape[0]):
        row = nbr_j.dtype.type(i)
        f0 = 0.0
        f1 = 0.0
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j, d0, d1, r = pair_offset(xd, xs, nbr_j, i, k)
            if r < 1e-12 * h:
                continue
            c = vols[j] * (pd[i] + ps[j]) * kernel_dw(kind, r, h) / r
            m = row if m_on_dest else j
            f0 += c * (M[m, 0, 0] * d0 + M[m, 0, 1] * d1)
            f1 += c * (M[m, 1, 0] * d0 + M[m, 1, 1] * d1)
        out_f[i, 0] = -scale * vold[i] * f0
        out_f[i, 1] = -scale * vold[i] * f1


@njit(cache=True, parallel=True)
def rigid_pair_terms(x_s, vol_s, x_f, vol_f, sf_start, sf_j, h, kind, scale, M, body_of, xc,
                     out_rbar, out_pair):
    """Terms of the PPE's rigid-body rows (``coupling.structure_acceleration = "rigid"``),
    per structure particle ``i`` and per interface pair ``k`` of its fluid neighbours.

    ``out_rbar[i] = sum_f w_if (x_i - x_f)`` (Shepard weights over structure particle ``i``'s
    fluid neighbours; 0 without any), the lever of Adami's extrapolation. ``out_pair[k]``:
    the pair's coefficients ``(G_x, G_y, r_i x G)`` of the pressures ``p_i + p_f`` in the
    generalised interface force of ``i``'s body ``b`` (x force, y force, torque about
    ``xc[b]``), from [F 46-47]::

        F_b = sum_{i in b} sum_f G_if (p_i + p_f),  G_if = -c V_i V_f M_f grad_i W_if,
        T_b = sum_{i in b} sum_f (r_i x G_if) (p_i + p_f),  r_i = x_i - xc[b]

    (``M_f`` the pair weights of :func:`pair_pressure_forces`, the identity but on the
    waterline rows, so that the solve sees the force the body then receives). A coincident
    pair's coefficients are 0. :func:`add_pair_terms` sums them into the body's rows."""
    for i in prange(x_s.shape[0]):
        b = body_of[i]
        rx = x_s[i, 0] - xc[b, 0]
        ry = x_s[i, 1] - xc[b, 1]
        sw = 0.0
        r0 = 0.0
        r1 = 0.0
        for k in range(sf_start[i], sf_start[i + 1]):
            j, d0, d1, r = pair_offset(x_s, x_f, sf_j, i, k)
            wt = kernel_w(kind, r, h)
            sw += wt
            r0 += wt * d0
            r1 += wt * d1
            out_pair[k, 0] = 0.0
            out_pair[k, 1] = 0.0
            out_pair[k, 2] = 0.0
            if r < 1e-12 * h:
                continue
            c = -scale * vol_s[i] * vol_f[j] * kernel_dw(kind, r, h) / r
            gx = c * (M[j, 0, 0] * d0 + M[j, 0, 1] * d1)
            gy = c * (M[j, 1, 0] * d0 + M[j, 1, 1] * d1)
            out_pair[k, 0] = gx
            out_pair[k, 1] = gy
            out_pair[k, 2] = rx * gy - ry * gx
        if sw > 0.0:
            out_rbar[i, 0] = r0 / sw
            out_rbar[i, 1] = r1 / sw
        else:
            out_rbar[i, 0] = 0.0
            out_rbar[i, 1] = 0.0


@njit(cache=True)
def add_pair_terms(pair_body, col_i, col_f, pair, out_g):
    """``out_g[3 b + d, col] += pair[k, d]`` for each pair ``k`` (of body ``pair_body[k]``),
    in the pairs' order, at both of its columns: the structure row's ``col_i[k]`` and the
    fluid row's ``col_f[k]`` (the rigid-body rows of :func:`rigid_pair_terms`). A fluid row
    beside two structure particles collects from both, so this loop scatters and runs
    serially; the order of the pairs is the order of the sums."""
    for k in range(len(pair_body)):
        b = pair_body[k]
        for col in (col_i[k], col_f[k]):
            for d in range(3):
                out_g[3 * b + d, col] += pair[k, d]
