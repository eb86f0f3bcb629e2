"""Measurements of the dam-break validation (validation/dam_break.py) on curves with a known
answer: the onset-corrected front error and the front speed."""

import numpy as np
import pytest

from validation.dam_break import ONSET_SHIFT_T, front_errors, front_speed, speed_comparison


def _data():
    """An 'experiment' whose clock runs ONSET_SHIFT_T ahead of the water: Z = 1 + 2 (T - shift)
    beside our Z = 1 + 2 T."""
    T = np.linspace(0.3, 2.3, 15)
    return {"exp": (T, 1.0 + 2.0 * (T - ONSET_SHIFT_T))}


def test_onset_shift_is_the_published_correction():
    """0.175 in t sqrt(2 g / a) is 0.175 / sqrt(2) in T = t sqrt(g / a)."""
    assert ONSET_SHIFT_T == pytest.approx(0.1237, abs=1e-4)


def test_onset_corrected_error_vanishes_for_an_early_clock():
    T_sim = np.linspace(0.0, 3.0, 301)
    Z_sim = 1.0 + 2.0 * T_sim
    plain = front_errors(T_sim, Z_sim, _data())
    onset = front_errors(T_sim, Z_sim, _data(), ONSET_SHIFT_T, "_onset")
    assert onset["front_pct_exp_onset"] == pytest.approx(0.0, abs=1e-9)
    # without the correction the simulated front leads: 2 shift / Z at the first point
    z_exp0 = 1.0 + 2.0 * (0.3 - ONSET_SHIFT_T)
    assert plain["front_pct_exp"] == pytest.approx(100 * 2 * ONSET_SHIFT_T / z_exp0, rel=1e-9)
    assert "front_pct" in plain and "front_pct" not in onset


def test_front_speed_is_the_slope_over_the_range():
    T = np.round(np.linspace(0.0, 3.0, 61), 12)  # samples symmetric about T = 1.9
    Z = 1.0 + 0.5 * T**2  # dZ/dT = T: mean slope over [1.5, 2.3] is 1.9
    assert front_speed(T, Z) == pytest.approx(1.9, rel=1e-6)
    assert np.isnan(front_speed(T[:3], Z[:3]))
    err, val = speed_comparison(T, Z, {"exp": (T, 1.0 + 2.0 * T)})
    assert val["front_speed_exp"] == pytest.approx(2.0)
    assert err["front_speed_pct_exp"] == pytest.approx(-5.0, rel=1e-6)
