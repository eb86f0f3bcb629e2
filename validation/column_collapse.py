"""Column collapse of aluminium bars (Bui et al. 2008): final deposit and failure line.

Reference: the experiment of Bui, Fukagawa, Sako & Ohno (2008, Int. J. Numer. Anal. Meth.
Geomech. 32:1537-1570): a 0.2 m x 0.1 m column of aluminium bars (rho 2040, phi 19.8 deg, c 0)
released on one side. Its final deposit is read at run time from
``<data>/bui2008_column_collapse/`` (``final_surface.csv``: the free surface, toe at
x = 0.442 m; ``final_failure_line.csv``: the boundary between the bars that moved and the
static wedge at the back wall).

Measurements (final state, t_end = 0.8 s; the deposit is at rest by 0.6 s):
* ``deposit_height(x)``: the deposit's volume-equivalent height, the particles' area
  (``dx^2`` each) in a bin of width ``2 dx`` around x divided by the bin width. A single layer
  of particles is ``dx`` high; scattered particles are less.
* ``values.runout_contour_m`` / ``errors.runout_pct``: the toe where the height, walked from
  the back wall, first falls below ``TOE_HEIGHT`` = 2 mm (about one grain; Feng et al. 2021
  read simulated toes there, since a toe read at the last particle moves with resolution),
  against the experiment's 0.442 m. ``values.runout_m``: the old measure (last particle of
  the contiguous deposit, :func:`soil_common.deposit_toe`), kept for the record.
* ``errors.surface_rms_mm``: RMS of ``deposit_height`` minus the experiment's surface over the
  file's points.
* ``values.failure_angle_final_deg`` / ``errors.failure_angle_final_diff_deg``: the final
  failure line as the experiment defines it, the boundary between the bars that moved and the
  static wedge: in each initial row of particles, scanned from the released face towards the
  wall, the first of three particles in a row whose displacement is below ``STATIC_DISP``
  (1 mm: half a bar diameter); a straight line through these points (orthogonal least
  squares, :func:`line_angle_deg`, the same fit as the experiment's line) against the
  experiment's fitted line. ``values.failure_angle_final_eps_deg``: the same line drawn from
  the plastic strain (below ``EPS_LINE``), for comparison.
* ``values.failure_angle_onset_deg``: the failure line at failure onset (the plastic-strain
  field when the front has advanced ``ONSET_ADVANCE`` x H beyond the released face), shown
  against the bracket of shear-band angles of a frictional material (Bardet 1991): the
  Roscoe angle 45 + psi/2 (45 deg) and the Coulomb angle 45 + phi/2 (54.9 deg);
  ``errors.onset_outside_bracket_deg`` is its distance outside that bracket (0 inside).

Targets (project issue 24) at the finest rung (dx = 2 mm), with the material as specified:
|runout_pct| < 10, surface_rms_mm < 8, |failure_angle_final_diff_deg| < 5.
"""

from __future__ import annotations

import json
import logging
import math

import numpy as np

from validation.soil_common import advance, build, deposit_toe, record

log = logging.getLogger(__name__)

CASE = "column_collapse"
PHI_DEG = 19.8
PSI_DEG = 0.0
EPS_LINE = 0.05  # plastic strain that separates the sliding wedge from the undisturbed one
STATIC_DISP = 1e-3  # m: displacement below which a bar has not moved (half a bar diameter)
STATIC_DISP_SENS = (0.5e-3, 1e-3, 2e-3, 5e-3)  # recorded sensitivity of the final line
TOE_HEIGHT = 2e-3  # m: the run-out is read where the deposit is this high (one grain)
RUNOUT_EXP = 0.442  # m: the experiment's toe (SOURCE.md)
DATA = "bui2008_column_collapse"
HEIGHT, LENGTH = 0.1, 0.2  # m: the column
ONSET_ADVANCE = 0.2  # of H: front advance beyond the released face that marks failure onset
# sensitivity of the onset line (recorded, not a criterion): other onset moments and thresholds
SENS_ADVANCES = (0.05, 0.1, 0.2, 0.3)
SENS_THRESHOLDS = (0.01, 0.05, 0.2)


def failure_line(x0, eps_p, dx, height=0.1, eps_line=EPS_LINE):
    """Points (x0, y0) of the failure line and the fitted angle (deg from horizontal)."""
    rows = np.round(x0[:, 1] / dx).astype(int)
    pts = []
    for r in np.unique(rows):
        sel = rows == r
        y0 = float(x0[sel, 1].mean())
        if not 0.1 * height < y0 < 0.9 * height:
            continue
        xs = x0[sel, 0]
        e = eps_p[sel]
        order = np.argsort(xs)[::-1]  # from the released face towards the wall
        xs, e = xs[order], e[order]
        below = np.flatnonzero(e < eps_line)
        if len(below) == 0:
            continue
        # first particle (from the face) of a run of 3 below the threshold
        k = next((b for b in below if np.all(e[b:b + 3] < eps_line)), below[0])
        pts.append((float(xs[k]), y0))
    pts = np.array(pts)
    if len(pts) < 3:
        return pts, float("nan")
    slope = np.polyfit(pts[:, 1], pts[:, 0], 1)[0]  # dx0/dy0
    return pts, math.degrees(math.atan2(1.0, abs(slope)))


