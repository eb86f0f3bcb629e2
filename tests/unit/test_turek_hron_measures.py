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


def _noisy_lift(t):
    """A lift of 234.2 N/m at 2 Hz with its 3rd harmonic, and noise of +-150 N/m at 17-19 Hz
    as the SPH force carries."""
    clean = 0.88 + 234.2 * np.sin(2 * np.pi * 2.0 * t) + 30.0 * np.sin(2 * np.pi * 6.0 * t)
    noise = 90.0 * np.sin(2 * np.pi * 17.0 * t + 1.0) + 60.0 * np.sin(2 * np.pi * 19.3 * t)
    return clean, clean + noise


def test_lowpass_removes_the_noise_and_keeps_the_harmonics():
    """Samples at irregular times (a probe written at the first step past each probe time):
    the filtered signal matches the clean one away from the ends, with no phase shift."""
    rng = np.random.default_rng(3)
    t = np.cumsum(0.005 + 0.001 * rng.random(3000))
    clean, noisy = _noisy_lift(t)
    from validation.turek_hron_measures import lowpass

    t_u, y_f = lowpass(t, noisy, 10.0)
    inner = (t_u > t_u[0] + 1.0) & (t_u < t_u[-1] - 1.0)
    ref = np.interp(t_u, t, clean)
    assert np.max(np.abs(y_f - ref)[inner]) < 0.05 * 234.2
    assert np.max(np.abs(np.interp(t_u, t, noisy) - ref)[inner]) > 0.5 * 234.2


def test_periodic_errors_of_a_filtered_force():
    """The benchmark's (max - min) / 2 of the noisy lift reads the noise (+50 % and more);
    filtered at 10 Hz it reads the lift's own amplitude, and the cut-off is recorded."""
    from validation.turek_hron_measures import oscillation, periodic_errors

    t = np.linspace(0.0, 10.0, 2001)
    clean, noisy = _noisy_lift(t)
    ref = {"lift_N_per_m": (0.88, 234.2, 2.0)}
    late = t >= 7.0
    amp_clean = oscillation(t[late], clean[late])[1]
    raw, _ = periodic_errors(t, {"lift_N_per_m": noisy}, ref, 3.0)
    filtered, values = periodic_errors(t, {"lift_N_per_m": noisy}, ref, 3.0,
                                       lowpass_hz={"lift_N_per_m": 10.0})
    assert raw["lift_amplitude_pct"] > 50.0
    assert values["lift_lowpass_Hz"] == 10.0
    assert values["lift_N_per_m_amplitude"] == pytest.approx(amp_clean, rel=0.02)
    assert filtered["lift_frequency_pct"] == pytest.approx(0.0, abs=0.5)


def test_a_harmonic_wiggling_about_the_mean_does_not_start_a_cycle():
    """A 2 Hz signal with a strong 6 Hz harmonic crosses its mean three times upwards per
    period; the frequency is still 2 Hz."""
    t = np.linspace(0.0, 3.0, 6001)
    y = np.sin(2 * np.pi * 2.0 * t) - 0.8 * np.sin(2 * np.pi * 6.0 * t)
    from validation.oscillating_plate import crossing_times

    assert len(crossing_times(t, y, upward=True)) > 10  # the plain count is wrong
    assert oscillation(t, y)[2] == pytest.approx(2.0, rel=1e-3)


def _steps_file(path, dts):
    import json

    import h5py

    t = np.cumsum(dts)
    with h5py.File(path, "w") as f:
        d = f.create_dataset("steps", data=np.column_stack([t, dts, np.zeros_like(t)]))
        d.attrs["columns"] = json.dumps(["t", "dt", "n_sub"])
    return t


@pytest.mark.parametrize("tail, first_short", [([1e-3, 0.6e-3, 0.6e-3], 4),
                                               ([1e-3, 1e-3, 0.2e-3], 5),
                                               ([1e-3, 0.999e-3, 0.998e-3], None)])
def test_landing_start_finds_the_shortened_last_steps(tmp_path, tail, first_short):
    """The run's end split in two equal steps, a last step cut short, or no landing (dt
    drifting by 0.1 % a step): the measures stop where the first short step starts."""
    from validation.turek_hron_measures import landing_start

    dts = np.array([1.02e-3, 1.01e-3, 1.0e-3, *tail])
    t = _steps_file(tmp_path / "run.h5", dts)
    start = landing_start(tmp_path / "run.h5")
    if first_short is None:
        assert start == np.inf
    else:
        assert start == pytest.approx(t[first_short - 1], abs=1e-15)


def test_a_run_without_a_step_table_has_no_landing(tmp_path):
    import h5py

    from fsi_sph.output import read_steps
    from validation.turek_hron_measures import landing_start

    with h5py.File(tmp_path / "run.h5", "w") as f:
        f.create_group("probes")
    assert read_steps(tmp_path / "run.h5") == {}
    assert landing_start(tmp_path / "run.h5") == np.inf
