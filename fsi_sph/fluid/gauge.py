"""The pressure level of a confined flow beside a body, for the force probes.

The pair form of the interface's pressure term [F 46-47], ``sum_f (p_w + p_f) V_f grad W_wf``,
does not vanish under a uniform pressure where the support is irregular (a round body's rings
are not on the fluid's lattice). In a confined flow (no free surface:
``IncompressibleFluid.fills_its_channel``) the whole channel's pressure level moves by
kilopascals from step to step (the column between the inflow and the outflow answers any net
volume error of the step; CFD2 at D/dx = 10: std 4.1 kPa beside the body about a mean of
0.14 kPa), and through the pair form that level became force noise on the probed body. A
uniform pressure does no net work on a closed body, so a force probe of a confined flow takes
the pressures relative to the mean pressure of the fluid rows beside its body
(:func:`level_beside`; docs/numerics/fluid.md § Round bodies and forces on bodies).

The same gauge in the coupling itself (the pair-form gradient of the rows beside a structure,
the interface force, the implicit rows of the solve) was measured and not adopted
(docs/numerics/coupling.md § Pressure level of a confined flow). Not in PHYSICS.md;
tests/unit/test_interface_gauge.py.
"""

from __future__ import annotations

import numpy as np

from fsi_sph.fluid.boundary import rows_kept


def level_beside(ps, boundary_rows):
    """The mean pressure of the fluid rows beside the boundary rows ``boundary_rows`` (a
    body's particles after the fluid's; their fluid neighbour lists ``wf``): the level a
    force probe on a closed body takes the pressures relative to in a confined flow (0
    without fluid neighbours)."""
    keep = np.zeros(ps.nw, dtype=bool)
    keep[boundary_rows] = True
    _, nb = rows_kept(ps.wf_start[:ps.nw + 1], ps.wf_j[:ps.wf_start[ps.nw]], keep)
    nb = np.unique(nb[nb < ps.nf])
    return float(ps.p_all[nb].mean()) if len(nb) else 0.0
