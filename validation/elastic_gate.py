"""Dam break through an elastic gate (Antoci et al. 2007; PHYSICS.md §8, [F 3-1]).

Horizontal and vertical displacement of the gate's free end against the experiment
(``antoci2007_elastic_gate/exp_x_Ex10X.txt``, ``exp_y_Ex10Y.txt``; each file's first sample
is subtracted, as SOURCE.md says), compared at the experiment's ten times:

- ``errors.peak_x_pct``: our peak horizontal displacement vs the experiment's 46.3 mm;
- ``values.peak_time_x_s`` (experiment: 0.162 s), ``values.rms_x_mm``, ``values.rms_y_mm``:
  RMS differences at the experiment's times.

A plot overlays the experiment, the source paper's SPH curve (Antoci) and ours. Ladder:
dx = 2.5, 1.67, 1.25, 1 mm (2, 3, 4, 5 particles through the 5 mm gate); ``--quick`` runs the
coarsest. The full ladder adds the plane-strain gate at 1.25 mm for comparison (its first record).

Plane stress or plane strain: the case models the gate in plane stress. Beam theory under the
initial hydrostatic head (:func:`static_tip_deflection`, recorded as
``values.static_tip_mm_plane_stress`` / ``_plane_strain``) gives 45.4 mm with the bending
stiffness E t^3/12 and 38.2 mm with E t^3/(12 (1 - nu^2)); the experiment's slow rise to
46.3 mm at 0.16 s is close to the first, and out of reach of the second (the head only falls
as the tank drains). E = 12 MPa reproduces the experiment as a beam modulus.

But the deflection is not small: the TLSPH gate alone under the initial head
(:func:`tlsph_static_tip`, recorded as ``values.static_tip_mm_tlsph_linear`` and
``_tlsph_pressure``) deflects 47.4 mm in the linear regime (beam theory +4 %) and 41.0 mm
(dx 2.5 mm; 41.6 mm at dx 1 mm) under the pressure of the full head, the tip rising 12 mm:
geometric nonlinearity takes 13 % off. The coupled runs peak at 39.5-40.2 mm (2-5 across,
converged in dx and in dt since the implicit coupling's boundary velocity was made
consistent, 2026-12-01e), a little below that static value for a head that falls as the
tank drains; the experiment's 46.3 mm is 11 % above it. With E = 12 MPa and an elastic gate
no 2D model reaches 46.3 mm quasi-statically.

A second, numerical reference: the SPH-FEM curves labelled Yang et al. 2012 (an independent
2D solution, peak 34.1 mm at 0.102 s), recorded as ``values.rms_x_mm_yang`` /
``rms_y_mm_yang``. The plane-strain rung follows them within 2.4 / 0.7 mm RMS over 0-0.38 s
(the plane-stress rungs, softer, 5.4 / 1.6 mm), while every rung stays ~10 mm below the
experiment after its peak. A 10-across gate (dx 0.5 mm, measured once, to 0.15 s) peaks at
40.22 mm at 0.1125 s. The hourglass control matters at these thicknesses (4 across: none
44.7 mm, but the uncontrolled gate alone is 50-100 % too soft statically; the conservative
penalty 35.5 mm, far too stiff); the default (Ganzenmueller, 10) is within 7 % of beam
theory in the linear regime (docs/numerics/solid.md, "Hourglass control").

Published 2D models of the gate with E about 12 MPa (``PUBLISHED_MODELS``, SOURCE.md's table:
Khayyer et al. 2018, 42.7 mm; Yang et al. 2012 as redrawn by Ng et al. 2020, 39.3 mm; Ng et al.
2020, 39.0 mm; all at about 0.12 s) open the gate less and earlier than the experiment; they
are drawn on the plot and stored in the record (``values.published_models``). Target (project
issue 24): our peak inside their spread, ``PUBLISHED_SPREAD_MM`` = 39-43 mm, at every rung
from 3 across (``values.in_published_spread``; ``errors.peak_x_outside_published_mm``: the
distance outside it, 0 inside). The experiment's error (``errors.peak_x_pct``) is kept as it
is; E is not tuned.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from fsi_sph.errors import SimulationError
from validation.common import CASES, machine, make_record, run_case, write_outputs

CASE = CASES / "dam_break_elastic_gate.toml"
LADDER = [("2 / gate thickness", 0.0025), ("3 / gate thickness", 0.005 / 3),
          ("4 / gate thickness", 0.00125), ("5 / gate thickness", 0.001)]
#: the plane-strain comparison run of the full ladder (PHYSICS.md §4's idealisation)
PLANE_STRAIN = ("4 / gate thickness, plane strain", 0.00125)
REF_PEAK_X = 0.0463  # m, experiment (SOURCE.md)
#: published 2D models with E about 12 MPa (SOURCE.md): peak x, peak y (mm), peak time (s)
PUBLISHED_MODELS = {
    "Khayyer et al. 2018, ISPH-SPH": {"peak_x_mm": 42.7, "peak_y_mm": 14.8, "peak_time_s": 0.12},
    "Yang et al. 2012, SPH-FEM (Ng et al. 2020's redrawing)": {
        "peak_x_mm": 39.3, "peak_y_mm": 13.1, "peak_time_s": 0.12},
    "Ng et al. 2020, SPH-VCPM": {"peak_x_mm": 39.0, "peak_y_mm": 13.7, "peak_time_s": 0.12}}
PUBLISHED_SPREAD_MM = (39.0, 43.0)
MARKS = {"Antoci SPH (2007)": {"peak_x_pct": 100 * (0.0506 - REF_PEAK_X) / REF_PEAK_X},
         **{name: {"peak_x_pct": 100 * (1e-3 * m["peak_x_mm"] - REF_PEAK_X) / REF_PEAK_X}
            for name, m in PUBLISHED_MODELS.items()}}


def static_tip_deflection(E, nu, plane, thickness=0.005, length=0.079, head=0.14,
                          y_clamp=0.079, rho=1000.0, g=9.81):
    """Tip deflection (m) of the gate as a linear cantilever under the initial hydrostatic
    load ``rho g (head - y)``: ``w = int q(s) s^2 (3 L - s) / (6 EI) ds``, ``s`` from the
    clamp, ``EI = E' t^3 / 12`` with ``E' = E`` (plane stress) or ``E / (1 - nu^2)`` (plane
    strain)."""
    e_bend = E if plane == "stress" else E / (1.0 - nu * nu)
    ei = e_bend * thickness**3 / 12.0
    s = np.linspace(0.0, length, 4001)
    q = rho * g * (head - (y_clamp - s))
    return float(np.trapezoid(q * s**2 * (3.0 * length - s) / (6.0 * ei), s))


def tlsph_static_tip(dx, load_scale=1.0, follower=True, overrides=(), damping=300.0):
    """Static tip displacement (m, (ux, uy)) of the case's TLSPH gate alone, by dynamic
    relaxation (mass damping ``damping`` 1/s), under the initial hydrostatic pressure
    ``load_scale rho g (head - y)`` on its upstream face: with ``follower`` normal to the
    deformed face and taken at the deformed heights (a pressure), else horizontal at the
    initial heights. Beside :func:`static_tip_deflection` it separates the solid's own
    answer, geometric nonlinearity included, from the coupling's."""
    from fsi_sph.config import load_config
    from fsi_sph.solid.tlsph import ElasticBody

    cfg = load_config(CASE, [f"case.dx={dx}", *overrides])
    gcfg = cfg.solid["gate"].model_copy(update={"damping": damping})
    body = ElasticBody("gate", gcfg, dx, cfg.sph, (0.0, 0.0))
    b = body.body
    x0 = b["x0"]
    face = np.flatnonzero(np.isclose(x0[:, 0], x0[:, 0].min()))
    face = face[np.argsort(x0[face, 1])]
    tip = int(np.argmin(np.hypot(x0[:, 0] - x0[:, 0].mean(), x0[:, 1] - x0[:, 1].min())))
    head = cfg.fluid.blocks[0].size[1]
    rho_g = load_scale * cfg.fluid.material.rho0 * abs(cfg.case.gravity[1])
    dt = body.stable_dt()
    t, v_stop = 0.0, 1e-5 * load_scale
    while t < 2.0:
        x = b["x"][face]
        if follower:
            tangent = np.gradient(x, axis=0)  # along the face, bottom to top
            ds = np.hypot(tangent[:, 0], tangent[:, 1])
            normal = np.column_stack([tangent[:, 1], -tangent[:, 0]]) / ds[:, None]
            p = rho_g * np.maximum(head - x[:, 1], 0.0)
        else:
            ds, normal = np.full(len(face), dx), np.tile([1.0, 0.0], (len(face), 1))
            p = rho_g * np.maximum(head - x0[face, 1], 0.0)
        b["f_ext"][:] = 0.0
        b["f_ext"][face] = (p * ds)[:, None] * normal
        body.substep(dt)
        t += dt
        if t > 0.05 and np.abs(b["v"]).max() < v_stop:
            break
    return b["x"][tip] - x0[tip]


