"""Numba kernels of the Drucker-Prager soil (updated-Lagrangian SPH, PHYSICS.md §6), by topic:
:mod:`.constitutive` (the law and its return mapping), :mod:`.walls` (mirror ghosts, wall
friction), :mod:`.loops` (the particle loops); re-exported here for ``drucker_prager.py``.

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

from fsi_sph.soil._kernels.constitutive import (
    dp_parameters,
    invariants,
    principal_in_plane,
    return_map,
    stress_update,
)
from fsi_sph.soil._kernels.loops import (
    DET_MIN,
    artificial_stress,
    integrate,
    momentum,
    shepard_stress,
    velocity_gradient,
    xsph,
)
from fsi_sph.soil._kernels.walls import (
    BOTTOM,
    COULOMB,
    FREE_SLIP,
    LEFT,
    NO_SLIP,
    RIGHT,
    TOP,
    coulomb_friction,
    enforce_walls,
    fill_ghosts,
    make_ghosts,
)

__all__ = [
    "BOTTOM",
    "COULOMB",
    "DET_MIN",
    "FREE_SLIP",
    "LEFT",
    "NO_SLIP",
    "RIGHT",
    "TOP",
    "artificial_stress",
    "coulomb_friction",
    "dp_parameters",
    "enforce_walls",
    "fill_ghosts",
    "integrate",
    "invariants",
    "make_ghosts",
    "momentum",
    "principal_in_plane",
    "return_map",
    "shepard_stress",
    "stress_update",
    "velocity_gradient",
    "xsph",
]
