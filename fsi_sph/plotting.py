"""Matplotlib figures of a run file: particle snapshots coloured by a field, probe series."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from fsi_sph.errors import UsageError


def _scalar(values):
    """A per-particle scalar from a field: vectors -> magnitude, tensors -> Frobenius norm."""
    v = np.asarray(values)
    if v.ndim == 1:
        return v
    return np.sqrt(np.sum(v.reshape(len(v), -1) ** 2, axis=1))


def plot_run(path, out_dir, field="von_mises", max_snapshots=12):
    """Write ``snapshot_<k>.png`` for evenly spaced snapshots and ``probe_<name>.png`` for
    every probe; returns the list of files written."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    files = []
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        raise UsageError(f"{path}: not a readable HDF5 run file ({e})") from None
    with f:
        if "snapshots" not in f:
            raise UsageError(f"{path}: not an fsi_sph run file (no /snapshots)")
        snaps = sorted(f["snapshots"])
        if not snaps:
            raise UsageError(f"{path}: the run has no snapshot")
        pick = np.unique(np.linspace(0, len(snaps) - 1, min(max_snapshots, len(snaps))).astype(int))
        fields = set()
        for b in f["snapshots"][snaps[0]]:
            fields |= set(f["snapshots"][snaps[0]][b])
        if field not in fields:
            raise UsageError(f"--field {field}: not in this run; available: "
                             f"{', '.join(sorted(fields))}")
        # common colour scale and axes over the snapshots shown
        lo, hi = np.inf, -np.inf
        xlo, xhi = np.full(2, np.inf), np.full(2, -np.inf)
        for k in pick:
            for g in f["snapshots"][snaps[k]].values():
                if field not in g:  # e.g. wall particles carry only x and p
                    continue
                s = _scalar(g[field][()])
                lo, hi = min(lo, s.min()), max(hi, s.max())
                x = g["x"][()]
                xlo, xhi = np.minimum(xlo, x.min(0)), np.maximum(xhi, x.max(0))
        pad = 0.05 * max(xhi - xlo)
        for k in pick:
            g0 = f["snapshots"][snaps[k]]
            fig, ax = plt.subplots(figsize=(8, 4.5), layout="constrained")
            for g in g0.values():
                x = g["x"][()]
                if field not in g:
                    ax.scatter(x[:, 0], x[:, 1], s=2, c="0.6", linewidths=0)
                    continue
                sc = ax.scatter(x[:, 0], x[:, 1], c=_scalar(g[field][()]), s=4, vmin=lo, vmax=hi,
                                cmap="viridis", linewidths=0)
            fig.colorbar(sc, ax=ax, label=field)
            ax.set_aspect("equal")
            ax.set_xlim(xlo[0] - pad, xhi[0] + pad)
            ax.set_ylim(xlo[1] - pad, xhi[1] + pad)
            ax.set_xlabel("x (m)")
            ax.set_ylabel("y (m)")
            ax.set_title(f"t = {g0.attrs['t']:.4f} s  ({field})")
            name = out / f"snapshot_{k:04d}.png"
            fig.savefig(name, dpi=110)
            plt.close(fig)
            files.append(name)
        for pname, ds in f["probes"].items():
            cols = json.loads(ds.attrs["columns"])
            data = ds[()]
            fig, axes = plt.subplots(len(cols) - 1, 1, figsize=(7, 1.8 * (len(cols) - 1) + 0.6),
                                     sharex=True, layout="constrained", squeeze=False)
            for c, ax in enumerate(axes[:, 0], start=1):
                ax.plot(data[:, 0], data[:, c], lw=1.2)
                ax.set_ylabel(cols[c])
                ax.grid(alpha=0.3)
            axes[-1, 0].set_xlabel("t (s)")
            axes[0, 0].set_title(f"probe {pname}")
            name = out / f"probe_{pname}.png"
            fig.savefig(name, dpi=110)
            plt.close(fig)
            files.append(name)
    return files


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
