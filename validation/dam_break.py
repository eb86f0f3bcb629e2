"""Dam break on a dry floor: surge-front position against experiments.

Column a = 1 m wide, 2a high (cases/dam_break.toml). The data are read at run time from
``data_dir/dam_break_rigid_surge_front/`` (see SOURCE.md there):

- Koshizuka & Oka (1996): columns time (s), front x (m) for a = 1 m, g = 9.81;
- Martin & Moyce (1952): T = t sqrt(g/a), Z = x/a.

Both are compared in the dimensionless form Z(T). ``errors.front_pct`` is the largest
relative error |Z_sim - Z_exp| / Z_exp over the points of both data sets (the range the data
cover); ``errors.front_pct_koshizuka`` and ``errors.front_pct_martin_moyce`` give each one.
The front is the largest x of the fluid particles with at least 3 fluid neighbours (the
``surge_front`` probe; single particles sliding ahead along the floor are not counted).

The experiments' clock runs ahead of the water: their time origin is the start of the gate's
removal, and the column only starts to move freely once the gate is clear. A published, fixed
correction adds 0.175 to the simulation's ``t sqrt(2 g / a)`` when it is set beside the
experiments, i.e. ``ONSET_SHIFT_T`` = 0.175 / sqrt(2) = 0.124 in our ``T = t sqrt(g / a)``:
the experiment's point at ``T`` is compared with our front at ``T - ONSET_SHIFT_T``
(``errors.front_pct_koshizuka_onset``, ``errors.front_pct_martin_moyce_onset``; the shift
is fixed, not fitted).
``values.front_speed_<name>`` is the front speed dZ/dT over T in [1.5, 2.3] (least-squares
slope; ours and each experiment's, the experiments' from their own points), and
``errors.front_speed_pct_<name>`` ours against each.

A peer code run on the same geometry, metric and data files (a/dx = 50, the same front
definition; ``PEERS``) measured 18.0 / 23.0 % (weakly compressible, EDAC) and 32.7 / 40.7 %
(implicit incompressible) against Koshizuka & Oka / Martin & Moyce: marked on the plots.
Targets (project issue 24): ``front_pct_koshizuka`` at most the peer's 18, the onset-corrected
errors below 10 (stretch 8).
Also written: Z(T) against the data, error against wall time, and a pressure snapshot.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from fsi_sph.output import read_probe
from validation.common import record, run_case, write_outputs

CASE = Path(__file__).resolve().parents[1] / "cases" / "dam_break.toml"
LADDER = [0.05, 0.035, 0.025, 0.0175]   # m; a / dx = 20, 29, 40, 57
QUICK = [0.05, 0.035]
FOLDER = "dam_break_rigid_surge_front"
ONSET_SHIFT_T = 0.175 / math.sqrt(2.0)  # the experiments' onset lag, in T = t sqrt(g/a)
SPEED_RANGE_T = (1.5, 2.3)  # where the front speed is compared
PEERS = {"peer code, EDAC (WCSPH), a/dx 50": {"front_pct_koshizuka": 18.0,
                                              "front_pct_martin_moyce": 23.0},
         "peer code, implicit ISPH, a/dx 50": {"front_pct_koshizuka": 32.7,
                                               "front_pct_martin_moyce": 40.7}}


def load_data(data_dir):
    """Experimental (T, Z) pairs: {name: (T, Z)}."""
    d = Path(data_dir) / FOLDER
    ko = np.loadtxt(d / "koshizuka_oka_1996_tip_position.tsv", skiprows=1)
    mm = np.loadtxt(d / "martin_moyce_1952_surge_front_trixiparticles.csv", skiprows=1,
                    delimiter=",")
    g, a = 9.81, 1.0  # the geometry the Koshizuka & Oka file is given for (SOURCE.md)
    return {"koshizuka": (ko[:, 0] * math.sqrt(g / a), ko[:, 1] / a),
            "martin_moyce": (mm[:, 0], mm[:, 1])}


def disagreement_floor(data):
    """The smallest ``front_pct`` any curve can reach against both data sets: at each
    Martin & Moyce time inside the common T range, the best value lies between the two
    experiments, with relative error ``|Z_k - Z_m| / (Z_k + Z_m)`` to each; the largest over
    those times (%). (5.4 %: the experiments differ by up to 11 % at T = 1.9.)"""
    (tk, zk), (tm, zm) = data["koshizuka"], data["martin_moyce"]
    sel = (tm >= max(tk.min(), tm.min())) & (tm <= min(tk.max(), tm.max()))
    zk_m = np.interp(tm[sel], tk, zk)
    return float(100.0 * np.max(np.abs(zk_m - zm[sel]) / (zk_m + zm[sel])))


def front_errors(T_sim, Z_sim, data, shift=0.0, suffix=""):
    """Largest relative front error (%) against each data set, over the data's T range, the
    experiment's point at ``T`` against our front at ``T - shift`` (the onset correction; 0:
    as published)."""
    out = {}
    for name, (T, Z) in data.items():
        zs = np.interp(T - shift, T_sim, Z_sim)
        out[f"front_pct_{name}{suffix}"] = float(100.0 * np.max(np.abs(zs - Z) / Z))
    if not suffix:
        out["front_pct"] = max(out.values())
    return out


def front_speed(T, Z, lo=SPEED_RANGE_T[0], hi=SPEED_RANGE_T[1]):
    """Least-squares slope dZ/dT of the points with T in [lo, hi] (nan with fewer than 2)."""
    sel = (T >= lo) & (T <= hi)
    if sel.sum() < 2:
        return float("nan")
    return float(np.polyfit(T[sel], Z[sel], 1)[0])


def speed_comparison(T_sim, Z_sim, data):
    """Our front speed, each experiment's, and ours against each (%)."""
    errors, values = {}, {"front_speed_sim": front_speed(T_sim, Z_sim)}
    for name, (T, Z) in data.items():
        v = front_speed(T, Z)
        values[f"front_speed_{name}"] = v
        errors[f"front_speed_pct_{name}"] = 100.0 * (values["front_speed_sim"] - v) / v
    return errors, values


