"""Measures of the Turek & Hron (2006) benchmarks' periodic cases (FSI2, CFD3): each signal
of the periodic state is given as ``mean +- amplitude`` at a frequency, with
``mean = (max + min) / 2`` and ``amplitude = (max - min) / 2`` over the last periods."""

from __future__ import annotations

import numpy as np

from fsi_sph.output import read_probe
from validation.oscillating_plate import crossing_times


def oscillation(t, y):
    """``(mean, amplitude, frequency)`` of a periodic signal as the benchmark defines them:
    ``(max + min) / 2``, ``(max - min) / 2``, and 1 / the mean period between the upward
    crossings of the mean (``nan`` with fewer than two crossings)."""
    hi, lo = float(np.max(y)), float(np.min(y))
    mean = 0.5 * (hi + lo)
    ups = crossing_times(t, y - mean, upward=True)
    freq = (len(ups) - 1) / (ups[-1] - ups[0]) if len(ups) >= 2 else float("nan")
    return mean, 0.5 * (hi - lo), float(freq)


def body_force(run_file, probes):
    """Time, drag and lift (N/m): the sum of the force probes ``probes``."""
    fx = fy = 0.0
    for name in probes:
        t, f = read_probe(run_file, name)
        fx, fy = fx + f["fx"], fy + f["fy"]
    return t, fx, fy


def _pct(value, ref):
    return 100.0 * (value - ref) / abs(ref)


def periodic_errors(t, signals, ref, window):
    """Errors (signed %) and values of each signal of ``signals`` (``{key: series}``, keys
    ``"<name>_<unit>"``) over the last ``window`` seconds against ``ref``
    (``{key: (mean, amplitude, frequency or None)}``). A mean much smaller than its
    amplitude (a flag's u_y, a lift) has no meaningful % and is a value only; a signal that
    does not cross its mean twice has the frequency error 1000 %."""
    late = t >= t[-1] - window
    errors, values = {}, {"window_s": window, "t_end_s": float(t[-1])}
    for key, (r_mean, r_amp, r_freq) in ref.items():
        mean, amp, freq = oscillation(t[late], signals[key][late])
        name = key.split("_")[0]
        values.update({f"{key}_mean": mean, f"{key}_amplitude": amp,
                       f"{name}_frequency_Hz": freq})
        if abs(r_mean) > 0.1 * r_amp:
            errors[f"{name}_mean_pct"] = _pct(mean, r_mean)
        errors[f"{name}_amplitude_pct"] = _pct(amp, r_amp)
        if r_freq is not None:
            errors[f"{name}_frequency_pct"] = _pct(freq, r_freq) if np.isfinite(freq) else 1e3
    return errors, values
