"""Slope 3 of [S 5-5] (c = 10 kPa, phi = 20 deg, 45 deg face 10 m high on a 5 m layer):
SPH strength reduction vs Bishop's simplified method."""

from validation.slope_fos import Slope, validate_slope

SLOPE = Slope("slope_3_cohesive_layer", "clay", ladder=(0.75, 0.5), quick_ladder=(0.75,))


def validate(quick=False, data_dir=None, out_dir=None):
    return validate_slope(SLOPE, quick, out_dir)
