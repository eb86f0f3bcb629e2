"""Factor of safety of a Drucker-Prager slope by shear strength reduction (``fsi-sph fos``).

Shear strength reduction (Griffiths & Lane 1999; Bui et al. 2011 for SPH), everything taken
from the case:

1. **Geometry** (:func:`slope_geometry`): the ground profile is the upper edge of the soil
   body's blocks, extended down a free end and along the floor beyond the toe (unless a right
   wall closes the body); the rigid floor and back wall are
   the case's bottom and left walls; the crest is the last highest point, the toe the first
   lowest point after it, the height ``H`` their difference.
2. **Geostatic state**: the case is loaded by gravity with mass damping while the soil is held
   elastic (its cohesion raised far above any stress) for ``SETTLE_TG`` gravity times
   ``t_g = sqrt(H/g)``; the state is stored.
3. **Trial factor F**: from the stored state, ``c/F`` and ``tan(phi)/F`` (``psi`` at most the
   reduced ``phi``), a damped run of ``TRIAL_TG t_g``. Damping ``xi = DAMPING_TG/t_g``: the
   same number of gravity times, whatever the slope's size.
4. **Failure test** (:func:`verdict`): does the slope come to rest? With ``u`` the 98th
   percentile of the displacement since the geostatic state over the particles with a full
   kernel support (:func:`resolved_mask`: the free-surface row, whose stress comes from a
   truncated support, is left out: alone it creeps down a cohesionless face at a lower F than
   the soil below it (slope 1 at dx 0.025: FoS 0.282 with it, 0.298 without;
   validation/README_soil.md)), ``g3`` and ``g4`` the growth over the third and the last
   quarter of the same percentile of the departure from an **elastic reference trial** (the
   geostatic stage continued for a trial's time, run once: the geostatic state's residual
   settling decays by about 0.7 per quarter at any F, and a slope that stays elastic departs
   from it by exactly nothing), the trial **failed**
   when ``g4 > REST_TOL u`` (still moving, relative to what it has moved) and
   ``g4 >= FAIL_DECEL g3`` (not slowing down), or when ``u > COLLAPSE H`` (a slip so large it
   may have come to rest again in its run-out). A slope at rest moves ~1e-5 of its
   displacement in the last quarter; a slipping one 0.2-0.3 (validation/README_soil.md).
   No absolute displacement enters: a large soft slope that settles by decimetres is stable,
   a shallow slip that keeps sliding by millimetres has failed.
5. **Bracket and bisection**: from ``[0.8, 1.25]`` times the limit-equilibrium factor of
   safety (Bishop, critical circle), widened until stable/failed, then bisected until
   ``hi - lo <= tol lo``; the factor of safety is the bracket's mid point. The widening stops
   at ``F_MAX`` and ``F_MIN``: a slope that still stands at ``F_MAX`` (or still fails at
   ``F_MIN``) is reported as a bound, ``status`` ``"stands_past"`` (``"fails_below"``),
   never as a number.
"""

from __future__ import annotations

import json
import logging
import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from fsi_sph.soil.limit_equilibrium import critical_circle

log = logging.getLogger(__name__)

FAIL_DECEL = 0.7   # failed: last-quarter growth at least this times the third-quarter one ...
REST_TOL = 1e-3    # ... and above this fraction of the trial's displacement
COLLAPSE = 0.1     # of H: a trial that moved this far has failed
DAMPING_TG = 10.0  # mass damping xi = DAMPING_TG / t_g
SETTLE_TG = 2.0    # geostatic stage, in t_g
TRIAL_TG = 4.0     # one trial, in t_g
TOL = 0.02         # bisection: hi - lo <= TOL lo
F_MAX = 5.0        # a slope that stands at this F is reported as "FoS > F_MAX"
F_MIN = 0.05       # ... and one that fails at this F as "FoS < F_MIN"
RESOLVED = 0.85    # Shepard sum below which a particle is in the free-surface row
QUARTERS = (0.25, 0.5, 0.75, 1.0)  # of a trial: where the displacement is read


