"""Helpers shared by the soil validations (column collapse, slopes): running a case at a given
spacing, the shared JSON record, deposit measurements and plots.

Not a validation itself (``fsi-sph validate`` would list it, but it has no ``validate``).
"""

from __future__ import annotations

import logging
import math
import time
from pathlib import Path

import numpy as np

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation

log = logging.getLogger(__name__)

REPO = Path(__file__).resolve().parents[1]
CASES = REPO / "cases"


def build(case, dx=None, overrides=()):
    """Simulation of ``cases/<case>.toml`` at spacing ``dx`` (None: the case's own)."""
    ov = list(overrides)
    if dx is not None:
        ov.append(f"case.dx={dx!r}")
    cfg = load_config(CASES / f"{case}.toml", ov)
    return Simulation(cfg)


def advance(sim, t_end, on_step=None):
    """Step ``sim`` to ``t_end`` (checking for NaN every 200 steps); returns the wall time of
    the stepping loop alone and the particle-steps it made."""
    ps0 = sim.particle_steps
    t0 = time.perf_counter()
    eps = 1e-12 * max(t_end, 1.0)
    k = 0
    while sim.t < t_end - eps:
        sim.step(dt_max=t_end - sim.t)
        k += 1
        if k % 200 == 0:
            sim.check()
        if on_step is not None:
            on_step(sim)
    sim.check()
    return time.perf_counter() - t0, sim.particle_steps - ps0


def record(label, dx, n, steps, wall, particle_steps, errors, values):
    """One entry of the shared JSON record format."""
    return {"label": label, "dx": dx, "n_particles": int(n), "steps": int(steps),
            "wall_time_s": round(float(wall), 3),
            "particle_steps_per_s": float(particle_steps / max(wall, 1e-12)),
            "errors": {k: float(v) for k, v in errors.items()},
            "values": {k: (float(v) if isinstance(v, (int, float, np.floating)) else v)
                       for k, v in values.items()}}


def deposit_toe(x, dx, y_floor=0.0):
    """Run-out of a deposit: the right end of the contiguous deposit seen from the back wall.

    The x axis is cut in bins of width ``dx``; walking right from the first occupied bin, the
    deposit ends before the first gap of two empty bins (so that single particles thrown
    ahead of the front do not count). Returns the largest x of a particle in the deposit plus
    ``dx/2`` (the particle's own extent).
    """
    xs = x[:, 0]
    lo = xs.min()
    k = np.floor((xs - lo) / dx).astype(int)
    occ = np.bincount(k)
    last = 0
    gap = 0
    for b, c in enumerate(occ):
        if c > 0:
            last = b
            gap = 0
        else:
            gap += 1
            if gap >= 2:
                break
    return float(xs[k <= last].max() + 0.5 * dx)


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
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
