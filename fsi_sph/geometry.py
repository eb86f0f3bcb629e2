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


def _fill(shape, dx):
    if getattr(shape, "shape", "rectangle") == "polygon":
        return fill_polygon(shape.vertices, dx)
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
    x = np.concatenate(pts, axis=0)
    if len(pts) > 1:
        key = np.round(x / (1e-6 * dx)).astype(np.int64)
        _, keep = np.unique(key, axis=0, return_index=True)
        x = x[np.sort(keep)]
    return x


def in_shapes(x, shapes):
    """Mask of the points inside any of ``shapes``."""
    mask = np.zeros(len(x), dtype=bool)
    for s in shapes:
        if getattr(s, "shape", "rectangle") == "polygon":
            mask |= in_polygon(x, s.vertices)
        else:
            mask |= in_rectangle(x, s.origin, s.size)
    return mask