class SlopeInputError(ValueError):
    """The case is not a slope that strength reduction can work on (bad input)."""


@dataclass
class SlopeGeometry:
    profile: list  # [(x, y), ...] ground surface, soil below, facing +x
    x_wall: float
    y_floor: float
    crest: tuple
    toe: tuple
    height: float

    @property
    def beta_deg(self):
        return math.degrees(math.atan2(self.height, self.toe[0] - self.crest[0]))


def soil_body_name(cfg, body=None):
    """The Drucker-Prager body to work on: ``body`` or the case's only soil body."""
    names = list(cfg.soil)
    if body is not None:
        if body not in cfg.soil:
            raise SlopeInputError(
                f"--body {body!r}: the case has no soil body of that name; its Drucker-Prager "
                f"bodies are {names or 'none'}.")
        return body
    if not names:
        raise SlopeInputError(
            "the case has no Drucker-Prager soil body ([soil.NAME] section): strength "
            "reduction works on a soil slope; see cases/slope_*.toml.")
    if len(names) > 1:
        raise SlopeInputError(
            f"the case has {len(names)} soil bodies ({', '.join(names)}): say which one to "
            "reduce with --body NAME.")
    return names[0]


def _vertices(shape):
    if getattr(shape, "shape", "rectangle") == "polygon":
        return np.asarray(shape.vertices, dtype=np.float64)
    (x0, y0), (sx, sy) = shape.origin, shape.size
    return np.array([[x0, y0], [x0 + sx, y0], [x0 + sx, y0 + sy], [x0, y0 + sy]])


def _top(polys, x):
    """Highest point of the union of the polygons on the vertical line at ``x``."""
    y = -math.inf
    for v in polys:
        for k in range(len(v)):
            (x1, y1), (x2, y2) = v[k], v[(k + 1) % len(v)]
            if min(x1, x2) <= x <= max(x1, x2):
                y = max(y, max(y1, y2) if x1 == x2 else y1 + (x - x1) * (y2 - y1) / (x2 - x1))
    return y


def slope_geometry(cfg, body):
    """Ground profile, floor, back wall, crest, toe and height of soil body ``body``."""
    polys = [_vertices(s) for s in cfg.soil[body].blocks]
    allv = np.concatenate(polys)
    xmin, xmax = float(allv[:, 0].min()), float(allv[:, 0].max())
    span = xmax - xmin
    eps = 1e-9 * span
    pts = []
    for x in np.unique(allv[:, 0]):
        y = _top(polys, x)  # the limits from either side differ only at a vertical edge
        yl, yr = (y if abs(_top(polys, min(max(x + d, xmin), xmax)) - y) <= 1e-6 * span
                  else _top(polys, min(max(x + d, xmin), xmax)) for d in (-eps, eps))
        x = float(x)
        pts.append((x, float(yl if x > xmin else yr)))
        if x < xmax and abs(yr - yl) > 1e-6 * span:
            pts.append((float(x), yr))
    walls = cfg.boundary.walls if cfg.boundary is not None else []
    bottom = [w.position for w in walls if w.side == "bottom"]
    left = [w.position for w in walls if w.side == "left"]
    right = [w.position for w in walls if w.side == "right"]
    y_floor = max(bottom) if bottom else float(allv[:, 1].min())
    x_wall = max(left) if left else xmin
    # beyond the body (unless a right wall closes it): down its free end to the floor, then
    # along the floor to a right wall or 2 (top - floor) further
    if not (right and abs(min(right) - xmax) <= 1e-6 * span):
        top_y = max(p[1] for p in pts)
        x_end = float(min(right)) if right else xmax + 2.0 * (top_y - y_floor)
        if pts[-1][1] > y_floor + 1e-6 * span:
            pts.append((xmax, float(y_floor)))
        pts.append((x_end, float(y_floor)))
    ys = np.array([p[1] for p in pts])
    top_y = ys.max()
    k_crest = int(np.flatnonzero(ys >= top_y - 1e-6 * span).max())
    rest = ys[k_crest:]
    k_toe = k_crest + int(np.flatnonzero(rest <= rest.min() + 1e-6 * span)[0])
    height = float(top_y - rest.min())
    if height <= 1e-3 * span:
        raise SlopeInputError(
            f"soil body {body!r} has a flat top (no face descending to the right of its "
            "highest point): there is no slope whose factor of safety could be found. "
            "Strength reduction needs a ground profile that falls from a crest to a toe "
            "towards +x, as in cases/slope_*.toml.")
    # drop points in the middle of straight runs
    keep = [pts[0]]
    for k in range(1, len(pts) - 1):
        (x0, y0), (x1, y1), (x2, y2) = keep[-1], pts[k], pts[k + 1]
        if abs((x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0)) > 1e-9 * span * span:
            keep.append(pts[k])
    keep.append(pts[-1])
    crest = pts[k_crest]
    toe = pts[k_toe]
    return SlopeGeometry(keep, float(x_wall), float(y_floor), crest, toe, float(height))


