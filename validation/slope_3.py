"""Slope 3 of [S 5-5] (c = 10 kPa, phi = 20 deg, 45 deg face 10 m high on a 5 m layer):
SPH strength reduction vs Bishop's simplified method."""

from validation.slope_fos import Slope, validate_slope

SLOPE = Slope("slope_3_cohesive_layer", "clay",
              [(0.0, 15.0), (10.0, 15.0), (20.0, 5.0), (45.0, 5.0)], height=10.0,
              ladder=(0.75, 0.5), quick_ladder=(0.75,), t_settle=2.0, t_trial=4.0,
              damping=15.0, bracket=(0.8, 1.4))


def validate(quick=False, data_dir=None, out_dir=None):
    return validate_slope(SLOPE, quick, out_dir)