def onset_sensitivity(x0, fields, dx, thresholds=SENS_THRESHOLDS):
    """Failure-line angle for each captured onset field and threshold:
    ``{"adv=<a>H,eps=<e>": angle}`` with ``fields = {a: eps_p}`` (a = front advance / H).
    A record of how much the 'onset line' depends on the two choices the criterion fixes
    (ONSET_ADVANCE, EPS_LINE); see validation/README_soil.md."""
    return {f"adv={a:g}H,eps={e:g}": round(failure_line(x0, f, dx, eps_line=e)[1], 2)
            for a, f in sorted(fields.items()) for e in thresholds}


def _fit(pts):
    """Centre and unit direction of the orthogonal least-squares line through ``pts``
    (n x 2): the direction of the points' largest spread."""
    pts = np.asarray(pts, dtype=float)
    c = pts.mean(axis=0)
    _, _, vt = np.linalg.svd(pts - c, full_matrices=False)
    return c, vt[0]


def line_angle_deg(pts):
    """Angle (deg, 0-90) from the horizontal of the orthogonal least-squares line through
    ``pts`` (:func:`_fit`)."""
    if len(pts) < 3:
        return float("nan")
    ux, uy = _fit(pts)[1]
    return math.degrees(math.atan2(abs(uy), abs(ux)))


def deposit_height(x, dx, xs, x_wall=0.0):
    """Volume-equivalent height of the deposit at each of ``xs``: the area of the particles
    (``dx^2`` each) whose x lies in the bin ``[x - dx, x + dx)``, divided by its width ``2 dx``
    (a bin that would cross the back wall ``x_wall`` starts at the wall instead)."""
    xs = np.asarray(xs, dtype=float)
    px = np.sort(x[:, 0])
    left = np.maximum(xs - dx, x_wall)
    lo = np.searchsorted(px, left, side="left")
    hi = np.searchsorted(px, left + 2.0 * dx, side="left")
    return (hi - lo) * dx / 2.0


def contour_toe(x, dx, height=TOE_HEIGHT):
    """Run-out read on the height contour: walking from the deposit's back (the first point
    at least ``height`` high) in steps of ``dx/4``, the first x where :func:`deposit_height`
    falls below ``height`` (linear between steps)."""
    xs = np.arange(0.0, x[:, 0].max() + 2.0 * dx, 0.25 * dx)
    h = deposit_height(x, dx, xs)
    high = np.flatnonzero(h >= height)
    if len(high) == 0:
        return float("nan")
    below = np.flatnonzero(h[high[0]:] < height)
    if len(below) == 0:
        return float(xs[-1])
    k = int(high[0] + below[0])
    return float(xs[k - 1] + (xs[k] - xs[k - 1]) * (h[k - 1] - height) / (h[k - 1] - h[k]))


def surface_rms_mm(x, dx, surface):
    """RMS (mm) of the deposit's height against the experiment's surface points (x, y)."""
    h = deposit_height(x, dx, surface[:, 0])
    return 1e3 * math.sqrt(float(np.mean((h - surface[:, 1]) ** 2)))


def load_experiment(data_dir):
    """(surface, failure line) of the experiment's final deposit, each n x 2 in metres."""
    from pathlib import Path

    folder = Path(data_dir) / DATA
    surf = np.loadtxt(folder / "final_surface.csv", delimiter=",", skiprows=1)
    line = np.loadtxt(folder / "final_failure_line.csv", delimiter=",", skiprows=1)
    return surf, line


def static_bounds(phi_deg=PHI_DEG, height=HEIGHT, length=LENGTH):
    """What statics allows a cohesionless deposit (free surface no steeper than phi, area
    conserved): the longest undisturbed top ``x_a``, the shortest run-out and the steepest
    final failure line from the original toe (degrees)."""
    t = math.tan(math.radians(phi_deg))
    x_a = length - height / (2.0 * t)
    return x_a, x_a + height / t, math.degrees(math.atan2(height, length - x_a))


def _line(pts):
    """The fitted line through ``pts`` drawn across the column's height (orthogonal fit)."""
    if len(pts) < 3:
        return None
    c, (ux, uy) = _fit(pts)
    if abs(uy) < 1e-12:
        return None
    s = (np.array([0.0, HEIGHT]) - c[1]) / uy
    return np.column_stack([c[0] + s * ux, c[1] + s * uy])