def limit_equilibrium(cfg, body, geo):
    """Bishop's simplified method, critical circle, on the case's soil (unreduced)."""
    mat = cfg.soil[body].material
    gamma = mat.rho0 * abs(cfg.case.gravity[1])
    try:
        return critical_circle(geo.profile, mat.cohesion, mat.friction_angle_deg, gamma,
                               x_wall=geo.x_wall, y_floor=geo.y_floor)
    except ValueError as e:  # no circle cuts the soil between the wall and the floor
        raise SlopeInputError(
            f"soil body {body!r}: {e} between the back wall x = {geo.x_wall:g} and the floor "
            f"y = {geo.y_floor:g} (crest {geo.crest}, toe {geo.toe}); strength reduction "
            "needs a slope that a slip circle can cut.") from None


def verdict(u, g3, g4, height):
    """``'failed'`` or ``'stable'`` from the trial's displacement ``u`` and its growth over
    the third and the last quarter (see the module docstring)."""
    if u > COLLAPSE * height:
        return "failed"
    if g4 > REST_TOL * u and g4 >= FAIL_DECEL * g3:
        return "failed"
    return "stable"


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


def search_bracket(trial, f_start, tol):
    """The bracket ``(lo, hi, status)`` of the factor of safety: ``trial(F, left)`` is True
    when the slope fails at ``F`` (``left``: an estimate of the trials still to make after
    it; each ``F`` is tried once). From ``[0.8, 1.25] f_start`` (clipped to
    ``[F_MIN, F_MAX]``), widened down until stable and up until failed, then bisected to
    ``hi - lo <= tol lo``. ``status``: ``"bracketed"``, ``"stands_past"`` (stable at
    ``F_MAX``: ``lo = F_MAX``, ``hi = None``), ``"fails_below"`` (failed at ``F_MIN``:
    ``lo = None``, ``hi = F_MIN``)."""
    seen = {}

    def failed(F, left):
        if F not in seen:
            seen[F] = trial(F, left)
        return seen[F]

    hi = min(max(1.25 * f_start, F_MIN), F_MAX)
    lo = max(min(0.8 * f_start, 0.8 * hi), F_MIN)
    while failed(lo, 1 + bisections(lo, hi, tol)):  # widen downwards until stable
        if lo <= F_MIN:
            return None, lo, "fails_below"
        hi, lo = lo, max(0.8 * lo, F_MIN)
    while not failed(hi, bisections(lo, hi, tol)):  # widen upwards until it fails
        if hi >= F_MAX:
            return hi, None, "stands_past"
        lo, hi = hi, min(1.25 * hi, F_MAX)
    while hi - lo > tol * lo:
        mid = 0.5 * (lo + hi)
        if failed(mid, bisections(lo, hi, tol) - 1):
            hi = mid
        else:
            lo = mid
    return lo, hi, "bracketed"


