"""The Turek & Hron validations' measures (validation/turek_hron_measures.py) on signals with a known
answer: the benchmark's mean, amplitude and frequency."""

import numpy as np
import pytest

from validation.turek_hron_measures import oscillation


def test_mean_amplitude_and_frequency_of_a_sine():
    t = np.linspace(7.0, 10.0, 3001)
    y = 1.23 + 80.6 * np.sin(2 * np.pi * 2.0 * t + 0.3)
    mean, amp, freq = oscillation(t, y)
    assert mean == pytest.approx(1.23, abs=1e-3)
    assert amp == pytest.approx(80.6, rel=1e-5)
    assert freq == pytest.approx(2.0, rel=1e-6)


def test_mean_is_halfway_between_the_extremes_not_the_average():
    """The benchmark's mean is (max + min) / 2: for a skewed signal it differs from the time
    average."""
    t = np.linspace(0.0, 3.0, 30001)
    y = np.sin(2 * np.pi * 3.8 * t) + 0.5 * np.cos(2 * np.pi * 7.6 * t)  # max 0.75, min -1.5
    mean, amp, freq = oscillation(t, y)
    assert mean == pytest.approx(0.5 * (y.max() + y.min()), abs=1e-12)
    assert mean == pytest.approx(-0.375, abs=1e-4)
    assert abs(mean - y.mean()) > 0.3
    assert amp == pytest.approx(0.5 * (y.max() - y.min()), abs=1e-12)
    assert freq == pytest.approx(3.8, rel=1e-3)


def test_a_signal_without_two_crossings_has_no_frequency():
    t = np.linspace(0.0, 1.0, 101)
    assert np.isnan(oscillation(t, t)[2])


def test_periodic_errors_against_a_reference():
    """A lift 10 % too large at the right frequency, over the last 2 s of a run whose first
    second is a start-up that the window leaves out; a mean near zero is a value only."""
    from validation.turek_hron_measures import periodic_errors

    t = np.linspace(0.0, 3.0, 6001)
    lift = 1.1 * 437.81 * np.sin(2 * np.pi * 4.3956 * t) - 11.893
    lift[t < 1.0] *= 5.0  # a start-up transient outside the window
    drag = 439.45 + 5.6183 * np.cos(2 * np.pi * 2 * 4.3956 * t)
    ref = {"drag_N_per_m": (439.45, 5.6183, None), "lift_N_per_m": (-11.893, 437.81, 4.3956)}
    errors, values = periodic_errors(t, {"drag_N_per_m": drag, "lift_N_per_m": lift}, ref, 2.0)
    assert errors["lift_amplitude_pct"] == pytest.approx(10.0, abs=1e-3)
    assert errors["lift_frequency_pct"] == pytest.approx(0.0, abs=1e-2)  # crossings interpolated
    assert "lift_mean_pct" not in errors
    assert values["lift_N_per_m_mean"] == pytest.approx(-11.893, abs=1e-2)
    assert errors["drag_mean_pct"] == pytest.approx(0.0, abs=1e-4)
    assert errors["drag_amplitude_pct"] == pytest.approx(0.0, abs=1e-2)  # peaks between samples
    assert "drag_frequency_pct" not in errors
