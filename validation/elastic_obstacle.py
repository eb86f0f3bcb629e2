"""Dam break on an elastic obstacle (Walhorn et al. 2005; PHYSICS.md §8, [F 3-2]).

Horizontal displacement of the obstacle's top-right corner against the published record: six
digitised curves in ``walhorn2005_dam_break_elastic_obstacle/`` (Walhorn et al. 2005, the
original benchmark, 41.4 mm at 0.246 s; Idelsohn et al. 2008; Rafiee & Thiagarajan 2009; Li;
Meduri et al. 2018, 49.1 mm; Ryzhakov et al. 2010, 41.0 mm) and three more first peaks read
from figures (SOURCE.md). The published first peaks span 41.0-49.1 mm: the case's own spread.

- ``values.peak_mm``, ``values.peak_time_s``: our first peak (the largest displacement
  before 0.35 s) and its time; ``values.in_band``: 1 if the peak lies in PEAK_BAND_MM (the
  published spread with the digitisation tolerance, 39-51 mm) at PEAK_BAND_T (0.21-0.26 s);
- ``errors.peak_pct_walhorn``: the first peak against Walhorn's 41.4 mm, in percent;
  ``errors.peak_pct``: against the middle of the published spread (45 mm), kept for the record;
- ``values.ladder_change_pct``: the change of the first peak between the two finest rungs
  (the convergence target: within 3 %);
- ``values.rms_mm_<curve>``: RMS difference against each curve over its points in 0 .. t_end;
- ``values.published_peaks``: every published first peak with its time (the table the report
  and the plot show).

Ladder: dx = 4, 3, 2, 1.5 mm (3, 4, 6, 8 particles across the 12 mm obstacle); ``--quick``
runs the coarsest.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from fsi_sph.errors import SimulationError
from validation.common import CASES, machine, make_record, run_case, write_outputs
from validation.elastic_gate import summary_of

CASE = CASES / "dam_break_elastic_obstacle.toml"
LADDER = [("3 across", 0.004), ("4 across", 0.003), ("6 across", 0.002),
          ("8 across", 0.0015)]
PEAK_BAND_MM = (39.0, 51.0)  # published spread 41.0-49.1 mm with the digitisation tolerance
PEAK_BAND_T = (0.21, 0.26)
WALHORN_PEAK_MM = 41.4  # Walhorn et al. 2005, the original benchmark (SOURCE.md)
SPREAD_MID_MM = 45.0
LADDER_CHANGE_PCT = 3.0  # the two finest rungs agree within this
FIRST_PEAK_BEFORE = 0.35  # s: the first peak is the largest displacement before this time
CSV_CURVES = {"Walhorn et al. 2005": "walhorn.csv", "Idelsohn et al. 2008": "idelsohn.csv",
              "Rafiee & Thiagarajan 2009": "rafiee.csv", "Li": "li.csv"}
# first peaks read from figures, no curve file (SOURCE.md): (mm, s)
FIGURE_PEAKS = {"Liu 2013 (SPH)": (46.5, 0.253), "Sun et al. 2019 (MPS-DEM)": (46.2, 0.217),
                "Bogaers et al. 2016": (45.0, 0.232)}


def load_reference(data_dir):
    """``{name: (t, ux)}`` of the six published curves (the CSV files' two padding points
    ``(0, 0)``, ``(0.1, 0)`` dropped: they are not data)."""
    folder = Path(data_dir) / "walhorn2005_dam_break_elastic_obstacle"
    d = np.loadtxt(folder / "refSol_meduri_ryzhakov.tsv", skiprows=1)
    refs = {}
    for name, fname in CSV_CURVES.items():
        c = np.loadtxt(folder / fname, delimiter=",", skiprows=1)
        c = c[c[:, 0] > 0.1 + 1e-12]
        refs[name] = (c[:, 0], c[:, 1])
    refs["Meduri et al. 2018"] = (d[:, 0], d[:, 1])
    refs["Ryzhakov et al. 2010"] = (d[:, 0], d[:, 2])
    return refs


def published_peaks(refs):
    """``{name: {"peak_mm", "peak_time_s"}}``: every curve's first peak and the figure-only
    ones."""
    out = {}
    for name, (tr, ur) in refs.items():
        tp, up = first_peak(tr, ur)
        out[name] = {"peak_mm": round(1e3 * up, 2), "peak_time_s": round(tp, 4)}
    for name, (mm, ts) in FIGURE_PEAKS.items():
        out[name] = {"peak_mm": mm, "peak_time_s": ts}
    return out


def first_peak(t, ux):
    """(time, value) of the largest horizontal displacement before FIRST_PEAK_BEFORE."""
    sel = t <= FIRST_PEAK_BEFORE
    k = int(np.argmax(np.where(sel, ux, -np.inf)))
    return float(t[k]), float(ux[k])


def compare(t, ux, refs):
    tp, up = first_peak(t, ux)
    peak_mm = 1e3 * up
    values = {"peak_mm": peak_mm, "peak_time_s": tp,
              "in_band": float(PEAK_BAND_MM[0] <= peak_mm <= PEAK_BAND_MM[1]
                               and PEAK_BAND_T[0] <= tp <= PEAK_BAND_T[1])}
    for name, (tr, ur) in refs.items():
        inside = tr <= t[-1] + 1e-9
        diff = np.interp(tr[inside], t, ux) - ur[inside]
        key = "rms_mm_" + name.split()[0].lower()
        values[key] = 1e3 * math.sqrt(float(np.mean(diff ** 2))) if inside.any() else math.nan
    errors = {"peak_pct_walhorn": 100.0 * (peak_mm - WALHORN_PEAK_MM) / WALHORN_PEAK_MM,
              "peak_pct": 100.0 * (peak_mm - SPREAD_MID_MM) / SPREAD_MID_MM}
    return errors, values


def ladder_change_pct(records):
    """Change of the first peak between the two finest rungs, in percent of the finer."""
    if len(records) < 2:
        return math.nan
    a, b = (r["values"]["peak_mm"] for r in records[-2:])
    return 100.0 * abs(b - a) / b


def plot(runs, refs, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.8), layout="constrained")
    styles = ("-", "--", ":", "-.", (0, (5, 1, 1, 1)), (0, (1, 3)))
    for (name, (tr, ur)), style in zip(refs.items(), styles, strict=True):
        ax.plot(tr, 1e3 * ur, linestyle=style, color="0.3", lw=1.0, label=name)
    fig_t = [ts for _, ts in FIGURE_PEAKS.values()]
    fig_mm = [mm for mm, _ in FIGURE_PEAKS.values()]
    ax.plot(fig_t, fig_mm, "kx", ms=6,
            label="first peaks from figures: " + ", ".join(n.split(" (")[0] for n in FIGURE_PEAKS))
    ax.add_patch(plt.Rectangle((PEAK_BAND_T[0], PEAK_BAND_MM[0]),
                               PEAK_BAND_T[1] - PEAK_BAND_T[0],
                               PEAK_BAND_MM[1] - PEAK_BAND_MM[0], color="0.88", zorder=0,
                               label="published first peaks 41-49 mm, with tolerance"))
    for label, (t, ux) in runs.items():
        ax.plot(t, 1e3 * ux, lw=1.6, label=f"fsi_sph, {label}")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("horizontal displacement of the top corner (mm)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def validate(quick=False, data_dir="../shared/validation_data",
             out_dir="validation/results/elastic_obstacle"):
    from fsi_sph.output import read_probe

    out = Path(out_dir)
    refs = load_reference(data_dir)
    ladder = LADDER[:1] if quick else LADDER
    records, runs = [], {}
    for label, dx in ladder:
        run_dir = out / f"dx_{dx:.5g}"
        try:
            _, s = run_case(CASE, [f"case.dx={dx}"], out_dir=run_dir)
        except SimulationError as e:  # record it; compare what ran
            s = summary_of(run_dir / "run.h5")
            s["status"] = f"failed: {e}"
        t, c = read_probe(run_dir / "run.h5", "obstacle_tip")
        errors, values = compare(t, c["ux"], refs)
        values.update(status=s["status"], t_reached_s=float(t[-1]))
        records.append(make_record(label, dx, s, errors, values))
        runs[label] = (t, c["ux"])
    plot(runs, refs, out / "obstacle_displacement.png")
    peaks = published_peaks(refs)
    change = ladder_change_pct(records)
    records[-1]["values"]["ladder_change_pct"] = change
    records[-1]["values"]["published_peaks"] = peaks
    result = {"case": "elastic_obstacle",
              "reference": "published record (six curves, three more peaks): first peaks "
                           "41.0-49.1 mm at 0.22-0.26 s; Walhorn et al. 2005 41.4 mm at 0.246 s",
              "machine": machine(), "records": records,
              "published_peaks": peaks,
              "targets": {"finest peak_mm in": list(PEAK_BAND_MM),
                          "finest peak_time_s in": list(PEAK_BAND_T),
                          "ladder_change_pct below": LADDER_CHANGE_PCT},
              # the published models on the error-vs-time plot (no run time known)
              "marks": {name: {"peak_pct_walhorn": 100.0 * (p["peak_mm"] - WALHORN_PEAK_MM)
                               / WALHORN_PEAK_MM}
                        for name, p in peaks.items() if not name.startswith("Walhorn")}}
    write_outputs(result, out, ["peak_pct_walhorn"], "Elastic obstacle: error vs wall time")
    return result
