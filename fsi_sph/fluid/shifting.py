"""Particle shifting [F 22-33] (PHYSICS.md §3).

Default law: Fickian (Lind et al. 2012), ``dr = -A h |u| dt grad C`` with the colour gradient
``grad C = sum_j V_j grad W_ij`` over fluid and wall neighbours; ``fickian_fixed`` uses a
fixed diffusion coefficient ``D = A h^2`` (PHYSICS.md §3: ``D ~ 0.5 h^2``), which also acts
where the flow is slow; the [F 23-25] centroid law ``dr = eps sum_j V_j r_ij W_ij`` is the
third choice. Either way free- and near-surface
particles shift only tangentially [F 31-32], splashed particles do not shift, ``|dr|`` is
capped, and velocity and pressure are corrected by a Taylor step [F 33].
"""

from __future__ import annotations

from fsi_sph.fluid import _kernels as K

MODELS = {"fickian": 0, "centroid": 1, "fickian_fixed": 2}


class Shifting:
    """Shifting with the settings of a ``ShiftingSection``."""

    def __init__(self, cfg, h):
        self.cfg = cfg
        self.model = MODELS[cfg.model]
        self.cap = cfg.max_shift * h

    def vectors(self, x, v, vol, nbr_start, nbr_j, nf, h, kind, dt, classes, normals, out_dr):
        """Shift vectors of the fluid rows into ``out_dr`` (nf, 2)."""
        K.shift_vectors(x, v, vol, nbr_start, nbr_j, nf, h, kind, self.model,
                        self.cfg.coefficient, dt, self.cap, classes, normals, out_dr)

    def apply(self, dr, grad_p, grad_v, lo, hi, x, p, v):
        """Move the particles and (if enabled) Taylor-correct ``p`` and ``v`` [F 33], within
        the neighbourhood's range ``[lo, hi]`` (:func:`_kernels.neighbour_bounds`)."""
        K.apply_shift(dr, grad_p, grad_v, self.cfg.taylor_correction, lo, hi, x, p, v,
                      self.cfg.taylor_energy_cap)
