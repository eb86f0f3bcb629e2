"""Measurements of the column-collapse validation (validation/column_collapse.py) on
configurations with a known answer."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from validation.column_collapse import (  # noqa: E402
    failure_line,
    onset_sensitivity,
    static_bounds,
)
from validation.soil_common import deposit_toe  # noqa: E402


def test_static_bounds_of_a_cohesionless_deposit():
    """phi = 45 deg, H = L = 1: the surface at 45 deg from the end of an undisturbed top x_a
    holds the area L H when x_a + H/2 = 1, so x_a = 0.5, run-out 1.5, steepest final line
    from the toe atan(1/0.5)."""
    x_a, runout, angle = static_bounds(45.0, 1.0, 1.0)
    assert x_a == pytest.approx(0.5, rel=1e-12)
    assert runout == pytest.approx(1.5, rel=1e-12)
    assert angle == pytest.approx(math.degrees(math.atan(2.0)), rel=1e-12)
    # the column of the validation: phi = 19.8 deg, H = 0.1, L = 0.2
    x_a, runout, angle = static_bounds()
    assert 0.1 * x_a + 0.5 * 0.1 * 0.1 / math.tan(math.radians(19.8)) == pytest.approx(0.02)
    assert angle < 45.0 + 19.8 / 2 - 5.0


@pytest.mark.parametrize("theta", [40.0, 54.9, 65.0])
def test_failure_line_of_a_planar_wedge(theta):
    """Plastic strain 1 in the wedge in front of a plane through the toe at theta, 0 behind
    it: the fitted angle is theta to within the lattice resolution."""
    dx = 0.0025
    xs, ys = np.meshgrid(np.arange(dx / 2, 0.2, dx), np.arange(dx / 2, 0.1, dx))
    x0 = np.column_stack([xs.ravel(), ys.ravel()])
    eps = (x0[:, 0] > 0.2 - x0[:, 1] / math.tan(math.radians(theta))).astype(float)
    _, angle = failure_line(x0, eps, dx)
    assert angle == pytest.approx(theta, abs=1.5)


def test_deposit_toe_ignores_particles_thrown_ahead():
    dx = 0.01
    x = np.array([[0.005 + k * dx, 0.005] for k in range(30)] + [[0.5, 0.005]])
    assert deposit_toe(x, dx) == pytest.approx(0.295 + 0.005)


def test_onset_sensitivity_of_a_graded_wedge():
    """A wedge whose plastic strain falls linearly from 1 on the 70 deg plane through the toe
    to 0 on the 45 deg plane: each threshold e finds the plane where the strain is e, so the
    line steepens from 45 towards 70 deg as the threshold rises (the way the onset line of
    the column depends on EPS_LINE); a sharp wedge gives the same angle at every threshold."""
    dx = 0.0025
    xs, ys = np.meshgrid(np.arange(dx / 2, 0.2, dx), np.arange(dx / 2, 0.1, dx))
    x0 = np.column_stack([xs.ravel(), ys.ravel()])
    x45 = 0.2 - x0[:, 1]
    x70 = 0.2 - x0[:, 1] / math.tan(math.radians(70.0))
    graded = np.clip((x0[:, 0] - x45) / (x70 - x45 + 1e-12), 0.0, 1.0)
    sharp = (x0[:, 0] > 0.2 - x0[:, 1] / math.tan(math.radians(55.0))).astype(float)
    res = onset_sensitivity(x0, {0.1: graded, 0.2: sharp}, dx, thresholds=(0.05, 0.5, 0.95))
    assert set(res) == {f"adv={a}H,eps={e}" for a in (0.1, 0.2) for e in (0.05, 0.5, 0.95)}
    a = [res[f"adv=0.1H,eps={e}"] for e in (0.05, 0.5, 0.95)]
    assert a[0] < a[1] < a[2]
    assert a[0] == pytest.approx(46.0, abs=2.5)
    assert a[2] == pytest.approx(69.0, abs=2.5)
    for e in (0.05, 0.5, 0.95):
        assert res[f"adv=0.2H,eps={e}"] == pytest.approx(55.0, abs=1.5)