def _ray(angle_deg, x_toe=LENGTH):
    """A line from the column's toe at ``angle_deg`` from the floor, up to the top."""
    return np.array([[x_toe, 0.0], [x_toe - HEIGHT / math.tan(math.radians(angle_deg)), HEIGHT]])


def run_one(dx, t_end, out_dir, exp):
    surf, exp_line = exp
    sim = build(CASE, dx)
    body = sim.structures["bars"]
    onset = {}
    sens = {}

    def grab(s):  # the plastic-strain field at failure onset (and at the other advances)
        adv = (body.body["x"][:, 0].max() - LENGTH) / HEIGHT
        for a in SENS_ADVANCES:
            if a not in sens and adv >= a:
                sens[a] = body.body["eps_p"].copy()
        if "eps_p" not in onset and adv >= ONSET_ADVANCE:
            onset["eps_p"] = body.body["eps_p"].copy()
            onset["t"] = s.t

    wall, psteps = advance(sim, t_end, on_step=grab)
    b = body.body
    x, x0 = b["x"], b["x0"]
    # the final state, for re-plotting and re-measuring without a re-run (git-ignored)
    (out_dir / "runs").mkdir(parents=True, exist_ok=True)
    np.savez_compressed(out_dir / "runs" / f"final_dx{dx:g}.npz", x=x, x0=x0, eps_p=b["eps_p"],
                        eps_p_onset=onset["eps_p"], t_onset=onset["t"])
    disp = np.linalg.norm(x - x0, axis=1)
    pts_on, _ = failure_line(x0, onset["eps_p"], dx)
    angle_on = line_angle_deg(pts_on)
    pts, _ = failure_line(x0, disp, dx, eps_line=STATIC_DISP)
    angle = line_angle_deg(pts)
    angle_eps = line_angle_deg(failure_line(x0, b["eps_p"], dx)[0])
    angle_sens = {f"{1e3 * d:g} mm": round(line_angle_deg(
        failure_line(x0, disp, dx, eps_line=d)[0]), 2) for d in STATIC_DISP_SENS}
    exp_angle = line_angle_deg(exp_line)
    runout_c = contour_toe(x, dx)
    runout = deposit_toe(x, dx)
    rms = surface_rms_mm(x, dx, surf)
    roscoe, coulomb = 45.0 + PSI_DEG / 2.0, 45.0 + PHI_DEG / 2.0
    outside = max(0.0, roscoe - angle_on, angle_on - coulomb)
    x_a, runout_min, angle_max = static_bounds()
    ke = body.kinetic_energy()
    sens_angles = onset_sensitivity(x0, sens, dx)
    log.info("dx %.4g: run-out at the 2 mm contour %.4f m (%+.1f %%), last particle %.4f m; "
             "surface rms %.2f mm; final failure line %.2f deg (experiment %.2f); onset %.2f "
             "deg (bracket %.1f-%.1f) at t = %.3f s; KE end %.3g J/m; %d steps in %.1f s", dx,
             runout_c, 100 * (runout_c / RUNOUT_EXP - 1), runout, rms, angle, exp_angle,
             angle_on, roscoe, coulomb, onset["t"], ke, sim.n_steps, wall)
    plot_one(out_dir / f"column_collapse_dx{dx:g}.png", dx, b, onset, exp, pts, pts_on,
             runout_c, angle, angle_on, exp_angle)
    return record(f"dx={dx:g}", dx, b.n, sim.n_steps, wall, psteps,
                  {"runout_pct": 100.0 * (runout_c - RUNOUT_EXP) / RUNOUT_EXP,
                   "surface_rms_mm": rms,
                   "failure_angle_final_diff_deg": angle - exp_angle,
                   "onset_outside_bracket_deg": outside},
                  {"runout_contour_m": runout_c, "runout_m": runout,
                   "failure_angle_final_deg": angle,
                   "failure_angle_final_exp_deg": exp_angle,
                   "failure_angle_final_eps_deg": angle_eps,
                   "failure_angle_final_sensitivity_deg": angle_sens,
                   "failure_angle_onset_deg": angle_on, "t_onset": onset["t"],
                   "roscoe_angle_deg": roscoe, "coulomb_angle_deg": coulomb,
                   "static_min_runout_m": runout_min,
                   "static_max_final_angle_deg": angle_max, "static_max_top_m": x_a,
                   "final_kinetic_energy": ke, "t_end": t_end,
                   "onset_angle_sensitivity_deg": sens_angles})


