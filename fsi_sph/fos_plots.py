"""The outputs of ``fsi-sph fos`` (:mod:`fsi_sph.strength_reduction`): ``result.json``, the
slip surface drawn on the geostatic configuration with the limit-equilibrium circle, and the
displacement against the strength reduction factor."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np


def _save(fig, path):
    import matplotlib.pyplot as plt

    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def profile_plot(path, title, panels, xlim=None, ylim=None, circle=None, extra=None):
    """Particles of each panel ``(label, x, colour_values, colour_label[, lines])`` over each
    other, with an optional slip circle ``(xc, yc, R)``, extra polylines ``[(label, xy), ...]``
    on every panel and a panel's own ``lines`` (same form) on it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(panels), 1, figsize=(9, 3.2 * len(panels)), squeeze=False)
    for ax, panel in zip(axes[:, 0], panels, strict=True):
        label, x, c, clabel = panel[:4]
        lines = list(extra or []) + list(panel[4] if len(panel) > 4 else [])
        sc = ax.scatter(x[:, 0], x[:, 1], c=c, s=4, cmap="viridis")
        fig.colorbar(sc, ax=ax, label=clabel)
        if circle is not None:
            t = np.linspace(0, 2 * math.pi, 400)
            ax.plot(circle[0] + circle[2] * np.cos(t), circle[1] + circle[2] * np.sin(t), "r-",
                    lw=1.5, label="critical circle (Bishop)")
        for k, (elabel, xy) in enumerate(lines):
            xy = np.asarray(xy)
            ax.plot(xy[:, 0], xy[:, 1], ("k--", "r-.", "m:", "c--")[k % 4], lw=1.2, label=elabel)
        if xlim:
            ax.set_xlim(*xlim)
        if ylim:
            ax.set_ylim(*ylim)
        ax.set_aspect("equal")
        ax.set_title(label, fontsize=9)
        if circle is not None or lines:
            ax.legend(fontsize=7, loc="upper right")
    fig.suptitle(title, fontsize=10)
    return _save(fig, path)


def slip_surface_plot(res, path, title=None):
    """Accumulated plastic strain of the lowest failed trial on the geostatic configuration,
    with the limit-equilibrium critical circle, and the deformed configuration."""
    geo = res.geometry
    prof = np.asarray(geo["profile"])
    H = geo["height"]
    c = res.circle
    eps = np.minimum(res.eps_p_fail, 0.05)
    F = min(t["F"] for t in res.trials if t["verdict"] == "failed")
    return profile_plot(
        path, title or f"{res.body}: SPH FoS {res.label} (strength reduction, dx = "
        f"{res.dx:g} m) vs Bishop {res.fos_bishop:.3f}",
        [(f"geostatic configuration coloured by accumulated plastic strain of the lowest "
          f"failed trial F = {F:.3f} (clipped at 0.05)", res.x_geo, eps, "eps_p"),
         ("deformed configuration of that trial", res.x_fail, eps, "eps_p")],
        xlim=(prof[0, 0] - 0.05 * H, prof[-1, 0] + 0.05 * H),
        ylim=(geo["y_floor"] - 0.3 * H, prof[:, 1].max() + 0.3 * H),
        circle=(c["xc"], c["yc"], c["R"]), extra=[("ground profile", prof)])


def curve_plot(res, path):
    """Trial displacement u98 (end of the trial, in H) against F, by verdict."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    H = res.geometry["height"]
    tr = sorted(res.trials, key=lambda t: t["F"])
    fig, ax = plt.subplots(figsize=(6, 4))
    F = [t["F"] for t in tr]
    ax.semilogy(F, [t["u98_m"] / H for t in tr], "k-", lw=0.8)
    for v, mk in (("stable", "bo"), ("failed", "rx")):
        pts = [(t["F"], t["u98_m"] / H) for t in tr if t["verdict"] == v]
        if pts:
            ax.semilogy(*zip(*pts, strict=True), mk, label=v)
    if res.fos is not None:
        ax.axvline(res.fos, color="g", ls="--", label=f"SPH FoS {res.fos:.3f}")
    ax.axvline(res.fos_bishop, color="r", ls=":", label=f"Bishop {res.fos_bishop:.3f}")
    ax.set_xlabel("strength reduction factor F")
    ax.set_ylabel("u98 at the end of the trial / H")
    ax.set_title(f"{res.body}: displacement vs F (trial {res.settings['trial_s']:.3g} s)",
                 fontsize=9)
    ax.legend(fontsize=8)
    return _save(fig, path)


def write_outputs(res, out_dir, stem="fos"):
    """``result.json`` and the two PNGs into ``out_dir``; returns their paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    j = out_dir / "result.json"
    j.write_text(json.dumps({"method": "sph", **res.to_json()}, indent=1))
    paths = [j]
    if res.eps_p_fail is not None:
        paths.append(slip_surface_plot(res, out_dir / f"{stem}_slip_surface.png"))
    paths.append(curve_plot(res, out_dir / f"{stem}_displacement_vs_F.png"))
    return paths
