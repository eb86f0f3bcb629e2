"""Lattice fills of simple shapes and region tests.

Particles sit at cell centres of a square lattice of spacing ``dx`` aligned with the
shape's origin, so a rectangle of size ``(a, b)`` holds ``round(a/dx) * round(b/dx)``
particles, each with volume ``dx^2``.

>>> fill_rectangle((0.0, 0.0), (0.3, 0.2), 0.1).shape
(6, 2)
>>> fill_polygon([(0.0, 0.0), (0.4, 0.0), (0.0, 0.4)], 0.1).shape  # right triangle: 4+3+2+1
(10, 2)
"""

import numpy as np

from fsi_sph.errors import ConfigError


def fill_rectangle(origin, size, dx):
    """Cell-centred lattice points inside the rectangle ``origin + [0, size]``."""
    nx = int(round(size[0] / dx))
    ny = int(round(size[1] / dx))
    if nx < 1 or ny < 1:
        raise ValueError(f"rectangle of size {tuple(size)} holds no particle at dx = {dx}")
    ix, iy = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    x = origin[0] + (ix.ravel() + 0.5) * dx
    y = origin[1] + (iy.ravel() + 0.5) * dx
    return np.column_stack([x, y])


def in_rectangle(x, origin, size):
    """Boolean mask of the points of ``x`` inside the closed rectangle."""
    return ((x[:, 0] >= origin[0]) & (x[:, 0] <= origin[0] + size[0])
            & (x[:, 1] >= origin[1]) & (x[:, 1] <= origin[1] + size[1]))


def in_polygon(x, vertices):
    """Boolean mask of the points of ``x`` inside the closed polygon (even-odd ray casting;
    points on an edge, within 1e-9 of the polygon's size, count as inside)."""
    v = np.asarray(vertices, dtype=np.float64)
    px, py = x[:, 0], x[:, 1]
    tol = 1e-9 * float(np.ptp(v, axis=0).max())
    inside = np.zeros(len(x), dtype=bool)
    on_edge = np.zeros(len(x), dtype=bool)
    for k in range(len(v)):
        (x1, y1), (x2, y2) = v[k], v[(k + 1) % len(v)]
        ex, ey = x2 - x1, y2 - y1
        t = np.clip(((px - x1) * ex + (py - y1) * ey) / (ex * ex + ey * ey), 0.0, 1.0)
        on_edge |= np.hypot(px - x1 - t * ex, py - y1 - t * ey) <= tol
        if y1 == y2:
            continue
        crosses = (y1 > py) != (y2 > py)
        xint = x1 + (py - y1) * ex / ey
        inside ^= crosses & (px < xint)
    return inside | on_edge


def fill_polygon(vertices, dx):
    """Cell-centred lattice points (aligned with the polygon's lowest-left bounding corner)
    inside the polygon."""
    v = np.asarray(vertices, dtype=np.float64)
    lo = v.min(axis=0)
    size = v.max(axis=0) - lo
    nx = int(np.ceil(size[0] / dx - 1e-9))
    ny = int(np.ceil(size[1] / dx - 1e-9))
    pts = fill_rectangle(lo, (nx * dx, ny * dx), dx)
    pts = pts[in_polygon(pts, v)]
    if len(pts) == 0:
        raise ValueError(f"polygon {v.tolist()} holds no particle at dx = {dx}")
    return pts


def fill_circle(centre, radius, dx):
    """Concentric rings of particles filling a disk: ring ``k`` at radius
    ``r_k = radius - (k + 1/2) dx`` holds ``round(2 pi r_k / dx)`` particles evenly spaced
    (each ring turned by half a spacing against the last), and a ring whose radius falls
    below ``dx / 2`` is one particle at the centre. The outer ring lies half a spacing inside
    the surface, as a lattice's outer row does, and the particles' count matches the area
    (``pi radius^2 / dx^2`` within a few particles).

    >>> fill_circle((0.0, 0.0), 0.05, 0.01).shape  # pi r^2 / dx^2 = 78.5
    (78, 2)
    """
    pts = []
    k = 0
    while True:
        r = radius - (k + 0.5) * dx
        if r < 0.5 * dx:
            if radius - k * dx > 0.0:
                pts.append(np.array([centre], dtype=np.float64))
            break
        n = max(int(round(2.0 * np.pi * r / dx)), 1)
        phi = (np.arange(n) + 0.5 * (k % 2)) * 2.0 * np.pi / n
        pts.append(np.column_stack([centre[0] + r * np.cos(phi), centre[1] + r * np.sin(phi)]))
        k += 1
    if not pts:
        raise ValueError(f"circle of radius {radius} holds no particle at dx = {dx}")
    return np.concatenate(pts, axis=0)


def in_circle(x, centre, radius):
    """Mask of the points of ``x`` inside the closed disk."""
    return np.hypot(x[:, 0] - centre[0], x[:, 1] - centre[1]) <= radius


def _fill(shape, dx):
    kind = getattr(shape, "shape", "rectangle")
    if kind == "polygon":
        return fill_polygon(shape.vertices, dx)
    if kind == "circle":
        return fill_circle(shape.centre, shape.radius, dx)
    return fill_rectangle(shape.origin, shape.size, dx)


def fill_shapes(shapes, dx, key="blocks"):
    """Union of the lattice fills of ``shapes`` (config ``Shape``/``Polygon`` models),
    duplicates removed. A shape that holds no particle at this ``dx`` is a
    :class:`ConfigError` naming ``key[k]``."""
    pts = []
    for k, s in enumerate(shapes):
        try:
            pts.append(_fill(s, dx))
        except ValueError as e:
            raise ConfigError(f"{key}[{k}]: {e}; make it larger or lower case.dx") from None
    pts = carve_circles(shapes, pts)
    x = np.concatenate(pts, axis=0)
    if len(pts) > 1:
        key = np.round(x / (1e-6 * dx)).astype(np.int64)
        _, keep = np.unique(key, axis=0, return_index=True)
        x = x[np.sort(keep)]
    return x


def carve_circles(shapes, pts):
    """A union with circles: a circle's rings are not on the lattice of the shapes beside
    it, so every other shape of the union loses its points inside a circle (no two particles
    on one site; a union without a circle is left as it is)."""
    out = list(pts)
    for k, s in enumerate(shapes):
        if getattr(s, "shape", None) != "circle":
            continue
        for m in range(len(out)):
            if m != k:
                out[m] = out[m][~in_circle(out[m], s.centre, s.radius)]
    return out


def in_shapes(x, shapes):
    """Mask of the points inside any of ``shapes``."""
    mask = np.zeros(len(x), dtype=bool)
    for s in shapes:
        kind = getattr(s, "shape", "rectangle")
        if kind == "polygon":
            mask |= in_polygon(x, s.vertices)
        elif kind == "circle":
            mask |= in_circle(x, s.centre, s.radius)
        else:
            mask |= in_rectangle(x, s.origin, s.size)
    return mask