def validate(quick, data_dir, out_dir):
    from fsi_sph.plotting import error_vs_time

    out_dir = Path(out_dir)
    data = load_data(data_dir)
    records = []
    curves = {}
    for dx in (QUICK if quick else LADDER):
        label = f"dx={dx:g}"
        sim, summary = run_case(CASE, [f"case.dx={dx}"], out_dir / label)
        a = sim.cfg.fluid.blocks[0].size[0]
        g = abs(sim.cfg.case.gravity[1])
        t, cols = read_probe(summary["output"], "front")
        T_sim = t * math.sqrt(g / a)
        Z_sim = (cols["x_front"] - sim.cfg.fluid.blocks[0].origin[0]) / a
        curves[label] = (T_sim, Z_sim)
        errs = front_errors(T_sim, Z_sim, data)
        errs.update(front_errors(T_sim, Z_sim, data, ONSET_SHIFT_T, "_onset"))
        speed_err, speed = speed_comparison(T_sim, Z_sim, data)
        errs.update(speed_err)
        ppe = _ppe_summary(summary["output"])
        records.append(record(label, dx, summary, errs,
                              {"n_fluid": sim.fluid.n, "a_over_dx": a / dx,
                               "front_pct_floor_of_the_data": disagreement_floor(data),
                               "onset_shift_T": ONSET_SHIFT_T, **speed, **ppe}))
    result = {"case": "dam_break",
              "reference": "surge front, Koshizuka & Oka (1996) and Martin & Moyce (1952); "
                           "onset-corrected (our T + 0.124 against theirs); peer code at "
                           "a/dx 50: EDAC 18.0 / 23.0 %, implicit ISPH 32.7 / 40.7 %",
              "targets": {"front_pct_koshizuka at most": 18.0,
                          "front_pct_*_onset below": 10.0, "stretch": 8.0},
              "marks": PEERS, "records": records}
    keys = ["front_pct_koshizuka", "front_pct_martin_moyce", "front_pct_koshizuka_onset",
            "front_pct_martin_moyce_onset"]
    write_outputs(result, out_dir, keys)
    _plot_front(curves, data, out_dir / "dam_break_front.png")
    error_vs_time(records, ["front_pct", *keys], "dam break: surge front error vs wall time",
                  out_dir / "dam_break_error.png", marks=PEERS)
    _plot_pressure(records[-1], out_dir)
    return result


