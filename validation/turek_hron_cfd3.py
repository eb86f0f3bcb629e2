"""Turek & Hron (2006) CFD3: periodic flow at Re = 200 past a cylinder with a rigid flag
(cases/turek_hron_cfd3.toml): the wake sheds vortices and the force on the body oscillates.

Reference (Turek & Hron 2006, the benchmark's table for CFD3, periodic state,
``mean +- amplitude``): drag ``439.45 +- 5.6183 N/m``, lift ``-11.893 +- 437.81 N/m`` at
4.3956 Hz, on the cylinder and the flag together (the ``body_force`` probe). Measured over the
last ``WINDOW`` seconds after a low-pass filter at ``LOWPASS_HZ``
(validation/turek_hron_measures.py); errors are signed %. The ladder
is D / dx = 10 / 20 (dx 0.01 / 0.005 m); ``--quick`` runs the first.
"""

from __future__ import annotations

from pathlib import Path

from validation.common import ladder_result
from validation.turek_hron_measures import body_force, periodic_errors

CASE = Path(__file__).resolve().parents[1] / "cases" / "turek_hron_cfd3.toml"
LADDER = [0.01, 0.005]   # m; D / dx = 10, 20
QUICK = [0.01]
WINDOW = 2.0             # s: about 9 shedding periods
#: the forces' low-pass cut-off: five times the shedding frequency (turek_hron_measures.lowpass)
LOWPASS_HZ = {"drag_N_per_m": 22.0, "lift_N_per_m": 22.0}
#: (mean, amplitude, frequency in Hz)
REF = {"drag_N_per_m": (439.45, 5.6183, None), "lift_N_per_m": (-11.893, 437.81, 4.3956)}
REFERENCE = ("Turek & Hron 2006 CFD3: drag 439.45 +- 5.6183 N/m, lift -11.893 +- 437.81 N/m "
             "at 4.3956 Hz (cylinder and flag)")


def measure(sim, run_file):
    t, drag, lift = body_force(run_file, ("body_force",))
    return periodic_errors(t, {"drag_N_per_m": drag, "lift_N_per_m": lift}, REF, WINDOW,
                           LOWPASS_HZ)


def validate(quick, data_dir, out_dir):
    ladder = QUICK if quick else LADDER
    return ladder_result("turek_hron_cfd3", REFERENCE, CASE, ladder, out_dir, measure,
                         ["case.output_every=1.0"])
