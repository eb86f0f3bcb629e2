"""Numba particle loops of the incompressible SPH fluid (gather-only: iteration ``i`` writes
only row ``i``), by topic: :mod:`.surface` (free surface), :mod:`.gradients` (correction
matrices, gradients, predictor, divergence, wall normals, Shepard averages), :mod:`.pressure`
(PPE rows, pressure gradients), :mod:`.motion` (collisions, shift, kinematic guard). The
fluid package reaches them all as ``K`` through this module.

Index space: the fluid particles come first (``0 .. nf-1``), the wall particles after them
(``nf .. nf+nw-1``); ``x``, ``v``, ``p``, ``vol`` passed to the loops are these stacked arrays.
Neighbour lists are CSR: ``nbr_j[nbr_start[i]:nbr_start[i+1]]`` are the sources of row ``i``
(fluid rows: fluid and wall sources, self excluded; wall rows: fluid sources).

Kernel gradient convention: ``grad W_ij = dW/dr (x_i - x_j) / r`` (gradient at ``x_i``).
Lattice normalisation: on a full, uniform lattice with h = 1.2 dx the discrete moment
``sum_j V_j (x_j - x_i) (x) grad W_ij`` is 0.991 I rather than I and the Morris sum of
``|r_ij|^2`` is 3.92 rather than 4. The callers pass global constants ``grad_scale`` and
``lap_scale`` that remove these lattice errors (one number per run, so pair antisymmetry and
the matrix structure are kept) and make the operators exact on linear (gradient) and
quadratic (Laplacian) fields in the interior of a uniform lattice.
"""

from fsi_sph.fluid._kernels.gradients import (
    DET_MIN,
    corrected_pair_gradient,
    correction_matrices,
    fluid_neighbour_counts,
    fluid_sublists,
    gradients,
    predict_velocity,
    shepard_at,
    smagorinsky,
    velocity_divergence,
    wall_normals,
)
from fsi_sph.fluid._kernels.motion import (
    apply_shift,
    boundary_guard,
    boundary_guard_rows,
    collision_dv,
    nearest_source,
    neighbour_bounds,
    shift_vectors,
)
from fsi_sph.fluid._kernels.pressure import (
    corrected_pressure_gradient,
    ppe_fill,
    ppe_row_lengths,
    pressure_gradient,
    structure_row_pressure_gradient,
    wall_floor,
)
from fsi_sph.fluid._kernels.surface import (
    INTERIOR,
    NEAR_SURFACE,
    SPLASHED,
    SURFACE,
    isolated_rows,
    pocket_rows,
    position_divergence,
    surface_classes,
    umbrella_scan,
)

__all__ = [
    "DET_MIN",
    "INTERIOR",
    "NEAR_SURFACE",
    "SPLASHED",
    "SURFACE",
    "apply_shift",
    "boundary_guard",
    "boundary_guard_rows",
    "collision_dv",
    "corrected_pair_gradient",
    "corrected_pressure_gradient",
    "correction_matrices",
    "fluid_neighbour_counts",
    "fluid_sublists",
    "gradients",
    "isolated_rows",
    "pocket_rows",
    "nearest_source",
    "neighbour_bounds",
    "position_divergence",
    "ppe_fill",
    "ppe_row_lengths",
    "predict_velocity",
    "pressure_gradient",
    "shepard_at",
    "shift_vectors",
    "smagorinsky",
    "structure_row_pressure_gradient",
    "surface_classes",
    "umbrella_scan",
    "velocity_divergence",
    "wall_floor",
    "wall_normals",
]
