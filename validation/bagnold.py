"""Steady granular flow down a rough incline against the Bagnold profile [G 36-37].

Glass beads (PHYSICS.md §7) with the mu(I) law, a layer H = 10 mm = 20 d on a no-slip bed
at theta = 24 deg, periodic along the slope (cases/bagnold.toml). The reference is
``U(y) / sqrt(g d) = (2/3) I sqrt(phi cos theta) (H^{3/2} - (H - y)^{3/2}) / d^{3/2}`` with
the uniform ``I = I0 (tan theta - mu_s) / (mu_2 - tan theta)``.

``errors.profile_pct``: the L2 (root-mean-square) difference between the simulated
velocity along the slope and U(y), over all fluid particles at ``t_end``, relative to the
reference surface velocity U(H). ``values`` also hold the surface speeds, the change of the
mean speed over the last 10 % of the run (how steady the end state is) and, from the step
log, the advective time step against the explicit viscous limit 0.125 h^2 / nu_max that the
implicit viscous step does not need.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from fsi_sph.fluid import rheology as R
from fsi_sph.output import read_steps
from validation.common import record, run_case, write_outputs

CASE = Path(__file__).resolve().parents[1] / "cases" / "bagnold.toml"
LADDER = [0.0005, 0.00025]   # m; H / dx = 20, 40
QUICK = [0.0005]


def reference(cfg):
    """(theta, depth, I, U(y) function) of the case."""
    g = np.asarray(cfg.case.gravity)
    theta = math.atan2(g[0], -g[1])
    q = cfg.fluid.material.mu_i
    depth = cfg.fluid.blocks[0].size[1]
    phi = cfg.fluid.material.rho0 / q.rho_s
    inertial = R.bagnold_inertial_number(theta, q.mu_s, q.mu_2, q.I0)
    gmag = float(np.hypot(*g))

    def profile(y):
        return R.bagnold_profile(y, depth, theta, q.d, phi, inertial, gmag)

    return theta, depth, inertial, profile


def snapshot_errors(run_file, profile, u_surf, dx):
    """(t, profile_pct, mean height of the top particle row in mm) at every snapshot: how
    the error approaches its end value and whether the layer keeps its thickness."""
    import h5py

    out = []
    with h5py.File(run_file, "r") as f:
        for name in sorted(f["snapshots"], key=lambda k: f["snapshots"][k].attrs["t"]):
            g = f["snapshots"][name]
            x, v = g["fluid/x"][()], g["fluid/v"][()]
            err = 100.0 * math.sqrt(float(np.mean((v[:, 0] - profile(x[:, 1])) ** 2))) / u_surf
            n_row = max(int(round(np.ptp(x[:, 0]) / dx)) + 1, 1)
            top = float(np.sort(x[:, 1])[-n_row:].mean() * 1e3)
            out.append((float(g.attrs["t"]), err, top))
    return out


def validate(quick, data_dir, out_dir):
    from fsi_sph.output import read_probe

    out_dir = Path(out_dir)
    records = []
    profiles = {}
    for dx in (QUICK if quick else LADDER):
        label = f"dx={dx:g}"
        sim, summary = run_case(CASE, [f"case.dx={dx}"], out_dir / label)
        theta, depth, inertial, profile = reference(sim.cfg)
        b = sim.fluid.body
        y, u = b["x"][:, 1] - sim.cfg.fluid.blocks[0].origin[1], b["v"][:, 0]
        u_ref = profile(y)
        u_surf = float(profile(depth))
        err = 100.0 * math.sqrt(float(np.mean((u - u_ref) ** 2))) / u_surf
        t, cols = read_probe(summary["output"], "stats")
        ke = cols["kinetic"]
        tail = t >= 0.9 * t[-1]
        change = 100.0 * (math.sqrt(ke[-1]) - math.sqrt(ke[tail][0])) / math.sqrt(ke[-1])
        log = read_steps(summary["output"])
        history = snapshot_errors(summary["output"], profile, u_surf, dx)
        top = y > depth - dx
        profiles[label] = (y, u)
        records.append(record(label, dx, summary, {"profile_pct": err}, {
            "theta_deg": math.degrees(theta), "I_ref": inertial, "H_over_dx": depth / dx,
            "u_surface_ref": u_surf, "u_surface_sim_top_row": float(u[top].mean()),
            "u_ref_at_top_row": float(u_ref[top].mean()),
            "bed_slip_first_row_over_ref": float(u[y < dx].mean() / u_ref[y < dx].mean()),
            "rms_speed_change_last_10pct_pct": change,
            "dt_advective_median": float(np.median(log["dt_advective"])),
            "dt_viscous_explicit_median": float(np.median(log["dt_viscous_explicit"])),
            "dt_used_median": float(np.median(log["dt"])),
            "dt_used_over_viscous_median": float(np.median(log["dt"] /
                                                           log["dt_viscous_explicit"])),
            "viscous_iterations_mean": float(np.mean(log["viscous_iterations"])),
            "ppe_iterations_mean": float(np.mean(log["ppe_iterations"])),
            "t_end_s": sim.t,
            "history_t_s": [h[0] for h in history],
            "history_profile_pct": [h[1] for h in history],
            "history_top_row_y_mm": [h[2] for h in history]}))
        _plot_dt(log, out_dir / f"bagnold_dt_{label}.png")
    result = {"case": "bagnold",
              "reference": "Bagnold profile of the mu(I) law [G 36-37] (glass beads, 24 deg)",
              "records": records}
    write_outputs(result, out_dir)
    _plot_profiles(profiles, profile, depth, out_dir / "bagnold_profile.png")
    return result


def _plot_profiles(profiles, profile, depth, path):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(4.8, 4.4), layout="constrained")
    yy = np.linspace(0.0, depth, 200)
    ax.plot(profile(yy), yy * 1e3, "k-", label="Bagnold [G 36]")
    for label, (y, u) in profiles.items():
        ax.plot(u, y * 1e3, ".", ms=2, label=f"ISPH mu(I) {label}")
    ax.set_xlabel("u along the slope (m/s)")
    ax.set_ylabel("y (mm)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _plot_dt(log, path):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.0, 3.6), layout="constrained")
    ax.semilogy(log["t"], log["dt"], label="dt used")
    ax.semilogy(log["t"], log["dt_advective"], "--", label="advective cfl h/|u|max")
    ax.semilogy(log["t"], log["dt_viscous_explicit"], ":",
                label="explicit viscous 0.125 h^2/nu_max")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("time step (s)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=120)
    plt.close(fig)
