"""Lattice fills of simple shapes and region tests.

Particles sit at cell centres of a square lattice of spacing ``dx`` aligned with the
shape's origin, so a rectangle of size ``(a, b)`` holds ``round(a/dx) * round(b/dx)``
particles, each with volume ``dx^2``.

>>> fill_rectangle((0.0, 0.0), (0.3, 0.2), 0.1).shape
(6, 2)
"""

import numpy as np

from fsi_sph.config import ConfigError


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


def fill_shapes(shapes, dx, key="blocks"):
    """Union of the lattice fills of ``shapes`` (config ``Shape`` models), duplicates removed.

    A shape that holds no particle at this ``dx`` is a :class:`ConfigError` naming ``key[k]``.
    """
    pts = []
    for k, s in enumerate(shapes):
        try:
            pts.append(fill_rectangle(s.origin, s.size, dx))
        except ValueError as e:
            raise ConfigError(f"{key}[{k}]: {e}; make it at least dx wide and high "
                              f"or lower case.dx") from None
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
        mask |= in_rectangle(x, s.origin, s.size)
    return mask
