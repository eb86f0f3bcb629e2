"""Measures of the Turek & Hron (2006) benchmarks' periodic cases (FSI2, CFD3): each signal
of the periodic state is given as ``mean +- amplitude`` at a frequency, with
``mean = (max + min) / 2`` and ``amplitude = (max - min) / 2`` over the last periods.

A force signal of SPH carries noise far above the flow's frequencies (FSI2: +-100-150 N/m at
15-20 Hz on a lift of +-230 N/m at 2 Hz), and max and min read the noise. Such signals are
measured after a zero-phase low-pass filter (``lowpass``: the signal resampled on a uniform
grid, a 4th-order Butterworth filter run forwards and backwards) whose cut-off each
validation states in its record, five times the case's fundamental frequency: the 2nd-4th
harmonics pass, the noise does not. Not in PHYSICS.md (a measure, not physics)."""

from __future__ import annotations

import math

import numpy as np

from fsi_sph.output import read_probe, read_steps


def cycle_starts(t, y, band):
    """Times where ``y`` crosses 0 upwards (linearly interpolated), counting a crossing only
    if ``y`` went below ``-band`` since the last one counted: a wiggle of a higher harmonic
    about the mean does not start a cycle (a Schmitt trigger)."""
    times, armed = [], False
    for k in range(len(y) - 1):
        armed = armed or y[k] < -band
        if armed and y[k] < 0.0 <= y[k + 1]:
            times.append(t[k] - y[k] * (t[k + 1] - t[k]) / (y[k + 1] - y[k]))
            armed = False
    return np.asarray(times)


def oscillation(t, y):
    """``(mean, amplitude, frequency)`` of a periodic signal as the benchmark defines them:
    ``(max + min) / 2``, ``(max - min) / 2``, and 1 / the mean period between the upward
    crossings of the mean that follow a swing below half the amplitude (``cycle_starts``;
    ``nan`` with fewer than two such crossings)."""
    hi, lo = float(np.max(y)), float(np.min(y))
    mean = 0.5 * (hi + lo)
    ups = cycle_starts(t, y - mean, 0.25 * (hi - lo))
    freq = (len(ups) - 1) / (ups[-1] - ups[0]) if len(ups) >= 2 else float("nan")
    return mean, 0.5 * (hi - lo), float(freq)


def lowpass(t, y, cutoff_hz, order=4):
    """``(t_u, y_f)``: ``y(t)`` linearly resampled on a uniform grid (the median sample
    spacing; probes are written at the first step past each probe time, so their spacing
    varies by a step) and filtered forwards and backwards by a Butterworth low-pass of
    ``order`` at ``cutoff_hz`` (no phase shift; the gain at the cut-off is 1/2)."""
    from scipy.signal import butter, sosfiltfilt

    h = float(np.median(np.diff(t)))
    t_u = np.arange(t[0], t[-1] + 0.5 * h, h)
    t_u = t_u[t_u <= t[-1]]
    sos = butter(order, cutoff_hz, fs=1.0 / h, output="sos")
    return t_u, sosfiltfilt(sos, np.interp(t_u, t, y))


def landing_start(run_file):
    """The time where a run's last steps start to be shortened to land on its end (the time
    left split in two equal steps, or the last step cut: ``Simulation.step``), or ``inf``.
    The pressure of a projection answers the divergence left over from the last step over
    ``dt``, so a step suddenly shorter carries a force spike (FSI2 at D/dx = 20: the lift
    -228 -> -832 N/m, the drag 150 -> 358 N/m on the final step at 0.6 dt): measures stop
    before it."""
    steps = read_steps(run_file)
    if len(steps.get("t", ())) < 3:
        return math.inf
    t, dt = steps["t"][-3:], steps["dt"][-3:]
    if abs(dt[-1] - dt[-2]) <= 1e-9 * dt[-2] and dt[-2] < 0.99 * dt[-3]:  # split in two
        return float(t[-2] - dt[-2])
    if dt[-1] < 0.99 * dt[-2]:  # the last step alone cut short
        return float(t[-1] - dt[-1])
    return math.inf


def probe_before_landing(run_file, name):
    """``read_probe`` without the samples of the run's shortened last steps
    (``landing_start``)."""
    t, cols = read_probe(run_file, name)
    keep = t < landing_start(run_file) - 1e-12
    return t[keep], {k: v[keep] for k, v in cols.items()}


def body_force(run_file, probes):
    """Time, drag and lift (N/m): the sum of the force probes ``probes``, without the samples
    of the run's shortened last steps (``landing_start``)."""
    fx = fy = 0.0
    for name in probes:
        t, f = probe_before_landing(run_file, name)
        fx, fy = fx + f["fx"], fy + f["fy"]
    return t, fx, fy


def _pct(value, ref):
    return 100.0 * (value - ref) / abs(ref)


def periodic_errors(t, signals, ref, window, lowpass_hz=None):
    """Errors (signed %) and values of each signal of ``signals`` (``{key: series}``, keys
    ``"<name>_<unit>"``) over the last ``window`` seconds against ``ref``
    (``{key: (mean, amplitude, frequency or None)}``). The signals named in ``lowpass_hz``
    (``{key: cut-off in Hz}``) are measured after ``lowpass`` over the whole run (so that the
    filter's start-up lies outside the window); the cut-off is recorded. A mean much smaller
    than its amplitude (a flag's u_y, a lift) has no meaningful % and is a value only; a
    signal that does not cross its mean twice has the frequency error 1000 %."""
    lowpass_hz = lowpass_hz or {}
    errors, values = {}, {"window_s": window, "t_end_s": float(t[-1])}
    for key, (r_mean, r_amp, r_freq) in ref.items():
        name = key.split("_")[0]
        ts, ys = t, signals[key]
        if key in lowpass_hz:
            ts, ys = lowpass(t, ys, lowpass_hz[key])
            values[f"{name}_lowpass_Hz"] = lowpass_hz[key]
        late = ts >= ts[-1] - window
        mean, amp, freq = oscillation(ts[late], ys[late])
        values.update({f"{key}_mean": mean, f"{key}_amplitude": amp,
                       f"{name}_frequency_Hz": freq})
        if abs(r_mean) > 0.1 * r_amp:
            errors[f"{name}_mean_pct"] = _pct(mean, r_mean)
        errors[f"{name}_amplitude_pct"] = _pct(amp, r_amp)
        if r_freq is not None:
            errors[f"{name}_frequency_pct"] = _pct(freq, r_freq) if np.isfinite(freq) else 1e3
    return errors, values
