"""Oscillating cantilever plate (PHYSICS §8, [F 49-50]) against thin-plate theory.

A plate of free length L = 0.2 m, thickness 0.02 m, clamped over x < 0, starts with the
velocity of its first bending mode. Reference (analytic): period T c0 / L = 72.39 and first
peak amplitude A / L = 0.115, c0 = sqrt(K / rho). Measured from the tip probe: the period
is the time of the first upward zero crossing of the tip's vertical displacement (the end of
the first cycle), the amplitude its first maximum.

Thin-plate theory neglects shear and rotary inertia; ``validation/plate_fem.py`` computes the
plane-strain 2D-elasticity period of the same plate by finite elements (T c0/L = 72.77, 0.5 %
longer), which a converged SPH solution should approach. Both errors are reported:
``period_pct`` against thin-plate theory (the issue's measure) and ``values.period_vs_2d_pct``.

Ladder: 5, 10, 20 and 40 particles through the thickness (dx = 4, 2, 1, 0.5 mm; the finest
takes about 13 minutes on 2 cores); ``--quick`` runs the coarse two.
"""

from __future__ import annotations

import math

import numpy as np

from validation.common import CASES, machine, make_record, run_case, write_outputs
from validation.plate_fem import converged_period

CASE = CASES / "oscillating_plate.toml"
L, K, RHO = 0.2, 3.25e6, 1000.0
REF_PERIOD = 72.39  # T c0 / L
REF_AMPLITUDE = 0.115  # A / L
LADDER = [("5 / thickness", 0.004), ("10 / thickness", 0.002), ("20 / thickness", 0.001),
          ("40 / thickness", 0.0005)]
#: errors reported by other codes (PHYSICS §8), drawn on the error-vs-time plot
MARKS = {"source paper": {"period_pct": 2.36, "amplitude_pct": 3.48},
         "earlier SPH (best)": {"period_pct": 12.0, "amplitude_pct": 8.0}}


def crossing_times(t, y, upward):
    """Linear-interpolated times where ``y`` crosses 0 (upward or downward)."""
    s = np.sign(y)
    if upward:
        k = np.flatnonzero((s[:-1] < 0) & (s[1:] >= 0))
    else:
        k = np.flatnonzero((s[:-1] > 0) & (s[1:] <= 0))
    return t[k] - y[k] * (t[k + 1] - t[k]) / (y[k + 1] - y[k])


def measure(t, uy):
    """(T c0 / L, A / L) from the tip displacement series."""
    c0 = math.sqrt(K / RHO)
    ups = crossing_times(t, uy, upward=True)
    ups = ups[ups > 1e-9]
    if len(ups) == 0:
        raise RuntimeError("the tip never completed a cycle: run longer")
    period = float(ups[0])
    first_half = t <= period / 2 + 1e-12
    amp = float(np.max(uy[first_half]))
    return period * c0 / L, amp / L


def validate(quick=False, data_dir=None, out_dir="validation/results/oscillating_plate"):
    """Run the ladder; returns the record dict (data_dir unused: the reference is analytic)."""
    from fsi_sph.output import read_probe

    ladder = LADDER[:2] if quick else LADDER
    E = 3 * K * (1 - 2 * 0.3975)
    t2d = converged_period(L, 0.02, E, 0.3975, RHO)[0] * math.sqrt(K / RHO) / L
    records = []
    for label, dx in ladder:
        run_dir = f"{out_dir}/dx_{dx:g}"
        _, s = run_case(CASE, [f"case.dx={dx}", "case.output_every=0.04"], out_dir=run_dir)
        t, c = read_probe(s["output"], "tip")
        tc, al = measure(t, c["uy"])
        errors = {"period_pct": 100 * (tc - REF_PERIOD) / REF_PERIOD,
                  "amplitude_pct": 100 * (al - REF_AMPLITUDE) / REF_AMPLITUDE}
        records.append(make_record(label, dx, s, errors, {
            "period_Tc0_over_L": tc, "amplitude_A_over_L": al,
            "period_2d_fem_Tc0_over_L": t2d, "period_vs_2d_pct": 100 * (tc - t2d) / t2d,
            "setup_s": s["setup_time_s"], "loop_s": s["loop_time_s"]}))
    result = {"case": "oscillating_plate",
              "reference": "thin-plate theory [F 49-50]: T c0/L = 72.39, A/L = 0.115 "
                           f"(2D plane-strain FEM: T c0/L = {t2d:.2f})",
              "machine": machine(), "marks": MARKS, "records": records}
    write_outputs(result, out_dir, ["period_pct", "amplitude_pct"],
                  "Oscillating plate: error vs wall time", marks=MARKS)
    return result