def plot_one(path, dx, b, onset, exp, pts, pts_on, runout_c, angle, angle_on, exp_angle):
    """Final deposit over the experiment's (bars that moved / did not), and the initial
    configuration coloured by the plastic strain at failure onset."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    surf, exp_line = exp
    x, x0 = b["x"], b["x0"]
    moved = np.linalg.norm(x - x0, axis=1) >= STATIC_DISP
    fig, axes = plt.subplots(2, 1, figsize=(10, 6.2), layout="constrained")
    ax = axes[0]
    ax.scatter(x[moved, 0], x[moved, 1], s=2, c="#e8b04a", linewidths=0,
               label=f"fsi_sph: moved >= {1e3 * STATIC_DISP:g} mm")
    ax.scatter(x[~moved, 0], x[~moved, 1], s=2, c="#4a6fa5", linewidths=0,
               label="fsi_sph: static")
    xs = np.arange(0.0, x[:, 0].max() + 2 * dx, 0.25 * dx)
    ax.plot(xs, deposit_height(x, dx, xs), "-", color="#b5551d", lw=1.2,
            label="fsi_sph: deposit height (volume-equivalent)")
    ax.plot(surf[:, 0], surf[:, 1], "k-", lw=2.0, label="experiment: final surface")
    ax.plot(exp_line[:, 0], exp_line[:, 1], "k--", lw=2.0,
            label=f"experiment: failure line ({exp_angle:.1f} deg)")
    if _line(pts) is not None:
        ax.plot(*_line(pts).T, "r-", lw=2.0, label=f"fsi_sph: failure line ({angle:.1f} deg)")
    ax.plot([runout_c] * 2, [0.0, 0.012], "r-", lw=2.0)
    ax.plot([RUNOUT_EXP] * 2, [0.0, 0.012], "k-", lw=2.0)
    ax.annotate(f"toe at 2 mm: {runout_c:.3f} m (experiment {RUNOUT_EXP} m)",
                (runout_c, 0.012), xytext=(-150, 20), textcoords="offset points", fontsize=8,
                arrowprops={"arrowstyle": "-", "color": "0.4"})
    ax.set_title(f"Column collapse (Bui et al. 2008), dx = {dx:g} m: final deposit over the "
                 "experiment's", fontsize=10)
    ax.legend(fontsize=7, loc="upper right", markerscale=4)
    ax = axes[1]
    sc = ax.scatter(x0[:, 0], x0[:, 1], c=np.minimum(onset["eps_p"], 0.2), s=2,
                    cmap="viridis", linewidths=0)
    fig.colorbar(sc, ax=ax, label="plastic strain at onset (clipped at 0.2)", shrink=0.4,
                 location="bottom", aspect=40)
    ax.plot(*_ray(45 + PSI_DEG / 2).T, "k--", lw=1.5,
            label=f"Roscoe 45 + psi/2 = {45 + PSI_DEG / 2:.1f} deg")
    ax.plot(*_ray(45 + PHI_DEG / 2).T, "k-.", lw=1.5,
            label=f"Coulomb 45 + phi/2 = {45 + PHI_DEG / 2:.1f} deg")
    if _line(pts_on) is not None:
        ax.plot(*_line(pts_on).T, "r-", lw=2.0, label=f"fitted onset line ({angle_on:.1f} deg)")
    ax.set_title(f"initial configuration, plastic strain at failure onset (t = {onset['t']:.3f} "
                 "s)", fontsize=10)
    ax.legend(fontsize=7, loc="upper right")
    for ax in axes:
        ax.set_xlim(0.0, max(0.46, runout_c + 0.02))
        ax.set_ylim(-0.003, 0.106)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    fig.savefig(path, dpi=120)
    plt.close(fig)


def validate(quick=False, data_dir="../shared/validation_data", out_dir=None):
    from pathlib import Path

    out_dir = Path(out_dir or "validation/results/column_collapse")
    out_dir.mkdir(parents=True, exist_ok=True)
    exp = load_experiment(data_dir)
    ladder = [0.005] if quick else [0.005, 0.0025, 0.002]
    t_end = 0.8  # the deposit is at rest by 0.6 s (kinetic energy recorded)
    recs = [run_one(dx, t_end, out_dir, exp) for dx in ladder]
    result = {"case": CASE,
              "reference": "Bui et al. 2008 aluminium-bar column, experiment's final deposit: "
                           "toe (2 mm contour) 0.442 m, surface heights 77.6 / 47.4 / 22.1 mm at "
                           "x = 0.1 / 0.2 / 0.3 m, failure line about 32 deg; onset line between "
                           "the Roscoe (45 deg) and Coulomb (54.9 deg) angles",
              "targets": {"|runout_pct| below": 10.0, "surface_rms_mm below": 8.0,
                          "|failure_angle_final_diff_deg| below": 5.0,
                          "stretch": {"runout_pct": 5.0, "surface_rms_mm": 5.0,
                                      "failure_angle_final_diff_deg": 3.0}},
              "records": recs}
    (out_dir / "column_collapse.json").write_text(json.dumps(result, indent=1))
    return result