def bisections(lo, hi, tol):
    """Bisections that take the bracket ``[lo, hi]`` to ``hi - lo <= tol lo``."""
    if hi - lo <= tol * lo:
        return 0
    return math.ceil(math.log2((hi - lo) / (tol * lo)))


def _restore(sim, sb, saved, t_geo):
    """Back to the stored geostatic state (the start of every trial)."""
    for k, v in saved.items():
        sb.body.arrays[k][...] = v
    sb.body["eps_p"][:] = 0.0
    sim.t = t_geo


def _elastic_reference(sim, sb, saved, t_geo, t_g):
    """Positions at the trial's quarter marks of a trial held elastic (the geostatic
    stage continued): what every trial is measured against, so that the geostatic state's
    residual settling, which decays by about 0.7 per quarter whatever F, is not read as a
    slip (a slope at elastic rest departs from it by nothing)."""
    _restore(sim, sb, saved, t_geo)
    xs = []
    for q in QUARTERS:
        advance(sim, t_geo + q * TRIAL_TG * t_g)
        xs.append(sb.body["x"].copy())
    return xs


def _u98(x, x_ref):
    return float(np.percentile(np.linalg.norm(x - x_ref, axis=1), 98))


def resolved_mask(sb):
    """Particles whose kernel support is (nearly) full, wall ghosts included: Shepard sum
    ``V_i W(0) + sum_j V_j W_ij >= RESOLVED``. The others are the free-surface row, whose
    stress divergence comes from a truncated support."""
    from fsi_sph.sph.kernels import kernel_w

    sb.build_ghosts()
    n = sb.body.n
    cnt = np.diff(sb.nbr_start)
    i = np.repeat(np.arange(n), cnt)
    j = sb.nbr_j[: sb.nbr_start[n]]
    r = np.linalg.norm(sb.xa[i] - sb.xa[j], axis=1)
    w = np.array([kernel_w(sb.kernel, float(q), sb.h) for q in r])
    shep = np.bincount(i, weights=sb.ma[j] / sb.ra[j] * w, minlength=n)
    shep += sb.body["m"] / sb.body["rho"] * kernel_w(sb.kernel, 0.0, sb.h)
    return shep >= RESOLVED


@dataclass
class Result:
    body: str
    dx: float
    n_particles: int
    fos: float
    bracket: list
    fos_bishop: float
    circle: dict
    geometry: dict
    settings: dict
    trials: list = field(default_factory=list)
    status: str = "bracketed"  # or "stands_past" (FoS > bracket[0]), "fails_below" (< [1])
    wall_time_s: float = 0.0
    steps: int = 0
    particle_steps: int = 0
    x_geo: np.ndarray | None = None
    x_fail: np.ndarray | None = None
    eps_p_fail: np.ndarray | None = None

    @property
    def label(self):
        """The answer in words: the value, or the bound it passed."""
        if self.status == "stands_past":
            return f"> {self.bracket[0]:.3g} (stands at F = {self.bracket[0]:.3g})"
        if self.status == "fails_below":
            return f"< {self.bracket[1]:.3g} (fails at F = {self.bracket[1]:.3g})"
        return f"{self.fos:.4f}"

    def to_json(self):
        d = {k: v for k, v in asdict(self).items() if k not in ("x_geo", "x_fail", "eps_p_fail")}
        return d


