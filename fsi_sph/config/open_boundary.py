"""``[[fluid.inflow]]`` and ``[[fluid.outflow]]``: open boundaries of the ISPH fluid
(fsi_sph/fluid/open_boundary.py). Both are vertical lines ``x = const`` over ``y_range``;
the flow enters at an inflow towards +x and leaves at an outflow towards +x. Each is a
buffer of particles one kernel support deep (behind the inflow line, beyond the outflow
line)."""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from fsi_sph.config.base import NonNegative, StrictModel, Vec2
from fsi_sph.expression import Expression

PROFILE_VARIABLES = ("y", "t")


def _finite(value, key):
    if not math.isfinite(value):
        raise ValueError(f"{key} = {value}: must be a finite number")


class InflowVelocity(StrictModel):
    """The prescribed normal velocity ``u(y, t)`` of an inflow (m/s), times the ramp
    ``(1 - cos(pi t / ramp_time)) / 2`` for ``t < ramp_time`` (Turek & Hron 2006)."""

    profile: Literal["uniform", "parabolic", "expression"] = Field(
        description="`uniform`: u = mean; `parabolic`: u = 6 mean s (1 - s), s = (y - y0) / "
        "(y1 - y0) over the inflow's y_range (plane Poiseuille, mean velocity `mean`); "
        "`expression`: u = the arithmetic expression `u` of y (m) and t (s)")
    mean: float | None = Field(None, description="mean velocity over y_range (m/s), for "
                               "`uniform` and `parabolic`")
    u: str | None = Field(None, description="for `expression`: u(y, t) (m/s) written with "
                          "numbers, y, t, pi, + - * / ** and sin cos tan exp log sqrt tanh "
                          "abs min max; checked finite over y_range and [0, case.t_end]")
    ramp_time: NonNegative = Field(0.0, description="duration of the start-up ramp "
                                   "(1 - cos(pi t / ramp_time)) / 2 (s); 0 = none")

    @model_validator(mode="after")
    def _parameters(self):
        if self.profile == "expression":
            if self.u is None or self.mean is not None:
                raise ValueError("profile = \"expression\" takes `u` (an expression of y and "
                                 "t), not `mean`")
            Expression(self.u, PROFILE_VARIABLES)  # raises with what is allowed
        else:
            if self.mean is None or self.u is not None:
                raise ValueError(f"profile = {self.profile!r} takes `mean` (m/s), not `u`")
            _finite(self.mean, "mean")
        _finite(self.ramp_time, "ramp_time")
        return self

    def function(self, y_range):
        """``u(y, t)`` as a callable of arrays (the ramp included)."""
        y0, y1 = y_range
        if self.profile == "expression":
            expr = Expression(self.u, PROFILE_VARIABLES)

            def shape(y, t):
                return np.broadcast_to(np.asarray(expr(y=y, t=t), dtype=float), np.shape(y))
        elif self.profile == "parabolic":
            def shape(y, t):
                s = (np.asarray(y) - y0) / (y1 - y0)
                return 6.0 * self.mean * s * (1.0 - s)
        else:
            def shape(y, t):
                return np.full(np.shape(y), float(self.mean))
        ramp_time = self.ramp_time

        def u(y, t):
            ramp = 0.5 * (1.0 - math.cos(math.pi * t / ramp_time)) if t < ramp_time else 1.0
            return ramp * shape(y, t)
        return u


class Inflow(StrictModel):
    """An inflow line ``x`` over ``y_range`` with a prescribed velocity (towards +x)."""

    x: float = Field(description="position of the inflow line (m); its buffer lies behind "
                     "it, at x - 2h .. x")
    y_range: Vec2 = Field(description="[y0, y1] (m) of the inflow line, y1 > y0")
    velocity: InflowVelocity

    @model_validator(mode="after")
    def _line(self):
        _line_checks(self.x, self.y_range)
        return self


class Outflow(StrictModel):
    """An outflow line ``x`` over ``y_range`` at a given pressure (flow towards +x)."""

    x: float = Field(description="position of the outflow line (m); its buffer lies "
                     "beyond it, at x .. x + 2h")
    y_range: Vec2 = Field(description="[y0, y1] (m) of the outflow line, y1 > y0")
    pressure: float = Field(0.0, description="pressure held in the outflow buffer (Pa)")

    @model_validator(mode="after")
    def _line(self):
        _line_checks(self.x, self.y_range)
        _finite(self.pressure, "pressure")
        return self


def _line_checks(x, y_range):
    _finite(x, "x")
    for v in y_range:
        _finite(v, "y_range")
    if not y_range[1] > y_range[0]:
        raise ValueError(f"y_range = {list(y_range)}: need y1 > y0")


