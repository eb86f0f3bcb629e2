"""Slope 1 of [S 5-5] (cohesionless, 45 deg face, phi = 20 deg): SPH strength reduction vs
Bishop. With c = 0 the limit-equilibrium factor of safety tends to that of an infinite slope,
tan(phi)/tan(45 deg) = 0.364, for skin-deep circles; the search excludes circles shallower
than 5 % of the height. Why the SPH value sits below it (non-associated flow, psi = 0), and
what made it 27 % low before: validation/README_soil.md."""

from validation.slope_fos import Slope, validate_slope

SLOPE = Slope("slope_1_granular", "sand", ladder=(0.05, 0.025), quick_ladder=(0.05,))


def validate(quick=False, data_dir=None, out_dir=None):
    return validate_slope(SLOPE, quick, out_dir)