def strength_reduction(case, body=None, overrides=(), tol=TOL, circle=None, on_trial=None):
    """SPH factor of safety of the soil ``body`` of the case file ``case`` with ``overrides``
    (``case.dx`` is the spacing); the overrides are applied after the method's own damping
    (``soil.NAME.damping``). ``circle``: a limit-equilibrium circle already found (else it
    is searched). ``on_trial(rec)`` is called after each trial (default: a log line)."""
    from fsi_sph.config import load_config
    from fsi_sph.simulation import Simulation

    cfg = load_config(case, list(overrides))
    body = soil_body_name(cfg, body)
    geo = slope_geometry(cfg, body)
    g = abs(cfg.case.gravity[1])
    t_g = math.sqrt(geo.height / g)
    xi = DAMPING_TG / t_g
    if circle is None:
        circle = limit_equilibrium(cfg, body, geo)
    cfg = load_config(case, [f"soil.{body}.damping={xi!r}", *overrides])
    sim = Simulation(cfg)
    sb = sim.structures[body]
    c0, phi0, psi0 = sb.cohesion, sb.phi, sb.psi
    H = geo.height
    t_start = time.perf_counter()
    steps0, ps0 = sim.n_steps, sim.particle_steps
    sb.set_strength(1e12, phi0, 0.0)  # 1. geostatic state, elastic
    advance(sim, sim.t + SETTLE_TG * t_g)
    saved = {k: v.copy() for k, v in sb.body.arrays.items()}
    t_geo = sim.t
    x_geo = saved["x"].copy()
    inner = resolved_mask(sb)
    log.info("%s: %d particles (dx %.3g m), H %.3g m, t_g %.3g s, damping %.3g 1/s; "
             "geostatic state in %.1f s", body, sb.body.n, cfg.case.dx, H, t_g, xi,
             time.perf_counter() - t_start)
    x_elastic = _elastic_reference(sim, sb, saved, t_geo, t_g)
    trials = []
    fail_state = {}
    report = on_trial or (lambda r: log.info(
        "  F = %.4f: u98 %.4g m (%.2f %% H), growth %.3g then %.3g m -> %s (%.1f s)", r["F"],
        r["u98_m"], 100.0 * r["u98_m"] / H, r["growth_q3_m"], r["growth_q4_m"], r["verdict"],
        r["elapsed_s"]))

    def trial(F, left):
        t0 = time.perf_counter()
        _restore(sim, sb, saved, t_geo)
        phi_f = math.atan(math.tan(phi0) / F)
        sb.set_strength(c0 / F, phi_f, min(psi0, phi_f))
        us, ups = [], []
        for k, q in enumerate(QUARTERS):
            advance(sim, t_geo + q * TRIAL_TG * t_g)
            us.append(_u98(sb.body["x"][inner], x_geo[inner]))
            ups.append(_u98(sb.body["x"][inner], x_elastic[k][inner]))
        g3, g4 = ups[2] - ups[1], ups[3] - ups[2]
        v = verdict(us[3], g3, g4, H)
        rec = {"F": F, "u98_m": us[3], "u98_quarters_m": us, "departure_quarters_m": ups,
               "growth_q3_m": g3, "growth_q4_m": g4, "verdict": v,
               "elapsed_s": time.perf_counter() - t0, "trials_left_estimate": left}
        trials.append(rec)
        report(rec)
        if v == "failed" and (not fail_state or F < fail_state["F"]):
            fail_state.update(F=F, x=sb.body["x"].copy(), eps_p=sb.body["eps_p"].copy())
        return v == "failed"

    lo, hi, status = search_bracket(trial, circle.fos, tol)
    res = Result(
        body=body, dx=float(cfg.case.dx), n_particles=int(sb.body.n),
        fos=0.5 * (lo + hi) if status == "bracketed" else None, bracket=[lo, hi],
        status=status, fos_bishop=float(circle.fos), circle=asdict(circle),
        geometry={**asdict(geo), "beta_deg": geo.beta_deg},
        settings={"t_g_s": t_g, "damping_per_s": xi, "settle_s": SETTLE_TG * t_g,
                  "trial_s": TRIAL_TG * t_g, "tol": tol, "f_max": F_MAX, "f_min": F_MIN,
                  "fail_decel": FAIL_DECEL,
                  "rest_tol": REST_TOL, "collapse_of_H": COLLAPSE,
                  "resolved_shepard": RESOLVED, "n_surface_row": int(np.sum(~inner))},
        trials=trials, wall_time_s=time.perf_counter() - t_start,
        steps=sim.n_steps - steps0, particle_steps=sim.particle_steps - ps0,
        x_geo=x_geo, x_fail=fail_state.get("x"), eps_p_fail=fail_state.get("eps_p"))
    return res


