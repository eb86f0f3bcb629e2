"""Fluid-structure coupling [F 46-48] (PHYSICS.md §5): a staggered explicit scheme.

Per fluid step ``dt_f``:

1. the fluid solves its pressure with the structure particles as moving boundary particles;
2. :func:`interface_forces` gives the pairwise pressure force on every structure particle
   (and the opposite one on the fluid), held fixed over the structure's sub-steps;
3. :func:`advance_structure` advances the structure ``n_sub`` sub-steps,
   ``n_sub = ceil(dt_f / dt_s)`` from the two stability limits unless the case fixes it
   (the source uses 100), and returns its velocity averaged over the sub-steps,
   ``(x^{n+1} - x^n) / dt_f``, which the fluid sees as the boundary velocity.

The power exchanged is logged on both sides: the rate of work of the interface force on
the structure (``sum_s F_s . v_s``) and on the fluid (``sum_f F_f . v_f``); for a consistent
coupling they are close to opposite.
"""

from __future__ import annotations

import math

import numpy as np

from fsi_sph.coupling import _kernels as K


def substep_count(dt_f, dt_s, fixed=None):
    """Sub-steps of a structure within one fluid step: ``fixed`` if the case sets it, else
    ``ceil(dt_f / dt_s)`` (at least 1) [F 48 and text]."""
    if fixed is not None:
        return int(fixed)
    return max(1, math.ceil(dt_f / dt_s - 1e-12))


def interface_forces(x_s, p_s, vol_s, x_f, p_f, vol_f, sf_start, sf_j, fs_start, fs_j, h,
                     kind, scale, out_on_structure, out_on_fluid):
    """Pairwise interface pressure forces [F 46-47] on the structure rows (from their fluid
    neighbours ``sf``) and on the fluid rows (from their structure neighbours ``fs``)."""
    K.pair_pressure_forces(x_s, p_s, vol_s, x_f, p_f, vol_f, sf_start, sf_j, h, kind, scale,
                           out_on_structure)
    K.pair_pressure_forces(x_f, p_f, vol_f, x_s, p_s, vol_s, fs_start, fs_j, h, kind, scale,
                           out_on_fluid)


def advance_structure(body, dt_f, n_sub):
    """Advance ``body`` (it has ``substep(dt)`` and ``.body['x']``, its ``f_ext`` already
    set and held) by ``n_sub`` equal sub-steps; returns the sub-step-averaged velocity."""
    x0 = body.body["x"].copy()
    dt_s = dt_f / n_sub
    for _ in range(n_sub):
        body.substep(dt_s)
    return (body.body["x"] - x0) / dt_f


def interface_power(force, velocity):
    """Rate of work ``sum_i F_i . v_i`` (W per metre of depth)."""
    return float(np.sum(force * velocity))
