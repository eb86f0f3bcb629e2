"""Measurements of the column-collapse validation (validation/column_collapse.py) on
configurations with a known answer."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from validation.column_collapse import (  # noqa: E402
    contour_toe,
    deposit_height,
    failure_line,
    line_angle_deg,
    onset_sensitivity,
    static_bounds,
    surface_rms_mm,
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


def _lattice(dx, length=0.2, height=0.1):
    xs, ys = np.meshgrid(np.arange(dx / 2, length, dx), np.arange(dx / 2, height, dx))
    return np.column_stack([xs.ravel(), ys.ravel()])


@pytest.mark.parametrize("angle", [0.0, 32.9, 45.0, 80.0])
def test_line_angle_of_noisy_points_on_a_line(angle):
    """Points scattered about a line at ``angle``: the orthogonal fit finds the angle (a fit of
    y on x would be biased towards flat for the steep line)."""
    rng = np.random.default_rng(3)
    s = np.linspace(0.0, 0.2, 40)
    a = math.radians(angle)
    pts = np.column_stack([0.18 - s * math.cos(a), s * math.sin(a)])
    pts += rng.normal(0.0, 1e-4, pts.shape)
    assert line_angle_deg(pts) == pytest.approx(angle, abs=0.2)


def test_deposit_height_and_contour_toe_of_a_wedge():
    """A deposit filling the triangle under y = 0.1 (1 - x / 0.4): the volume-equivalent height
    follows the line within a particle's height, and the 2 mm contour lies where the line is
    2 mm high (x = 0.392) to within two spacings (the lattice's last layer, one particle
    = 2 mm high, reaches x = 0.396); the surface RMS against the line is below dx."""
    dx = 0.002
    x = _lattice(dx, 0.4, 0.1)
    x = x[x[:, 1] < 0.1 * (1.0 - x[:, 0] / 0.4)]
    xs = np.array([0.001, 0.05, 0.1, 0.2, 0.3])
    assert np.allclose(deposit_height(x, dx, xs), 0.1 * (1.0 - xs / 0.4), atol=dx)
    assert contour_toe(x, dx) == pytest.approx(0.4 * (1.0 - 0.02), abs=2 * dx)
    surf = np.column_stack([xs, 0.1 * (1.0 - xs / 0.4)])
    assert surface_rms_mm(x, dx, surf) < 1e3 * dx
    # the same deposit shifted 1 cm down the floor: its toe moves by 1 cm, the RMS grows
    x2 = x + [0.01, 0.0]
    assert contour_toe(x2, dx) - contour_toe(x, dx) == pytest.approx(0.01, abs=0.5 * dx)
    assert surface_rms_mm(x2, dx, surf[1:]) > 2.0


def test_contour_toe_ignores_a_thin_spray():
    """A column with a one-particle layer 1 mm high running ahead: the toe at the 2 mm contour
    is the column's, not the layer's end."""
    dx = 0.001
    x = _lattice(dx, 0.1, 0.05)
    layer = np.column_stack([np.arange(0.1005, 0.3, dx), np.full(200, 0.0005)])
    assert contour_toe(np.vstack([x, layer]), dx) == pytest.approx(0.1, abs=2 * dx)
