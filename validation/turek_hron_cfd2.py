"""Turek & Hron (2006) CFD2: steady flow at Re = 100 past a cylinder with a rigid flag
(cases/turek_hron_cfd2.toml).

Reference (Turek & Hron 2006, the benchmark's table for CFD2): drag 136.7 N/m and lift
10.53 N/m on the cylinder and the flag together. Measured: the ``body_force`` probe (the
fluid's pressure and viscous pair forces on the wall particles of the cylinder and flag),
averaged over the last second of the run (up to the run's shortened last steps:
``turek_hron_measures.landing_start``); its standard deviation over that second says how
steady the SPH flow is. ``errors.drag_mean_pct`` and ``errors.lift_mean_pct`` are signed %.
The ladder is D / dx = 10 / 20 (dx 0.01 / 0.005 m); ``--quick`` runs the first.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from validation.common import ladder_result
from validation.turek_hron_measures import probe_before_landing

CASE = Path(__file__).resolve().parents[1] / "cases" / "turek_hron_cfd2.toml"
LADDER = [0.01, 0.005]   # m; D / dx = 10, 20
QUICK = [0.01]
DRAG, LIFT = 136.7, 10.53  # N/m (Turek & Hron 2006, CFD2)
WINDOW = 1.0  # s: the last second of the run is averaged


def measure(sim, run_file):
    t, f = probe_before_landing(run_file, "body_force")
    late = t >= t[-1] - WINDOW
    drag, lift = float(np.mean(f["fx"][late])), float(np.mean(f["fy"][late]))
    viscous = float(np.mean(f["fx_viscous"][late]))  # skin friction; the rest is pressure
    _, c = probe_before_landing(run_file, "cylinder_force")
    errors = {"drag_mean_pct": 100.0 * (drag - DRAG) / DRAG,
              "lift_mean_pct": 100.0 * (lift - LIFT) / LIFT}
    values = {"drag_N_per_m": drag, "lift_N_per_m": lift,
              "drag_std_N_per_m": float(np.std(f["fx"][late])),
              "lift_std_N_per_m": float(np.std(f["fy"][late])),
              "drag_viscous_N_per_m": viscous, "drag_pressure_N_per_m": drag - viscous,
              "cylinder_drag_N_per_m": float(np.mean(c["fx"][late])),
              "cylinder_lift_N_per_m": float(np.mean(c["fy"][late])),
              "window_s": WINDOW, "t_end_s": float(t[-1])}
    return errors, values


REFERENCE = "Turek & Hron 2006 CFD2: drag 136.7 N/m, lift 10.53 N/m (cylinder and flag)"


def validate(quick, data_dir, out_dir):
    ladder = QUICK if quick else LADDER
    return ladder_result("turek_hron_cfd2", REFERENCE, CASE, ladder, out_dir, measure,
                         ["case.output_every=1.0"])
