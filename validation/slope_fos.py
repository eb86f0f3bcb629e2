"""Factor of safety of the slopes of [S 5-5]: SPH strength reduction vs Bishop's simplified
method with a critical-circle search (validation/bishop.py).

SPH strength reduction (the shear strength reduction technique, e.g. Griffiths & Lane 1999;
Bui et al. 2011 for SPH):

1. Geostatic state: the case is loaded by gravity with damping while the soil is held elastic
   (its strength raised far above any stress), for ``t_settle``; the state is stored.
2. Trial factor F: from the stored state, ``c_F = c/F`` and ``tan(phi_F) = tan(phi)/F``; the
   run continues with the same damping for ``t_trial``.
3. Failure criterion (a displacement criterion, stated before the runs, the same for every
   slope): with ``u98`` the 98th percentile over the particles of the displacement since the
   geostatic state and ``H`` the slope height, the slope has **failed** at F when
   ``u98 > FAIL_DISP * H`` at the end of the trial *and* ``u98`` still grows by more than
   ``FAIL_RATE * H`` over its last quarter (a slip that goes on, not a settlement at rest).
   A non-convergence flag is recorded beside it for every trial: growth over the last quarter
   above ``NC_RATE * H`` and at least ``NO_DECEL`` times the growth over the third quarter.
   With mass damping a slope just past failure creeps slowly, so the displacement criterion
   places F higher, and the non-convergence one lower (slow plastic creep counts as failure);
   the two bracket the answer (see the records' trials).
4. Bisection on F between a stable and a failed bracket; the SPH factor of safety is the mid
   point of the final bracket.

The slip surface is the accumulated plastic strain of the first failed trial (in the
geostatic configuration), plotted over Bishop's critical circle.
"""

from __future__ import annotations

import json
import logging
import math
import time
from pathlib import Path

import numpy as np

from validation.bishop import critical_circle
from validation.soil_common import advance, build, profile_plot, record

log = logging.getLogger(__name__)

FAIL_DISP = 0.02   # of H: u98 at the end of a trial
FAIL_RATE = 0.002  # of H: growth of u98 over the last quarter of a trial
NC_RATE = 5e-4     # of H: non-convergence flag (recorded): last-quarter growth ...
NO_DECEL = 0.7     # ... and at least this times the third-quarter growth


class Slope:
    def __init__(self, case, body, profile, height, x_wall=0.0, y_floor=0.0, ladder=(),
                 quick_ladder=(), t_settle=2.0, t_trial=4.0, damping=10.0, bracket=(0.7, 1.5),
                 tol=0.02):
        self.case, self.body, self.profile, self.height = case, body, profile, height
        self.x_wall, self.y_floor = x_wall, y_floor
        self.ladder, self.quick_ladder = ladder, quick_ladder
        self.t_settle, self.t_trial, self.damping = t_settle, t_trial, damping
        self.bracket, self.tol = bracket, tol


def _u98(body, x_ref):
    u = np.linalg.norm(body.body["x"] - x_ref, axis=1)
    return float(np.percentile(u, 98))


def strength_reduction(slope: Slope, dx: float):
    """SPH factor of safety of ``slope`` at spacing ``dx``; returns (fos, info dict)."""
    sim = build(slope.case, dx, [f"soil.{slope.body}.damping={slope.damping!r}"])
    body = sim.structures[slope.body]
    c0, phi0, psi0 = body.cohesion, body.phi, body.psi
    H = slope.height
    wall = 0.0
    psteps = 0
    steps0 = sim.n_steps
    # 1. geostatic state, elastic
    body.set_strength(1e12, phi0, 0.0)
    w, p = advance(sim, slope.t_settle)
    wall += w
    psteps += p
    saved = {k: v.copy() for k, v in body.body.arrays.items()}
    t_geo = sim.t
    x_geo = saved["x"].copy()
    log.info("%s dx %.3g: %d particles, geostatic state in %.1f s (KE %.3g)", slope.case, dx,
             body.body.n, w, body.kinetic_energy())

    trials = []

    def trial(F):
        nonlocal wall, psteps
        for k, v in saved.items():
            body.body.arrays[k][...] = v
        body.body["eps_p"][:] = 0.0
        sim.t = t_geo
        body.set_strength(c0 / F, math.atan(math.tan(phi0) / F), psi0)
        w0, p0 = advance(sim, t_geo + 0.5 * slope.t_trial)
        u_h = _u98(body, x_geo)
        w1, p1 = advance(sim, t_geo + 0.75 * slope.t_trial)
        u_q = _u98(body, x_geo)
        w2, p2 = advance(sim, t_geo + slope.t_trial)
        u_end = _u98(body, x_geo)
        wall += w0 + w1 + w2
        psteps += p0 + p1 + p2
        g3, g4 = u_q - u_h, u_end - u_q
        failed = u_end > FAIL_DISP * H and g4 > FAIL_RATE * H
        nonconv = g4 > NC_RATE * H and g4 >= NO_DECEL * g3
        rec = {"F": F, "u98_end_m": u_end, "u98_growth_q3_m": g3, "u98_growth_q4_m": g4,
               "failed": bool(failed), "non_converged": bool(nonconv)}
        trials.append(rec)
        log.info("  F = %.4f: u98 %.4g m (growth %.3g then %.3g m) -> %s", F, u_end, g3, g4,
                 "failed" if failed else "stable")
        return failed, body.body["x"].copy(), body.body["eps_p"].copy()

    lo, hi = slope.bracket
    failed_lo, *_ = trial(lo)
    fail_state = None
    while failed_lo and lo > 0.2:  # widen downwards until stable
        hi = lo
        lo = lo * 0.7
        failed_lo, *_ = trial(lo)
    res = trial(hi)
    while not res[0] and hi < 5.0:  # widen upwards until it fails
        lo = hi
        hi = hi * 1.4
        res = trial(hi)
    fail_state = res[1:]
    while hi - lo > slope.tol * lo:
        mid = 0.5 * (lo + hi)
        res = trial(mid)
        if res[0]:
            hi, fail_state = mid, res[1:]
        else:
            lo = mid
    fos = 0.5 * (lo + hi)
    info = {"wall": wall, "particle_steps": psteps, "steps": sim.n_steps - steps0,
            "n": body.body.n, "trials": trials, "bracket": [lo, hi], "x_geo": x_geo,
            "x_fail": fail_state[0], "eps_p_fail": fail_state[1]}
    return fos, info


