"""Schaefer & Turek (1996) benchmark 2D-1: steady flow at Re = 20 past a cylinder in a
channel (cases/schafer_turek_2d1.toml).

Reference (Schaefer, M. & Turek, S. (1996), Benchmark computations of laminar flow around a
cylinder, in Flow Simulation with High-Performance Computers II, Notes on Numerical Fluid
Mechanics 52, 547-566; the benchmark's reference values, rho = 1, scaled here to
rho = 1000): drag coefficient 5.5795 (the paper's band 5.57-5.59), i.e. 11.159 N/m; lift
coefficient 0.0106 (0.0104-0.0110), 0.0212 N/m; pressure difference between the cylinder's
front and back points (0.15, 0.2) and (0.25, 0.2) 0.11752 (0.1172-0.1176), 117.52 Pa.

Measured: the ``cylinder_force`` probe (the fluid's pressure and viscous pair forces on the
cylinder's wall particles, as for Turek-Hron) and the ``p_front`` / ``p_back`` probes
(Shepard-interpolated over fluid and wall particles at the two points), averaged over the
last ``WINDOW`` seconds (up to the run's shortened last steps); ``errors.drag_mean_pct`` and
``errors.dp_pct`` signed %. The lift (0.2 % of the drag) is reported, not scored: the force's
step-to-step noise is larger. Ladder D / dx = 10 / 20; ``--quick`` runs the first.

The case isolates the round body and its no-slip wall in a through-flow from the flag of the
Turek-Hron cases (docs/validation/schafer_turek_2d1.md).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from validation.common import ladder_result
from validation.turek_hron_measures import probe_before_landing

CASE = Path(__file__).resolve().parents[1] / "cases" / "schafer_turek_2d1.toml"
LADDER = [0.01, 0.005]   # m; D / dx = 10, 20
QUICK = [0.01]
DRAG, LIFT, DP = 11.159, 0.0212, 117.52  # N/m, N/m, Pa (rho = 1000)
WINDOW = 3.0  # s: the last three seconds are averaged (the drag is steady from about 2 s)


def measure(sim, run_file):
    t, f = probe_before_landing(run_file, "cylinder_force")
    late = t >= t[-1] - WINDOW
    _, front = probe_before_landing(run_file, "p_front")
    _, back = probe_before_landing(run_file, "p_back")
    drag = float(np.mean(f["fx"][late]))
    dp = float(np.mean(front["p"][late] - back["p"][late]))
    viscous = float(np.mean(f["fx_viscous"][late]))
    errors = {"drag_mean_pct": 100.0 * (drag - DRAG) / DRAG,
              "dp_pct": 100.0 * (dp - DP) / DP}
    values = {"drag_N_per_m": drag, "drag_std_N_per_m": float(np.std(f["fx"][late])),
              "drag_viscous_N_per_m": viscous, "drag_pressure_N_per_m": drag - viscous,
              "lift_N_per_m": float(np.mean(f["fy"][late])),
              "lift_std_N_per_m": float(np.std(f["fy"][late])),
              "dp_Pa": dp, "dp_std_Pa": float(np.std(front["p"][late] - back["p"][late])),
              "window_s": WINDOW, "t_end_s": float(t[-1])}
    return errors, values


REFERENCE = ("Schaefer & Turek 1996, 2D-1 (Re = 20): drag 11.159 N/m (c_D 5.5795), lift "
             "0.0212 N/m, front-back pressure difference 117.52 Pa (rho = 1000)")


def validate(quick, data_dir, out_dir):
    ladder = QUICK if quick else LADDER
    return ladder_result("schafer_turek_2d1", REFERENCE, CASE, ladder, out_dir, measure,
                         ["case.output_every=1.0"])
