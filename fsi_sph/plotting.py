"""Matplotlib figures of a run file: particle snapshots coloured by a field, probe series."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from fsi_sph.plot_scene import DPI, SceneFigure, open_run, time_stamp  # noqa: E402
from fsi_sph.references import probe_references  # noqa: E402

log = logging.getLogger(__name__)


def plot_run(path, out_dir, field=None, max_snapshots=12, data_dir=None):
    """Write ``snapshot_<k>.png`` for evenly spaced snapshots (:class:`SceneFigure`) and
    ``probe_<name>.png`` for every probe (with its reference curves when the case names them
    and ``data_dir`` holds them); returns the list of files written."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    f, groups = open_run(path)
    with f:
        pick = np.unique(np.linspace(0, len(groups) - 1,
                                     min(max_snapshots, len(groups))).astype(int))
        scene = SceneFigure(f, [groups[k] for k in pick], field)
        files = []
        name = json.loads(f.attrs["config"])["case"]["name"]
        for k in pick:
            scene.draw(groups[k], time_stamp(groups[k], name))
            files.append(out / f"snapshot_{k:04d}.png")
            scene.fig.savefig(files[-1], dpi=DPI)
        scene.close()
        refs = probe_references(f.attrs["config"], data_dir)
        for pname, ds in f["probes"].items():
            files.append(plot_probe(pname, ds, refs.get(pname, []), out))
    return files


def plot_probe(name, ds, refs, out):
    """``probe_<name>.png`` (:func:`probe_figure`); returns the file."""
    fig = probe_figure(name, ds, refs)
    path = out / f"probe_{name}.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def probe_figure(name, ds, refs):
    """Each column of a probe (an h5py dataset) against time, with the reference curves
    drawn over their column."""
    cols = json.loads(ds.attrs["columns"])
    data = ds[()]
    for ref in refs:
        if ref["column"] not in cols:
            log.warning("probe %s: reference %r names column %r; the probe's columns are %s",
                        name, ref["label"], ref["column"], ", ".join(cols[1:]))
    fig, axes = plt.subplots(len(cols) - 1, 1, figsize=(7, 1.8 * (len(cols) - 1) + 0.6),
                             sharex=True, layout="constrained", squeeze=False)
    for c, ax in enumerate(axes[:, 0], start=1):
        ax.plot(data[:, 0], data[:, c], lw=1.2, label="this run")
        mine = [ref for ref in refs if ref["column"] == cols[c]]
        for ref in mine:
            ax.plot(ref["t"], ref["value"], "o", ms=4, mfc="none", label=ref["label"])
        if mine:
            ax.legend(fontsize=8)
        ax.set_ylabel(cols[c])
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("t (s)")
    axes[0, 0].set_title(f"probe {name}")
    return fig


def error_vs_time(records, error_keys, title, path, marks=None):
    """Log-log plot of each error in ``error_keys`` against wall time, one point per
    resolution (labelled). ``marks``: {label: {error_key: value}} drawn as horizontal lines
    (errors reported by other codes, no time known)."""
    fig, ax = plt.subplots(figsize=(6.4, 4.4), layout="constrained")
    t_all = np.array([r["wall_time_s"] for r in records])
    t = t_all[np.isfinite(t_all)] if np.isfinite(t_all).any() else np.array([1.0])
    for key in error_keys:
        # records that lack an error (e.g. one aspect ratio per record) are left out
        have = [r for r in records if key in r["errors"] and np.isfinite(r["wall_time_s"])]
        if not have:
            continue
        tk = np.array([r["wall_time_s"] for r in have])
        e = np.array([abs(r["errors"][key]) for r in have])
        ax.loglog(tk, np.maximum(e, 1e-3), "o-", label=key)
        for r, ti, ei in zip(have, tk, e, strict=True):
            ax.annotate(r["label"], (ti, max(ei, 1e-3)), textcoords="offset points",
                        xytext=(4, 4), fontsize=8)
    for lab, vals in (marks or {}).items():
        for key, v in vals.items():
            ax.axhline(v, ls=":", lw=1, color="gray")
            ax.text(t.min(), v, f" {lab}: {key} {v:g}", fontsize=7, va="bottom", color="gray")
    ax.set_xlabel("wall time (s)")
    ax.set_ylabel("|error| (%)")
    ax.set_title(title)
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
