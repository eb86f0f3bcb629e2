"""The 2D finite-element reference of the oscillating plate recovers thin-plate theory for a
slender plate and converges at second order."""

import math

from validation.plate_fem import converged_period, euler_bernoulli_period

K, NU, RHO = 3.25e6, 0.3975, 1000.0
E = 3 * K * (1 - 2 * NU)


def test_slender_plate_is_euler_bernoulli():
    T, _, order = converged_period(1.0, 0.02, E, NU, RHO, ny_list=(2, 4, 8))
    assert abs(T / euler_bernoulli_period(1.0, 0.02, E, NU, RHO) - 1) < 2e-3
    assert 1.5 < order < 2.5


def test_thick_plate_period_longer_than_thin_theory():
    """Shear and rotary inertia lengthen the period of the L/t = 10 plate."""
    T, _, _ = converged_period(0.2, 0.02, E, NU, RHO)
    c0 = math.sqrt(K / RHO)
    assert 72.39 * 1.002 < T * c0 / 0.2 < 72.39 * 1.01
