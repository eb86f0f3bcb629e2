"""Factor of safety of the slopes of [S 5-5]: SPH shear strength reduction vs Bishop's
simplified method with a critical-circle search, both from the package
(:mod:`fsi_sph.strength_reduction`, :mod:`fsi_sph.soil.limit_equilibrium`: the code of
``fsi-sph fos CASE``). Geometry, damping, durations and the failure test (does the slope come
to rest?) come from the case and the method's defaults, the same for every slope; the
scripts ``slope_N.py`` give only the case, the body and the spacings.
"""

from __future__ import annotations

import json
import logging
import time

from fsi_sph.config import load_config
from fsi_sph.fos_plots import curve_plot, slip_surface_plot
from fsi_sph.strength_reduction import (
    limit_equilibrium,
    slope_geometry,
    soil_body_name,
    strength_reduction,
)
from validation.soil_common import CASES, record

log = logging.getLogger(__name__)


class Slope:
    """A slope validation: the case (``cases/<case>.toml`` unless ``path`` names the file),
    its soil body, the spacings, and published factors of safety ``{label: FoS}`` of the same
    slope (``reference_fe``: the one the SPH value is also compared with, ``errors.fos_pct_fe``,
    signed)."""

    def __init__(self, case, body, ladder=(), quick_ladder=(), path=None, published=None,
                 reference_fe=None, reference=None):
        self.case, self.body = case, body
        self.ladder, self.quick_ladder = ladder, quick_ladder
        self.path = path or CASES / f"{case}.toml"
        self.published, self.reference_fe = published or {}, reference_fe
        self.reference = reference


def validate_slope(slope: Slope, quick=False, out_dir=None, label=None):
    from pathlib import Path

    out_dir = Path(out_dir or f"validation/results/{slope.case}")
    out_dir.mkdir(parents=True, exist_ok=True)
    path = slope.path
    cfg = load_config(path)
    body = soil_body_name(cfg, slope.body)
    geo = slope_geometry(cfg, body)
    t0 = time.perf_counter()
    circ = limit_equilibrium(cfg, body, geo)
    t_le = time.perf_counter() - t0
    log.info("%s: Bishop critical circle F = %.4f (centre %.2f, %.2f, R %.2f) in %.1f s",
             slope.case, circ.fos, circ.xc, circ.yc, circ.R, t_le)
    recs = []
    for dx in (slope.quick_ladder if quick else slope.ladder):
        res = strength_reduction(path, body, [f"case.dx={dx!r}"], circle=circ)
        err = abs(res.fos - circ.fos) / circ.fos * 100.0
        errors = {"fos_pct": err}
        if slope.reference_fe:
            fe = slope.published[slope.reference_fe]
            errors["fos_pct_fe"] = 100.0 * (res.fos - fe) / fe
        log.info("%s dx %.3g: SPH FoS %.4f (bracket %s) vs Bishop %.4f: %.1f %%", slope.case,
                 dx, res.fos, res.bracket, circ.fos, err)
        slip_surface_plot(res, out_dir / f"{slope.case}_dx{dx:g}.png")
        curve_plot(res, out_dir / f"{slope.case}_dx{dx:g}_displacement_vs_F.png")
        recs.append(record(f"dx={dx:g}", dx, res.n_particles, res.steps, res.wall_time_s,
                           res.particle_steps, errors,
                           {"fos_sph": res.fos, "fos_bishop": circ.fos,
                            "sph_bracket_lo": res.bracket[0],
                            "sph_bracket_hi": res.bracket[1],
                            "circle_xc": circ.xc, "circle_yc": circ.yc, "circle_R": circ.R,
                            "bishop_wall_time_s": t_le,
                            "settings": json.dumps(res.settings),
                            "trials": json.dumps(res.trials)}))
    result = {"case": label or slope.case,
              "reference": "limit equilibrium: Bishop's simplified method, critical circle "
                           "search (fsi_sph/soil/limit_equilibrium.py)"
                           + (f"; {slope.reference}" if slope.reference else ""),
              "records": recs}
    if slope.published:  # published values of the same slope, by the same measures
        fe = slope.published.get(slope.reference_fe)
        result["marks"] = {k: {"fos_pct": abs(v - circ.fos) / circ.fos * 100.0,
                               **({"fos_pct_fe": 100.0 * (v - fe) / fe} if fe else {})}
                           for k, v in slope.published.items()}
        result["values"] = {"published_fos": slope.published}
    (out_dir / f"{slope.case}.json").write_text(json.dumps(result, indent=1))
    return result
