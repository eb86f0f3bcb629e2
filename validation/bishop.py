"""Bishop's simplified method with a critical-circle search: moved into the package,
:mod:`fsi_sph.soil.limit_equilibrium` (``fsi-sph fos CASE --method bishop``); re-exported here
for the validation scripts. Not a validation itself (no ``validate``)."""

from fsi_sph.soil.limit_equilibrium import (  # noqa: F401
    Circle,
    bishop_fos,
    critical_circle,
    ground,
    infinite_slope_fos,
    slip_mass,
)