def fluid_inside_gate(run_file, dx):
    """Largest number of fluid particles inside the gate (its deformed lattice cells,
    :func:`validation.stability.fluid_inside`) over the run's snapshots."""
    import h5py

    from validation.stability import fluid_inside, lattice_quads

    with h5py.File(run_file, "r") as f:
        snaps = [f["snapshots"][k] for k in sorted(f["snapshots"])]
        quads = lattice_quads(snaps[0]["gate/x"][()], dx)
        return max(fluid_inside(s["fluid/x"][()], s["gate/x"][()], quads) for s in snaps)


def load_curve(path):
    """(t, displacement) of a digitised curve, first sample subtracted."""
    d = np.loadtxt(path)
    return d[:, 0], d[:, 1] - d[0, 1]


def compare(t, ux, uy, data_dir):
    """Errors and values of one run against the experiment."""
    folder = Path(data_dir) / "antoci2007_elastic_gate"
    tx, ex = load_curve(folder / "exp_x_Ex10X.txt")
    ty, ey = load_curve(folder / "exp_y_Ex10Y.txt")
    inside_x = tx <= t[-1] + 1e-9
    inside_y = ty <= t[-1] + 1e-9
    ox = np.interp(tx[inside_x], t, ux)
    oy = np.interp(ty[inside_y], t, uy)
    k = int(np.argmax(ux))
    values = {"peak_x_mm": 1e3 * ux[k], "peak_time_x_s": float(t[k]),
              "rms_x_mm": 1e3 * math.sqrt(np.mean((ox - ex[inside_x]) ** 2)),
              "rms_y_mm": 1e3 * math.sqrt(np.mean((oy - ey[inside_y]) ** 2)),
              "experiment_points_compared": int(inside_x.sum())}
    values.update(against_yang(t, ux, uy, folder))
    lo, hi = PUBLISHED_SPREAD_MM
    peak_mm = values["peak_x_mm"]
    values["in_published_spread"] = float(lo <= peak_mm <= hi)
    values["published_models"] = PUBLISHED_MODELS
    return {"peak_x_pct": 100 * (ux[k] - REF_PEAK_X) / REF_PEAK_X,
            "peak_x_outside_published_mm": max(0.0, lo - peak_mm, peak_mm - hi)}, values


