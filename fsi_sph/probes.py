"""Probes: small time series sampled during a run (tip displacement, energies)."""

from __future__ import annotations

import numpy as np


class PointDisplacement:
    """Displacement and position of the particle nearest to ``at`` in the reference
    configuration. Columns: ``ux, uy, x, y``."""

    columns = ("ux", "uy", "x", "y")

    def __init__(self, name, body, at):
        self.name = name
        self.body = body
        x0 = body.body["x0"]
        self.index = int(np.argmin(np.hypot(x0[:, 0] - at[0], x0[:, 1] - at[1])))
        self.x0 = x0[self.index].copy()

    def sample(self):
        x = self.body.body["x"][self.index]
        return [x[0] - self.x0[0], x[1] - self.x0[1], x[0], x[1]]


class Energy:
    """Kinetic, strain, hourglass-penalty (conservative model only, else 0) and total
    mechanical energy of a body (J per metre of depth)."""

    columns = ("kinetic", "strain", "hourglass", "total")

    def __init__(self, name, body):
        self.name = name
        self.body = body

    def sample(self):
        k = self.body.kinetic_energy()
        s = self.body.strain_energy() if hasattr(self.body, "strain_energy") else 0.0
        h = self.body.hourglass_energy() if hasattr(self.body, "hourglass_energy") else 0.0
        return [k, s, h, k + s + h]


class FluidPressure:
    """Fluid pressure at a fixed point: Shepard interpolation over fluid and wall particles.
    Column: ``p`` (Pa)."""

    columns = ("p",)

    def __init__(self, name, fluid, at):
        self.name = name
        self.fluid = fluid
        self.at = np.asarray([at], dtype=np.float64)

    def sample(self):
        return [float(self.fluid.pressure_at(self.at)[0])]


class SurgeFront:
    """Largest x of the fluid particles that have at least 3 fluid neighbours (droplets
    excluded). Column: ``x_front`` (m)."""

    columns = ("x_front",)

    def __init__(self, name, fluid):
        self.name = name
        self.fluid = fluid

    def sample(self):
        return [self.fluid.surge_front()]


class FluidStats:
    """Largest particle speed (m/s) and kinetic energy (J/m) of the fluid."""

    columns = ("max_speed", "kinetic")

    def __init__(self, name, fluid):
        self.name = name
        self.fluid = fluid

    def sample(self):
        return [self.fluid.max_speed(), self.fluid.kinetic_energy()]


def make_probe(cfg, bodies):
    """Build the probe a ``Probe`` config entry asks for (bodies by name)."""
    body = bodies[cfg.body]
    if cfg.kind == "point_displacement":
        return PointDisplacement(cfg.name, body, cfg.at)
    if cfg.kind == "pressure":
        return FluidPressure(cfg.name, body, cfg.at)
    if cfg.kind == "surge_front":
        return SurgeFront(cfg.name, body)
    if cfg.kind == "fluid_stats":
        return FluidStats(cfg.name, body)
    return Energy(cfg.name, body)
