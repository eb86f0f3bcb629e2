"""Limit equilibrium (fsi_sph/soil/limit_equilibrium.py): Bishop's simplified method and the
infinite slope on cases checked by hand."""

import math

import pytest

from fsi_sph.soil.limit_equilibrium import (
    bishop_fos,
    critical_circle,
    infinite_slope_fos,
    slip_mass,
)

GAMMA = 20.0e3
C = 20.0e3
H = 10.0
# vertical cut of height H, soil on the left of x = 50, floor far below the toe
CUT = [(0.0, H), (50.0, H), (50.0 + 1e-9, 0.0), (80.0, 0.0)]  # rigid floor at the toe level


def test_quarter_circle_by_hand():
    """phi = 0, centre at the crest edge (50, H), R = H through the toe: the slip mass is a
    quarter disc, driving moment gamma H^3/3, resisting c (pi H/2) H, so
    F = 3 pi c/(2 gamma H)."""
    F = bishop_fos(CUT, 50.0, H, H, C, 0.0, GAMMA, x_wall=-1e3, y_floor=-1e3, n_slices=400)
    assert F == pytest.approx(3 * math.pi * C / (2 * GAMMA * H), rel=2e-4)


def test_taylor_vertical_cut():
    """Critical toe circle of a vertical cut in phi = 0 soil: H_c = 3.83 c/gamma (Taylor's
    stability number 0.261), i.e. F = 3.83 c/(gamma H)."""
    circ = critical_circle(CUT, C, 0.0, GAMMA, x_wall=0.0, y_floor=0.0, n_centres=16,
                           n_radii=10)
    assert circ.fos == pytest.approx(3.83 * C / (GAMMA * H), rel=0.005)
    assert circ.x_exit == pytest.approx(50.0, abs=0.05)  # through the toe


def test_bishop_not_below_fellenius_with_friction():
    """With phi > 0 Bishop's F exceeds the ordinary (Fellenius) method's on the same circle."""
    slope = [(0.0, 10.0), (5.0, 10.0), (15.0, 0.0), (20.0, 0.0)]
    xc, yc, R = 14.0, 18.0, 16.0
    F, s = bishop_fos(slope, xc, yc, R, 11e3, 20.0, 2100 * 9.81, return_slices=True)
    cos_a = [math.sqrt(1 - v * v) for v in s["sin_a"]]
    fell = sum(11e3 * b / ca + W * ca * math.tan(math.radians(20.0))
               for b, W, ca in zip(s["b"], s["W"], cos_a, strict=True)) / sum(W * sa for W, sa in
                                                                  zip(s["W"], s["sin_a"], strict=True))
    assert F > fell > 0.5


def test_infinite_slope_by_hand():
    """c = 0: tan(phi)/tan(beta) at any depth (0.364 for slope 1 of [S 5-5]); with c the
    cohesive share c/(gamma z sin(beta) cos(beta)) is added."""
    assert infinite_slope_fos(20.0, 45.0, depth=3.0) == pytest.approx(
        math.tan(math.radians(20.0)), rel=1e-12)
    assert infinite_slope_fos(30.0, 20.0, 5e3, 2e4, 2.0) == pytest.approx(
        math.tan(math.radians(30.0)) / math.tan(math.radians(20.0))
        + 5e3 / (2e4 * 2.0 * math.sin(math.radians(20.0)) * math.cos(math.radians(20.0))),
        rel=1e-12)


def test_cohesionless_critical_circle_tends_to_the_infinite_slope():
    """c = 0: the critical circle is the shallowest admitted one and its F tends to
    tan(phi)/tan(beta) from above (slope 1 of [S 5-5], circles at least 5 % of H deep)."""
    slope = [(0.0, 1.0), (1.0, 1.0), (2.0, 0.0), (3.5, 0.0)]
    circ = critical_circle(slope, 0.0, 20.0, 2080 * 9.81, n_centres=10, n_radii=8,
                           n_starts=2)
    f_inf = infinite_slope_fos(20.0, 45.0)
    assert f_inf < circ.fos < 1.03 * f_inf


def test_griffiths_lane_example_1_against_the_charts():
    """The 2:1 slope of Griffiths & Lane (1999), example 1 (phi' = 20 deg, c'/(gamma H) = 0.05,
    rigid base at the toe level): Bishop & Morgenstern's (1960) charts give 1.380 (quoted by
    Griffiths & Lane); the package's Bishop with its circle search on the validation case's
    profile lands within 0.5 % of it."""
    H, gamma = 10.0, 20.0e3
    slope = [(0.0, H), (1.2 * H, H), (3.2 * H, 0.0), (5.2 * H, 0.0)]
    circ = critical_circle(slope, 0.05 * gamma * H, 20.0, gamma, x_wall=0.0, y_floor=0.0)
    assert circ.fos == pytest.approx(1.380, rel=0.005)


def test_a_circle_over_the_toe_moves_the_soil_beyond_it():
    """Slope 3's profile, a circle centred at (22, 19) passing 1 cm over the toe (20, 5): it
    dips under the layer's surface beyond the toe and comes out at x = 22 + sqrt(R^2 - 14^2)
    (about 23.9). The slip mass reaches there: the soil inside the circle moves with it.
    Cut short before the toe it left out ~4 m of base through the layer, and the search found
    slope 3's critical circle in that gap (0.897 instead of 0.901)."""
    layer = [(0.0, 15.0), (10.0, 15.0), (20.0, 5.0), (45.0, 5.0)]
    R = math.hypot(2.0, 14.0) - 0.01
    xe, xx = slip_mass(layer, 22.0, 19.0, R, x_wall=0.0, y_floor=0.0)
    assert xx == pytest.approx(22.0 + math.sqrt(R * R - 14.0**2), abs=1e-3)
    assert xe == pytest.approx(22.0 - math.sqrt(R * R - 4.0**2), abs=1e-3)  # enters the crest