def against_yang(t, ux, uy, folder):
    """RMS differences (mm) from the SPH-FEM curves labelled Yang et al. 2012 (a secondary,
    numerical reference: an independent 2D solution of the same case), at that curve's
    samples up to the end of the run; empty if the files are absent."""
    out = {}
    for comp, d in (("x", ux), ("y", uy)):
        path = folder / f"yang2012_sphfem_{comp}.txt"
        if not path.exists():
            return {}
        ty, dy = load_curve(path)
        inside = ty <= t[-1] + 1e-9
        diff = np.interp(ty[inside], t, d) - dy[inside]
        out[f"rms_{comp}_mm_yang"] = 1e3 * math.sqrt(np.mean(diff**2))
    return out


def plot(runs, data_dir, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder = Path(data_dir) / "antoci2007_elastic_gate"
    fig, axes = plt.subplots(1, 2, figsize=(13, 4), layout="constrained")
    for ax, comp, exp, sph, yang in (
            (axes[0], 0, "exp_x_Ex10X.txt", "antoci_sph_x.txt", "yang2012_sphfem_x.txt"),
            (axes[1], 1, "exp_y_Ex10Y.txt", "antoci_sph_y.txt", "yang2012_sphfem_y.txt")):
        te, de = load_curve(folder / exp)
        ts, ds = load_curve(folder / sph)
        ax.plot(te, 1e3 * de, "ko", label="experiment (Antoci 2007)")
        ax.plot(ts, 1e3 * ds, "k--", lw=1, label="SPH, Antoci 2007")
        if (folder / yang).exists():
            ty, dy = load_curve(folder / yang)
            ax.plot(ty, 1e3 * dy, "k:", lw=1.2, label="SPH-FEM, Yang et al. 2012")
        key = "peak_x_mm" if comp == 0 else "peak_y_mm"
        for (name, m), mk in zip(PUBLISHED_MODELS.items(), ("^", "v", "D"), strict=True):
            ax.plot(m["peak_time_s"], m[key], mk, color="0.35", mfc="none", ms=7,
                    label=f"peak, {name}")
        if comp == 0:
            ax.axhspan(*PUBLISHED_SPREAD_MM, color="0.9", zorder=0,
                       label="published models' peaks (E 12 MPa)")
        for label, (t, ux, uy) in runs.items():
            ax.plot(t, 1e3 * (ux if comp == 0 else uy), lw=1.5, label=f"fsi_sph, {label}")
        ax.set_xlabel("t (s)")
        ax.set_ylabel(("horizontal" if comp == 0 else "vertical") + " displacement (mm)")
        ax.grid(alpha=0.3)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside right upper", fontsize=7)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def summary_of(run_file):
    """The record fields of a run file whose run did not finish."""
    import h5py

    with h5py.File(run_file, "r") as f:
        tm = dict(f["timing"].attrs)
        n = sum(f["bodies"][b]["static"]["m"].shape[0] for b in f["bodies"]
                if "m" in f["bodies"][b]["static"])
    loop = float(tm.get("loop_s", math.nan))
    return {"n_particles": n, "steps": int(tm.get("steps", 0)), "wall_time_s": loop,
            "particle_steps_per_s": float(tm.get("particle_steps", 0)) / loop}


def validate(quick=False, data_dir="../shared/validation_data",
             out_dir="validation/results/elastic_gate"):
    from fsi_sph.config import load_config
    from fsi_sph.output import read_probe

    out = Path(out_dir)
    ladder = [(lb, dx, []) for lb, dx in (LADDER[:1] if quick else LADDER)]
    if not quick:  # first, so that the last record stays the finest of the case as written
        ladder.insert(0, (*PLANE_STRAIN, ["solid.gate.material.plane=strain"]))
    mat = load_config(CASE).solid["gate"].material
    static = {f"static_tip_mm_plane_{pl}": 1e3 * static_tip_deflection(mat.E, mat.nu, pl)
              for pl in ("stress", "strain")}
    # the TLSPH gate alone under the initial head (dx 2.5 mm, a few seconds): the linear
    # answer (1 % of the load, scaled up) and the large-deflection one under the pressure
    static["static_tip_mm_tlsph_linear"] = 1e5 * float(tlsph_static_tip(0.0025, 0.01)[0])
    static["static_tip_mm_tlsph_pressure"] = 1e3 * float(tlsph_static_tip(0.0025)[0])
    records, runs = [], {}
    for label, dx, extra in ladder:
        run_dir = out / (f"dx_{dx:.5g}" + ("_plane_strain" if extra else ""))
        try:
            _, s = run_case(CASE, [f"case.dx={dx}", "case.output_every=0.02", *extra],
                            out_dir=run_dir)
        except SimulationError as e:  # record it; compare what ran
            s = summary_of(run_dir / "run.h5")
            s["status"] = f"failed: {e}"
        t, c = read_probe(run_dir / "run.h5", "gate_tip")
        errors, values = compare(t, c["ux"], c["uy"], data_dir)
        values.update(status=s["status"], t_reached_s=float(t[-1]),
                      fluid_inside_gate_max=fluid_inside_gate(run_dir / "run.h5", dx),
                      plane=("strain" if extra else mat.plane), **static)
        records.append(make_record(label, dx, s, errors, values))
        runs[label] = (t, c["ux"], c["uy"])
    plot(runs, data_dir, out / "gate_displacement.png")
    result = {"case": "elastic_gate",
              "reference": "experiment, Antoci et al. 2007: peak horizontal displacement "
                           "46.3 mm at 0.162 s; published 2D models (E 12 MPa): 39.0-42.7 mm "
                           "at about 0.12 s",
              "machine": machine(), "marks": MARKS, "published_models": PUBLISHED_MODELS,
              "targets": {"peak_x_mm in (every rung from 3 across)": list(PUBLISHED_SPREAD_MM)},
              "records": records}
    write_outputs(result, out, ["peak_x_pct"], "Elastic gate: error vs wall time")
    return result
