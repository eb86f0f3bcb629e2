"""Limit-equilibrium factor of safety of a slope by Bishop's simplified method, with a search
for the critical slip circle.

Geometry conventions (those of the soil cases): the ground surface is a polyline
``profile = [(x0, y0), (x1, y1), ...]`` with soil below it; a rigid floor at ``y = y_floor``
and a rigid wall at ``x = x_wall`` (the slip circle may not cut either); the slope faces +x,
so the sliding mass moves to the right and rotates counter-clockwise about the centre.

Bishop's simplified method (Bishop 1955), no pore pressure, slices of width ``b``:

    F = sum[(c b + W tan(phi)) / m_a] / sum[W sin(a)],   m_a = cos(a) + sin(a) tan(phi) / F

with ``a`` the base inclination of a slice, ``sin(a) = (x_c - x)/R`` (``c b`` is evaluated as
``c l cos(a)`` with the exact arc length ``l`` of the slice base). For ``phi = 0`` it is
exact moment equilibrium of the circle (e.g. Taylor's vertical cut ``H_c = 3.83 c/gamma``).

Also the infinite slope (the limit of skin-deep slips, e.g. a cohesionless slope):
``F = (c + gamma z cos^2(beta) tan(phi)) / (gamma z sin(beta) cos(beta))`` at vertical depth
``z``, ``tan(phi)/tan(beta)`` for ``c = 0``.

``fsi-sph fos CASE --method bishop`` and the strength reduction
(:mod:`fsi_sph.strength_reduction`) use it; the slope validations import it.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize


def infinite_slope_fos(phi_deg, beta_deg, cohesion=0.0, gamma=1.0, depth=1.0):
    """Factor of safety of an infinite slope at angle ``beta`` against sliding on the plane
    parallel to the surface at vertical depth ``depth`` (Mohr-Coulomb ``c``, ``phi``)."""
    b = math.radians(beta_deg)
    sn = gamma * depth * math.cos(b) ** 2
    tau = gamma * depth * math.sin(b) * math.cos(b)
    return (cohesion + sn * math.tan(math.radians(phi_deg))) / tau


@dataclass(frozen=True)
class Circle:
    xc: float
    yc: float
    R: float
    fos: float
    x_entry: float
    x_exit: float


def ground(profile, x):
    """Ground height at ``x`` (linear interpolation; constant beyond the ends)."""
    p = np.asarray(profile, dtype=np.float64)
    return np.interp(x, p[:, 0], p[:, 1])


def slip_mass(profile, xc, yc, R, x_wall=0.0, y_floor=0.0, n_probe=1200):
    """Horizontal extent ``(x_entry, x_exit)`` of the soil above the lower arc of the circle,
    or ``None`` if the circle cuts no soil, the wall or the floor."""
    p = np.asarray(profile, dtype=np.float64)
    lo = max(xc - R, p[0, 0])
    hi = min(xc + R, p[-1, 0])
    if hi <= lo:
        return None
    x = np.linspace(lo, hi, n_probe)
    yarc = yc - np.sqrt(np.maximum(R * R - (x - xc) ** 2, 0.0))
    gx = ground(p, x)
    # soil above the arc: ground above the arc, and not just the bare floor beyond the toe
    inside = (gx - yarc > 0.0) & (gx > y_floor + 1e-9 * R)
    if not inside.any():
        return None
    # all of it, from the first to the last x where the arc is below the ground: a circle that
    # touches the ground at the toe and dips under it again beyond moves that soil too (the
    # largest run alone let the search pass circles through the toe at no cost beyond it)
    idx = np.flatnonzero(inside)
    k0, k1 = idx[0], idx[-1]
    if k0 == 0 or k1 == len(x) - 1:
        return None  # the lower arc does not close the slip mass (or it meets the profile ends)
    if x[k0] < x_wall - 1e-12:
        return None  # the arc would pass through the back wall
    if np.any(yarc[k0:k1 + 1] < y_floor - 1e-9 * R):
        return None  # the arc dips into the rigid floor under the soil
    # the two ends: linear interpolation of (ground - arc) between the bracketing probes
    d = gx - yarc

    px, py = p[:, 0].tolist(), p[:, 1].tolist()

    def g(xq):  # ground - arc at a scalar x (plain floats: called 30 times per end)
        k = min(max(bisect.bisect_right(px, xq) - 1, 0), len(px) - 2)
        t = min(max((xq - px[k]) / (px[k + 1] - px[k]), 0.0), 1.0)
        return py[k] + t * (py[k + 1] - py[k]) - (
            yc - math.sqrt(max(R * R - (xq - xc) ** 2, 0.0)))

    def cross(k):
        if (d[k] > 0.0) == (d[k + 1] > 0.0):  # the run ends at the bare floor, not the arc
            return x[k + 1] if d[k] > 0.0 else x[k]
        a, b, ga = x[k], x[k + 1], d[k]
        for _ in range(30):  # bisection: robust where the arc is steep
            m = 0.5 * (a + b)
            gm = g(m)
            if (gm > 0.0) == (ga > 0.0):
                a, ga = m, gm
            else:
                b = m
        return 0.5 * (a + b)

    xe = cross(k0 - 1)
    xx = cross(k1)
    return xe, xx


def bishop_fos(profile, xc, yc, R, cohesion, phi_deg, gamma, x_wall=0.0, y_floor=0.0,
               n_slices=80, min_depth=0.0, return_slices=False):
    """Bishop's simplified factor of safety of one circle; ``inf`` for an invalid circle
    (no soil cut, through wall or floor, slip mass shallower than ``min_depth``, or a slice
    with ``m_a <= 0``)."""
    ext = slip_mass(profile, xc, yc, R, x_wall, y_floor)
    if ext is None:
        return math.inf
    xe, xx = ext
    edges = np.linspace(xe, xx, n_slices + 1)
    xm = 0.5 * (edges[1:] + edges[:-1])
    b = np.diff(edges)
    # slice weight: Simpson on each slice of (ground - arc)
    def height(xq):
        return np.maximum(ground(profile, xq) - (yc - np.sqrt(np.maximum(R * R - (xq - xc) ** 2,
                                                                            0.0))), 0.0)

    hgt = (height(edges[:-1]) + 4.0 * height(xm) + height(edges[1:])) / 6.0
    if hgt.max() < min_depth:
        return math.inf
    W = gamma * b * hgt
    sin_a = (xc - xm) / R
    cos_a = np.sqrt(np.maximum(1.0 - sin_a**2, 0.0))
    # exact base length of each slice (the midpoint b/cos(a) is poor where the base is steep)
    theta = np.arcsin(np.clip((xc - edges) / R, -1.0, 1.0))
    base = R * np.abs(np.diff(theta))
    coh = np.where(hgt > 0.0, cohesion, 0.0)  # no cohesion where the arc passes through air
    drive = float(np.sum(W * sin_a))
    if drive <= 0.0:
        return math.inf
    tan_p = math.tan(math.radians(phi_deg))
    F = 1.0
    for _ in range(200):
        m_a = cos_a + sin_a * tan_p / F
        if np.any(m_a <= 0.0):
            return math.inf
        F_new = float(np.sum((coh * base * cos_a + W * tan_p) / m_a)) / drive
        if abs(F_new - F) < 1e-10 * F:
            F = F_new
            break
        F = F_new
    if return_slices:
        return F, dict(x=xm, b=b, W=W, sin_a=sin_a)
    return F


def critical_circle(profile, cohesion, phi_deg, gamma, x_wall=0.0, y_floor=0.0,
                    min_depth=None, n_centres=14, n_radii=12, refine=True, n_starts=4):
    """Search the circle of least Bishop factor of safety: a grid of centres above the slope,
    radii from just cutting the surface to touching the floor, then a Nelder-Mead refinement
    from the best grid circle. ``min_depth`` (default 5 % of the slope height) excludes
    skin-deep surface slides."""
    p = np.asarray(profile, dtype=np.float64)
    H = p[:, 1].max() - p[:, 1].min()
    L = p[-1, 0] - p[0, 0]
    if min_depth is None:
        min_depth = 0.05 * H
    xs = np.linspace(p[0, 0], p[-1, 0], n_centres)
    ys = np.linspace(p[:, 1].min() + 0.3 * H, p[:, 1].max() + 2.0 * H, n_centres)

    def fos(xc, yc, R):
        return bishop_fos(p, xc, yc, R, cohesion, phi_deg, gamma, x_wall, y_floor,
                          min_depth=min_depth)

    # radii: circles through points spread along the ground surface (toe circles among them)
    # and circles tangent to depths between the toe level and the floor
    seg = np.hypot(np.diff(p[:, 0]), np.diff(p[:, 1]))
    s_along = np.concatenate([[0.0], np.cumsum(seg)])
    s_pts = np.linspace(0.0, s_along[-1], 3 * n_radii)
    gx = np.interp(s_pts, s_along, p[:, 0])
    gy = np.interp(s_pts, s_along, p[:, 1])
    depths = np.linspace(y_floor, p[:, 1].min(), max(n_radii // 3, 2))
    cands = []  # (fos, circle) of every admissible grid circle
    for xc in xs:
        for yc in ys:
            radii = np.concatenate([np.hypot(gx - xc, gy - yc), yc - depths])
            for R in radii[radii > 1e-3 * H]:
                f = fos(xc, yc, R)
                if math.isfinite(f):
                    cands.append((f, (xc, yc, R)))
    cands.sort(key=lambda c: c[0])
    best = cands[0] if cands else (math.inf, None)
    if best[1] is None:
        raise ValueError("no admissible slip circle found")
    if refine:
        scale = np.array([L, H, H])

        def obj(z):
            xc, yc, R = z * scale
            return fos(xc, yc, R) if R > 0 else math.inf

        # multi-start: the objective has walls (inadmissible circles) and several valleys
        for _, z0 in cands[:n_starts]:
            res = minimize(obj, np.array(z0) / scale, method="Nelder-Mead",
                           options=dict(xatol=1e-6, fatol=1e-8, maxiter=3000))
            if res.fun < best[0]:
                best = (float(res.fun), tuple(res.x * scale))
    xc, yc, R = best[1]
    xe, xx = slip_mass(p, xc, yc, R, x_wall, y_floor)
    return Circle(float(xc), float(yc), float(R), float(best[0]), float(xe), float(xx))
