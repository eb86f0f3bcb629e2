"""Fixed wall particles in several layers (PHYSICS.md §2).

Walls are built from the ``[walls]`` table: an open-top tank gets ``layers`` rows of
particles outside its left, right and bottom sides (corners filled), on the same lattice as
the fluid, so that a fluid particle next to the wall has a full kernel support. Their
pressure is an unknown of the PPE (Adami's extrapolation rows, see ``ppe``); their velocity
is zero (no slip in the viscous term, no penetration in ``div u*``).
"""

from __future__ import annotations

import numpy as np

from fsi_sph.geometry import fill_rectangle, fill_shapes
from fsi_sph.neighbors import find_neighbors
from fsi_sph.particles import Body, FieldSpec


def tank_particles(origin, size, layers, dx):
    """Wall particles of an open-top tank whose inner rectangle is ``origin + [0, size]``."""
    t = layers * dx
    x0, y0 = origin
    w, hgt = size
    parts = [
        fill_rectangle((x0 - t, y0 - t), (w + 2 * t, t), dx),   # floor, with both corners
        fill_rectangle((x0 - t, y0), (t, hgt), dx),             # left side
        fill_rectangle((x0 + w, y0), (t, hgt), dx),             # right side
    ]
    return np.concatenate(parts, axis=0)


def wall_particles(cfg, dx):
    """All wall particle positions of a ``WallsSection``, duplicates removed."""
    pts = [tank_particles(s.origin, s.size, cfg.layers, dx) for s in cfg.tanks]
    if cfg.boxes:
        pts.append(fill_shapes(cfg.boxes, dx))
    x = np.concatenate(pts, axis=0)
    key = np.round(x / (1e-6 * dx)).astype(np.int64)
    _, keep = np.unique(key, axis=0, return_index=True)
    return x[np.sort(keep)]


class Walls:
    """The wall body: positions, volumes, (zero) velocity and the pressure from the PPE."""

    fields = (FieldSpec("x", (2,)), FieldSpec("v", (2,)), FieldSpec("vol"), FieldSpec("p"))

    def __init__(self, cfg, dx, structures_x=()):
        x = wall_particles(cfg, dx)
        for xs in structures_x:  # a structure's particles (e.g. a clamped root set into the
            # floor) take the place of the wall particles on their sites
            near_start, _ = find_neighbors(x, xs, 0.5 * dx)
            x = x[np.diff(near_start) == 0]
        self.body = b = Body("walls", "wall", len(x))
        b.allocate(self.fields)
        b["x"][:] = x
        b["vol"][:] = dx * dx

    def static(self):
        return {"x": self.body["x"], "vol": self.body["vol"]}
