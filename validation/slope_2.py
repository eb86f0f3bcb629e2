"""Slope 2 of [S 5-5] (c = 11 kPa, phi = 20 deg, 45 deg face 10 m high on a rigid floor at the
toe level): SPH strength reduction vs Bishop's simplified method."""

from validation.slope_fos import Slope, validate_slope

SLOPE = Slope("slope_2_cohesive", "clay", ladder=(0.4, 0.2), quick_ladder=(0.4,))


def validate(quick=False, data_dir=None, out_dir=None):
    return validate_slope(SLOPE, quick, out_dir)
