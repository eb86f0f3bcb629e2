"""Turek & Hron (2006) FSI2: the elastic flag behind a cylinder in a channel oscillates by
itself at Re = 100 (cases/turek_hron_fsi2.toml).

Reference (Turek & Hron 2006, the benchmark's table for FSI2, periodic state; each value is
``mean +- amplitude`` with ``mean = (max + min) / 2``, ``amplitude = (max - min) / 2`` over
the last periods, and the frequency of the signal):

- point A (the flag's end): ``u_x = -14.58 +- 12.44 mm`` at 3.8 Hz, ``u_y = 1.23 +- 80.6 mm``
  at 2.0 Hz;
- drag ``208.83 +- 73.75 N/m``, lift ``0.88 +- 234.2 N/m`` (cylinder and flag together: the
  ``cylinder_force`` and ``flag_force`` probes summed).

Measured over the last ``WINDOW`` seconds of the run; the drag and the lift after a low-pass
filter at ``LOWPASS_HZ`` (their SPH noise lies at 15-20 Hz). Errors are signed %; the means of
``u_y`` and of the lift (references near zero) are reported as values only. A plot of the
tip's displacement over the whole run with the reference's band (``tip.png``) and one of the
forces over the window, raw and filtered (``forces.png``), are written beside the record.
The ladder is D / dx = 10 / 20 (dx 0.01 / 0.005 m: two / four particles through the flag);
``--quick`` runs the first.
"""

from __future__ import annotations

from pathlib import Path

from validation.common import make_record, run_case, write_outputs
from validation.turek_hron_measures import body_force, periodic_errors, probe_before_landing

CASE = Path(__file__).resolve().parents[1] / "cases" / "turek_hron_fsi2.toml"
LADDER = [0.01, 0.005]   # m; D / dx = 10, 20
QUICK = [0.01]
WINDOW = 3.0             # s: the last seconds of the run are measured (six u_y periods)
#: the forces' low-pass cut-off: five times the flag's 2 Hz (turek_hron_measures.lowpass)
LOWPASS_HZ = {"drag_N_per_m": 10.0, "lift_N_per_m": 10.0}
#: Turek & Hron 2006, FSI2: (mean, amplitude, frequency in Hz)
REF = {"ux_mm": (-14.58, 12.44, 3.8), "uy_mm": (1.23, 80.6, 2.0),
       "drag_N_per_m": (208.83, 73.75, None), "lift_N_per_m": (0.88, 234.2, 2.0)}
REFERENCE = ("Turek & Hron 2006 FSI2: point A u_x -14.58 +- 12.44 mm (3.8 Hz), u_y 1.23 +- "
             "80.6 mm (2.0 Hz); drag 208.83 +- 73.75, lift 0.88 +- 234.2 N/m")


def signals(run_file):
    """Time and the four signals of the benchmark (mm and N/m) from a run's probes."""
    t, tip = probe_before_landing(run_file, "tip")
    _, drag, lift = body_force(run_file, ("cylinder_force", "flag_force"))
    return t, {"ux_mm": 1e3 * tip["ux"], "uy_mm": 1e3 * tip["uy"],
               "drag_N_per_m": drag, "lift_N_per_m": lift}


def measure(sim, run_file):
    t, sig = signals(run_file)
    return periodic_errors(t, sig, REF, WINDOW, LOWPASS_HZ)


def plot_tip(run_files, path):
    """The tip's u_y (and u_x) against time for each rung, with the reference's band."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(7.0, 5.6), sharex=True, layout="constrained")
    for label, run_file in run_files:
        t, sig = signals(run_file)
        axes[0].plot(t, sig["uy_mm"], lw=0.8, label=label)
        axes[1].plot(t, sig["ux_mm"], lw=0.8, label=label)
    for ax, key in zip(axes, ("uy_mm", "ux_mm"), strict=True):
        mean, amp, _ = REF[key]
        for y in (mean - amp, mean + amp):
            ax.axhline(y, color="k", ls="--", lw=0.8)
        ax.set_ylabel(f"point A {key[:2].replace('u', 'u_')} (mm)")
    axes[0].plot([], [], "k--", lw=0.8, label="Turek & Hron 2006: mean +- amplitude")
    axes[0].legend(fontsize=8)
    axes[1].set_xlabel("t (s)")
    fig.suptitle("Turek & Hron FSI2: the flag's end")
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_forces(run_files, path):
    """Drag and lift over the measured window for each rung: the probes' signal and the
    low-pass filtered one the measures read, with the reference's band."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from validation.turek_hron_measures import lowpass

    keys = ("drag_N_per_m", "lift_N_per_m")
    fig, axes = plt.subplots(2, len(run_files), figsize=(5.0 * len(run_files), 5.6),
                             squeeze=False, sharey="row", layout="constrained")
    for col, (label, run_file) in enumerate(run_files):
        t, sig = signals(run_file)
        for row, key in enumerate(keys):
            ax = axes[row, col]
            late = t >= t[-1] - WINDOW
            ax.plot(t[late], sig[key][late], lw=0.5, color="0.65", label="probe")
            t_f, y_f = lowpass(t, sig[key], LOWPASS_HZ[key])
            keep = t_f >= t[-1] - WINDOW
            ax.plot(t_f[keep], y_f[keep], lw=1.2, label=f"low-pass {LOWPASS_HZ[key]:g} Hz")
            mean, amp, _ = REF[key]
            for y in (mean - amp, mean + amp):
                ax.axhline(y, color="k", ls="--", lw=0.8)
            ax.set_title(f"{label}: {key.split('_')[0]}", fontsize=9)
            ax.set_ylabel(f"{key.split('_')[0]} (N/m)")
        axes[1, col].set_xlabel("t (s)")
    axes[0, 0].plot([], [], "k--", lw=0.8, label="Turek & Hron 2006: mean +- amplitude")
    axes[0, 0].legend(fontsize=7)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def validate(quick, data_dir, out_dir):
    ladder = QUICK if quick else LADDER
    records, runs = [], []
    for dx in ladder:
        label = f"dx={dx:g}"
        run_dir = Path(out_dir) / label
        sim, summary = run_case(CASE, [f"case.dx={dx}", "case.output_every=1.0"], run_dir)
        errors, values = measure(sim, run_dir / "run.h5")
        records.append(make_record(label, dx, summary, errors, values))
        runs.append((f"D/dx = {0.1 / dx:.0f}", run_dir / "run.h5"))
    result = {"case": "turek_hron_fsi2", "reference": REFERENCE, "records": records}
    out = write_outputs(result, out_dir)
    plot_tip(runs, out / "tip.png")
    plot_forces(runs, out / "forces.png")
    return result