# ----------------------------------------------------------------------------- command
def fos_command(case, body=None, out=None, overrides=(), method="sph", tol=TOL):
    """``fsi-sph fos``: the factor of safety of the case's soil slope by limit equilibrium
    (``bishop``) or strength reduction (``sph``); one line per trial on stdout; writes
    ``result.json`` (and the PNGs for ``sph``) into ``out`` (default
    ``runs/<case name>_fos``); ``tol``: the bracket's relative width. Bad input raises
    :class:`SlopeInputError`."""
    if not 0.0 < tol <= 0.5:
        raise SlopeInputError(f"--tol {tol!r}: the bracket's relative width must be in "
                              "(0, 0.5], e.g. 0.02 (the default) or 0.005")
    from fsi_sph.config import load_config

    cfg = load_config(case, list(overrides))
    body = soil_body_name(cfg, body)
    geo = slope_geometry(cfg, body)
    out = Path(out) if out else Path("runs") / f"{cfg.case.name}_fos"
    t0 = time.perf_counter()
    circ = limit_equilibrium(cfg, body, geo)
    print(f"{body}: slope H = {geo.height:.4g} m at {geo.beta_deg:.1f} deg, crest "
          f"({geo.crest[0]:.4g}, {geo.crest[1]:.4g}), toe ({geo.toe[0]:.4g}, {geo.toe[1]:.4g}); "
          f"Bishop (critical circle) F = {circ.fos:.4f} in {time.perf_counter() - t0:.1f} s",
          flush=True)
    if method == "bishop":
        out.mkdir(parents=True, exist_ok=True)
        (out / "result.json").write_text(json.dumps(
            {"method": "bishop", "body": body, "fos": circ.fos, "circle": asdict(circ),
             "geometry": {**asdict(geo), "beta_deg": geo.beta_deg}}, indent=1))
        print(f"factor of safety (Bishop) {circ.fos:.4f}; {out / 'result.json'}")
        return 0
    H = geo.height

    def line(r):
        print(f"  F = {r['F']:.4f}  u98 = {r['u98_m']:.4g} m ({100 * r['u98_m'] / H:.2f} % H), "
              f"beyond elastic, last quarters {r['growth_q3_m']:+.3g} / {r['growth_q4_m']:+.3g} m  "
              f"{r['verdict']:6s}  {r['elapsed_s']:.1f} s, about "
              f"{r['trials_left_estimate']} trial(s) left", flush=True)

    from fsi_sph.fos_plots import write_outputs

    res = strength_reduction(case, body, overrides, tol=tol, circle=circ, on_trial=line)
    paths = write_outputs(res, out)
    done = f"{len(res.trials)} trials in {time.perf_counter() - t0:.0f} s; " + ", ".join(
        str(p) for p in paths)
    if res.status != "bracketed":
        print(f"factor of safety (SPH strength reduction) {res.label}: a bound, not a value; "
              f"Bishop {circ.fos:.4f}; {done}")
        return 0
    print(f"factor of safety (SPH strength reduction) {res.fos:.4f}, bracket "
          f"[{res.bracket[0]:.4f}, {res.bracket[1]:.4f}]"
          f"{' (below 1: the slope fails as built)' if res.fos < 1.0 else ''}; Bishop "
          f"{circ.fos:.4f} ({100 * (res.fos - circ.fos) / circ.fos:+.1f} %); {done}")
    return 0