def _ppe_summary(run_file):
    from fsi_sph.output import read_steps

    s = read_steps(run_file)
    it = s["ppe_iterations"]
    return {"ppe_iterations_mean": float(it.mean()), "ppe_iterations_max": float(it.max()),
            "ppe_residual_max": float(s["ppe_residual"].max()),
            "ppe_rebuilds": float(s["ppe_rebuilt"].sum())}


def _plot_front(curves, data, path):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4), layout="constrained")
    for label, (T, Z) in curves.items():
        ax.plot(T, Z, lw=1.3, label=f"ISPH {label}")
    marks = {"koshizuka": "s", "martin_moyce": "o"}
    for name, (T, Z) in data.items():
        ax.plot(T, Z, marks[name], mfc="none", color="k", label=name.replace("_", " & "))
        ax.plot(T - ONSET_SHIFT_T, Z, marks[name], mfc="none", color="0.6", ms=4,
                label=f"{name.replace('_', ' & ')}, onset-corrected (T - {ONSET_SHIFT_T:.3f})")
    ax.axvspan(*SPEED_RANGE_T, color="0.93", zorder=0, label="front speed compared")
    ax.text(0.97, 0.03, "peer code, same metric (K&O / M&M):\n" + "\n".join(
        f"{k.split(', ', 1)[1]}: {v['front_pct_koshizuka']:.1f} / "
        f"{v['front_pct_martin_moyce']:.1f} %" for k, v in PEERS.items()),
        transform=ax.transAxes, va="bottom", ha="right", fontsize=7,
        bbox={"facecolor": "white", "edgecolor": "0.7"})
    ax.set_xlim(0, 2.6)
    ax.set_ylim(1, 4.5)
    ax.set_xlabel("T = t sqrt(g/a)")
    ax.set_ylabel("Z = x/a")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _plot_pressure(rec, out_dir):
    """Pressure of the finest run at the snapshot nearest to t = 0.3 s (before impact)."""
    import h5py
    import matplotlib.pyplot as plt

    run = Path(out_dir) / rec["label"] / "run.h5"
    with h5py.File(run, "r") as f:
        snaps = sorted(f["snapshots"])
        ts = np.array([f["snapshots"][s].attrs["t"] for s in snaps])
        k = int(np.argmin(np.abs(ts - 0.3)))
        g = f["snapshots"][snaps[k]]
        x, p = g["fluid/x"][()], g["fluid/p"][()]
        xw = g["walls/x"][()] if "walls" in g else np.zeros((0, 2))
        t = ts[k]
    fig, ax = plt.subplots(figsize=(8, 3.6), layout="constrained")
    ax.scatter(xw[:, 0], xw[:, 1], s=1, c="0.6", linewidths=0)
    sc = ax.scatter(x[:, 0], x[:, 1], c=p / 1000.0, s=2, cmap="viridis", linewidths=0)
    fig.colorbar(sc, ax=ax, label="p (kPa)")
    ax.set_aspect("equal")
    ax.set_title(f"dam break, {rec['label']}, t = {t:.3f} s: pressure")
    fig.savefig(Path(out_dir) / "dam_break_pressure.png", dpi=150)
    plt.close(fig)