def validate_slope(slope: Slope, quick=False, out_dir=None, label=None):
    out_dir = Path(out_dir or f"validation/results/{slope.case}")
    out_dir.mkdir(parents=True, exist_ok=True)
    from fsi_sph.config import load_config
    from validation.soil_common import CASES

    cfg = load_config(CASES / f"{slope.case}.toml")
    mat = cfg.soil[slope.body].material
    gamma = mat.rho0 * abs(cfg.case.gravity[1])
    t0 = time.perf_counter()
    circ = critical_circle(slope.profile, mat.cohesion, mat.friction_angle_deg, gamma,
                           x_wall=slope.x_wall, y_floor=slope.y_floor)
    t_le = time.perf_counter() - t0
    log.info("%s: Bishop critical circle F = %.4f (centre %.2f, %.2f, R %.2f) in %.1f s",
             slope.case, circ.fos, circ.xc, circ.yc, circ.R, t_le)
    recs = []
    for dx in (slope.quick_ladder if quick else slope.ladder):
        fos, info = strength_reduction(slope, dx)
        err = abs(fos - circ.fos) / circ.fos * 100.0
        log.info("%s dx %.3g: SPH FoS %.4f (bracket %s) vs Bishop %.4f: %.1f %%", slope.case,
                 dx, fos, info["bracket"], circ.fos, err)
        prof = np.asarray(slope.profile)
        profile_plot(
            out_dir / f"{slope.case}_dx{dx:g}.png",
            f"{slope.case}: SPH FoS {fos:.3f} (strength reduction, dx = {dx:g} m) vs Bishop "
            f"{circ.fos:.3f}",
            [(f"geostatic configuration coloured by accumulated plastic strain at the first "
              f"failed trial F = {info['bracket'][1]:.3f} (clipped at 0.05)", info["x_geo"],
              np.minimum(info["eps_p_fail"], 0.05), "eps_p"),
             ("deformed configuration of that trial", info["x_fail"],
              np.minimum(info["eps_p_fail"], 0.05), "eps_p")],
            xlim=(prof[0, 0] - 0.5, prof[-1, 0] + 2.0),
            ylim=(slope.y_floor - 0.5, prof[:, 1].max() + 0.3 * slope.height),
            circle=(circ.xc, circ.yc, circ.R), extra=[("ground profile", prof)])
        recs.append(record(f"dx={dx:g}", dx, info["n"], info["steps"], info["wall"],
                           info["particle_steps"], {"fos_pct": err},
                           {"fos_sph": fos, "fos_bishop": circ.fos,
                            "sph_bracket_lo": info["bracket"][0],
                            "sph_bracket_hi": info["bracket"][1],
                            "circle_xc": circ.xc, "circle_yc": circ.yc, "circle_R": circ.R,
                            "bishop_wall_time_s": t_le,
                            "trials": json.dumps(info["trials"])}))
    result = {"case": label or slope.case,
              "reference": "limit equilibrium: Bishop's simplified method, critical circle "
                           "search (validation/bishop.py)",
              "records": recs}
    (out_dir / f"{slope.case}.json").write_text(json.dumps(result, indent=1))
    return result
