"""Probes: small time series sampled during a run (tip displacement, energies)."""

from __future__ import annotations

import numpy as np

from fsi_sph.fluid.gauge import level_beside
from fsi_sph.geometry import in_shapes


class PointDisplacement:
    """Displacement and position of the material point at ``at`` in the reference
    configuration. Columns: ``ux, uy, x, y``.

    The particle nearest to ``at``; for a body with a deformation gradient (the TLSPH
    solid) its position carried from the particle to the point by it,
    ``x_A = x_p + F_p (X_A - X_p)`` [F 36] (exact for an affine motion; a rigid body, whose F
    stays I, by its rotation :func:`rotation`), averaged over every
    particle at the nearest distance (to 1e-9 of it). Where ``at`` is a particle's reference
    position that is the particle itself; where it is not (Turek & Hron's point A, the
    centre of the flag's end, lies between two particles half a spacing off), the nearest
    particle alone was off by its own offset turned with the body (at a tip rotation of
    0.3 rad and D/dx 10, 1.5 mm of u_x against the benchmark's 12.4 mm amplitude)."""

    columns = ("ux", "uy", "x", "y")

    def __init__(self, name, body, at):
        self.name = name
        self.body = body
        x0 = body.body["x0"]
        d = np.hypot(x0[:, 0] - at[0], x0[:, 1] - at[1])
        dmin = float(d.min())
        self.carried = "F" in body.body and dmin > 0.0
        self.rigid = bool(getattr(body, "rigid", False))   # F stays I: turn by the body
        if self.carried:
            self.indices = np.flatnonzero(d <= dmin + 1e-9 * dmin)
        else:
            self.indices = np.array([int(np.argmin(d))])
        self.at = np.asarray(at, dtype=float)
        self.x0 = x0[self.indices]
        self.offset = self.at - self.x0          # X_A - X_p

    def sample(self):
        b = self.body.body
        x = b["x"][self.indices]
        if not self.carried:   # the particle(s) themselves
            u = (x - self.x0).mean(axis=0)
            xa = x.mean(axis=0)
            return [u[0], u[1], xa[0], xa[1]]
        F = rotation(b["x"], b["x0"])[None] if self.rigid else b["F"][self.indices]
        xa = (x + np.einsum("pij,pj->pi", F, self.offset)).mean(axis=0)
        return [xa[0] - self.at[0], xa[1] - self.at[1], xa[0], xa[1]]


def rotation(x, x0):
    """The rotation that best maps the reference positions ``x0`` onto ``x`` about their
    centroids (the rotation of the polar decomposition of ``sum (x - xc) (x0 - x0c)^T``,
    exact for a rigid motion; not in PHYSICS.md)."""
    a = (x - x.mean(axis=0)).T @ (x0 - x0.mean(axis=0))
    t = np.arctan2(a[1, 0] - a[0, 1], a[0, 0] + a[1, 1])
    return np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])


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


class BodyForce:
    """The fluid's force on the fixed walls or a coupled structure, or on the part of it
    inside ``region`` (its particles' reference positions), from the same pair terms the
    coupling uses (:meth:`BoundaryRows.fluid_forces`: pressure [F 46-47] and viscous
    [F 11-12]). Columns: ``fx, fy`` (N/m): drag and lift for a flow along x, and
    ``fx_viscous, fy_viscous``, their viscous part (the skin friction; the rest is the
    pressure's). In a confined
    flow the pressure pair term is taken relative to the mean pressure of the fluid rows
    beside the body (:func:`fsi_sph.fluid.gauge.level_beside`): the channel's level moves by
    kilopascals from step to step, and the pair form on a closed body's irregular support
    turned that into force noise (Turek-Hron CFD2, D/dx = 10, the last second of the same
    run: drag std 94 -> 38 N/m, lift std 94 -> 73 N/m)."""

    columns = ("fx", "fy", "fx_viscous", "fy_viscous")

    def __init__(self, name, fluid, body, region):
        self.name = name
        self.fluid = fluid
        if body == "walls":
            x0 = fluid.walls.body["x"]
            self.offset = lambda: 0
        else:
            names = [s.name for s in fluid.structures]
            k = names.index(body)
            x0 = fluid.structures[k].body["x0"]
            before = sum(s.body.n for s in fluid.structures[:k])
            self.offset = lambda: fluid.n_walls + before
        self.rows = np.flatnonzero(in_shapes(x0, region)) if region else np.arange(len(x0))

    def sample(self):
        fl = self.fluid
        rows = self.offset() + self.rows
        # a confined flow: relative to the pressure level beside the body (fluid/gauge.py)
        level = level_beside(fl, rows) if fl.confined else None
        pressure, viscous = fl.boundary.fluid_forces(level, split=True)
        f = (pressure + viscous)[rows].sum(axis=0)
        fv = viscous[rows].sum(axis=0)
        return [float(f[0]), float(f[1]), float(fv[0]), float(fv[1])]


def make_probe(cfg, bodies):
    """Build the probe a ``Probe`` config entry asks for (bodies by name)."""
    if cfg.kind == "force":
        return BodyForce(cfg.name, bodies["fluid"], cfg.body, cfg.region)
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
