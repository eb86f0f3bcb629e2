"""Plane Poiseuille flow with an inflow and an outflow (cases/channel_poiseuille.toml).

Reference: the analytic profile of the developed flow between no-slip walls,
``u(y) = 6 U s (1 - s)``, ``s = y / H``, with ``U`` the prescribed mean inflow velocity, and
its pressure gradient ``dp/dx = -12 rho nu U / H^2``. The inflow is uniform, so the profile
develops behind it (entrance length about one H at Re = 10); it is measured over the
window ``3 H <= x <= 4 H`` at the end of the run (8 s, eight viscous time constants
``H^2 / (pi^2 nu)`` after the start).

Errors (signed % unless said):

- ``profile_rms_pct``: RMS over the window's particles of ``u_i - u(y_i)`` (each particle
  against the analytic value at its own height), over ``1.5 U`` (unsigned);
- ``flow_rate_pct``: the window's mean ``u`` against ``U``;
- ``mass_balance_pct``: the mass outflow rate against the inflow rate over the second half
  of the run (the slopes of the cumulative masses of the per-step table's ``mass_in`` and
  ``mass_out`` against time, so that the discreteness of single crossings averages out);
- ``pressure_gradient_pct``: the centreline pressure gradient (the difference of the
  ``p_4H`` and ``p_1H`` probes, Shepard-interpolated at 4 H and 1 H, averaged over the
  second half of the run: one snapshot of the field is not its mean, it moves from step to
  step) against the analytic one.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fsi_sph.output import read_probe, read_steps
from validation.common import ladder_result

CASE = Path(__file__).resolve().parents[1] / "cases" / "channel_poiseuille.toml"
LADDER = [0.01, 0.005, 0.0025]   # m; H / dx = 10, 20, 40
QUICK = [0.01, 0.005]
WINDOW = (3.0, 4.0)  # in H: where the profile is measured


def measure(sim, run_file):
    """The errors and values of one run (module docstring)."""
    cfg = sim.cfg
    inflow = cfg.fluid.inflow[0]
    y0, y1 = inflow.y_range
    H = y1 - y0
    U = inflow.velocity.mean
    mu = cfg.fluid.material.rho0 * cfg.fluid.material.nu
    x0 = inflow.x
    b = sim.fluid.body
    x, u = b["x"], b["v"][:, 0]
    sel = (x[:, 0] >= x0 + WINDOW[0] * H) & (x[:, 0] <= x0 + WINDOW[1] * H)
    s = (x[sel, 1] - y0) / H
    err = u[sel] - 6.0 * U * s * (1.0 - s)
    t_p, p1 = read_probe(run_file, "p_1H")
    _, p4 = read_probe(run_file, "p_4H")
    late_p = t_p >= 0.5 * t_p[-1]
    drop = p4["p"][late_p] - p1["p"][late_p]
    dpdx = float(np.mean(drop)) / (3.0 * H)
    dpdx_ref = -12.0 * mu * U / H ** 2
    steps = read_steps(run_file)
    t = steps["t"]
    m_in = np.cumsum(steps["mass_in"])
    m_out = np.cumsum(steps["mass_out"])
    late = t >= 0.5 * t[-1]
    rate_in = float(np.polyfit(t[late], m_in[late], 1)[0])
    rate_out = float(np.polyfit(t[late], m_out[late], 1)[0])
    rate_ref = cfg.fluid.material.rho0 * U * H
    errors = {"profile_rms_pct": 100.0 * float(np.sqrt(np.mean(err ** 2))) / (1.5 * U),
              "flow_rate_pct": 100.0 * (float(np.mean(u[sel])) - U) / U,
              "mass_balance_pct": 100.0 * (rate_out - rate_in) / rate_in,
              "pressure_gradient_pct": 100.0 * (dpdx - dpdx_ref) / abs(dpdx_ref)}
    values = {"profile_max_abs_pct": 100.0 * float(np.max(np.abs(err))) / (1.5 * U),
              "mass_rate_in": rate_in, "mass_rate_out": rate_out,
              "mass_rate_prescribed": rate_ref, "dpdx_Pa_per_m": dpdx,
              "dpdx_ref_Pa_per_m": dpdx_ref,
              "dpdx_std_Pa_per_m": float(np.std(drop)) / (3.0 * H),
              "window_particles": int(np.count_nonzero(sel)),
              "fluid_particles_end": int(sim.fluid.nf), "t_end_s": sim.t}
    return errors, values


REFERENCE = ("analytic plane Poiseuille flow u = 6 U s (1 - s), dp/dx = -12 rho nu U / H^2; "
             "mass in = mass out")


def validate(quick, data_dir, out_dir):
    ladder = QUICK if quick else LADDER
    return ladder_result("channel_poiseuille", REFERENCE, CASE, ladder, out_dir, measure,
                         ["case.output_every=2.0"])
