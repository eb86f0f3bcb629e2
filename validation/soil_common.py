"""Helpers shared by the soil validations (column collapse, slopes): running a case at a given
spacing, the shared JSON record, deposit measurements and plots.

Not a validation itself (``fsi-sph validate`` would list it, but it has no ``validate``).
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from fsi_sph.config import load_config
from fsi_sph.fos_plots import profile_plot  # noqa: F401 (re-exported)
from fsi_sph.simulation import Simulation
from fsi_sph.strength_reduction import advance  # noqa: F401 (re-exported)

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