def check_open_boundaries(cfg):
    """Cross-checks of the open boundaries against the scene (``Config``): the profile is
    finite over the line and the run, the buffers (one kernel support deep) do not
    overlap, and they lie inside the domain (``guard.domain``, else the walls' extent)."""
    fl = cfg.fluid
    if fl is None or not (fl.inflow or fl.outflow):
        return
    depth = 2.0 * cfg.sph.h_over_dx * cfg.case.dx
    boxes = []
    for k, inflow in enumerate(fl.inflow):
        key = f"fluid.inflow[{k}]"
        _check_profile(inflow, cfg.case.t_end, cfg.case.dx, key)
        boxes.append((key, inflow.x - depth, inflow.x, inflow.y_range))
    for k, outflow in enumerate(fl.outflow):
        boxes.append((f"fluid.outflow[{k}]", outflow.x, outflow.x + depth, outflow.y_range))
    for a in range(len(boxes)):
        for b in range(a + 1, len(boxes)):
            _check_apart(boxes[a], boxes[b])
    domain = _domain(cfg)
    if domain is not None:
        lo, hi = domain
        for key, x0, x1, (y0, y1) in boxes:
            if x0 < lo[0] or x1 > hi[0] or y0 < lo[1] or y1 > hi[1]:
                raise ValueError(
                    f"{key}: its buffer [{x0:g}, {x1:g}] x [{y0:g}, {y1:g}] m lies outside the "
                    f"domain [{lo[0]:g}, {hi[0]:g}] x [{lo[1]:g}, {hi[1]:g}] m (guard.domain, or "
                    f"else the extent of the walls); allowed: a line whose buffer (2h = "
                    f"{depth:g} m deep) lies inside it")


def _check_profile(inflow, t_end, dx, key):
    u = inflow.velocity.function(inflow.y_range)
    y = np.linspace(inflow.y_range[0], inflow.y_range[1], 65)
    for t in np.linspace(0.0, t_end, 33):
        with np.errstate(all="ignore"):
            try:
                val = np.asarray(u(y, float(t)), dtype=float)
            except (OverflowError, ZeroDivisionError, ValueError):
                val = np.array([np.nan])
        if not np.all(np.isfinite(val)):
            raise ValueError(f"{key}.velocity: the profile is not finite at some y in "
                             f"{list(inflow.y_range)} at t = {t:.4g} s; allowed: a profile "
                             "finite over the inflow line for 0 <= t <= case.t_end")


def _check_apart(a, b):
    (ka, a0, a1, (ay0, ay1)), (kb, b0, b1, (by0, by1)) = a, b
    if a0 < b1 and b0 < a1 and ay0 < by1 and by0 < ay1:
        raise ValueError(f"{kb} overlaps {ka}: their buffers (one kernel support, 2h, deep) "
                         f"[{b0:g}, {b1:g}] and [{a0:g}, {a1:g}] m share x over a common y "
                         "range; allowed: lines at least 2h apart, an outflow beyond the "
                         "inflow")
    if ka.startswith("fluid.inflow") and kb.startswith("fluid.outflow") \
            and b0 < a1 + (a1 - a0) and ay0 < by1 and by0 < ay1:
        raise ValueError(f"{kb}.x = {b0:g} m overlaps {ka} (x = {a1:g} m): allowed: an "
                         f"outflow at least one kernel support (2h = {a1 - a0:g} m) "
                         "downstream (at larger x) of the inflow it faces")


def _domain(cfg):
    """``(lo, hi)`` of the domain the open boundaries must lie in, or None."""
    if cfg.guard.domain is not None:
        lo = np.asarray(cfg.guard.domain.origin, dtype=float)
        return lo, lo + np.asarray(cfg.guard.domain.size, dtype=float)
    if cfg.walls is None:
        return None
    t = cfg.walls.layers * cfg.case.dx
    los, his = [], []
    for s in cfg.walls.tanks:
        los.append(np.subtract(s.origin, t))
        his.append(np.add(s.origin, s.size) + np.array([t, 1e30]))
    for s in cfg.walls.boxes:
        lo, hi = _bounds(s)
        los.append(lo)
        his.append(hi)
    return np.min(los, axis=0), np.max(his, axis=0)


def _bounds(shape):
    """Bounding box of a rectangle, polygon or circle."""
    kind = getattr(shape, "shape", "rectangle")
    if kind == "circle":
        return np.subtract(shape.centre, shape.radius), np.add(shape.centre, shape.radius)
    if kind == "polygon":
        v = np.asarray(shape.vertices, dtype=float)
        return v.min(axis=0), v.max(axis=0)
    return np.asarray(shape.origin, dtype=float), np.add(shape.origin, shape.size)
