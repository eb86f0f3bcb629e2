"""Periodic fluid in x (``[fluid] periodic_x = [x_min, x_max]``), by image particles.

At every neighbour update the fluid positions are wrapped into ``[x_min, x_max)`` and every
fluid or wall particle within one kernel support ``2h`` of an edge gets an image shifted by
``+-L`` (``L = x_max - x_min``) across the other edge. The images are extra boundary rows of
the fluid's stacked arrays, after the fixed walls (``[fluid | walls | images]``), so every
loop sees them as ordinary neighbours, with the state of their original copied in
(:meth:`Periodic.sync`: position + shift, velocity, pressure, viscosity). They are not free
unknowns:

* PPE: an image row is ``p_image - p_original = 0`` (scaled like the other rows), so one
  pressure field is solved for and the images carry exactly their original's pressure;
* divergence of ``u*``: a fluid image enters with its original's ``u*``;
* implicit viscous step: a fluid image's column is folded onto its original's
  (:mod:`fsi_sph.fluid.viscous`); wall images keep the wall velocity (zero);
* the wall rows' Adami extrapolation sees the fluid images as fluid neighbours, so a wall
  particle at the seam sees a full fluid support.

A period shorter than two supports plus dx is refused by the config (a particle would meet
two images of one neighbour). Structures (coupling) are not supported with periodicity.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from fsi_sph.neighbors import find_neighbors
from fsi_sph.sph.kernels import SUPPORT


def images(x, x_min, x_max, reach):
    """Indices of the points within ``reach`` of an edge and the x shift of their image:
    ``(idx, shift)``; points near ``x_min`` are copied to ``+L``, near ``x_max`` to ``-L``."""
    period = x_max - x_min
    lo = np.flatnonzero(x[:, 0] < x_min + reach)
    hi = np.flatnonzero(x[:, 0] >= x_max - reach)
    return (np.concatenate([lo, hi]),
            np.concatenate([np.full(len(lo), period), np.full(len(hi), -period)]))


def wrap(x, x_min, x_max):
    """Positions wrapped into ``[x_min, x_max)`` (in place)."""
    x[:, 0] = x_min + np.mod(x[:, 0] - x_min, x_max - x_min)


class Periodic:
    """Periodic images of an :class:`~fsi_sph.fluid.isph.IncompressibleFluid` (x only)."""

    def __init__(self, x_range, fluid):
        if fluid.ns:
            raise ValueError("periodic_x with coupled structures is not supported")
        self.x_min, self.x_max = float(x_range[0]), float(x_range[1])
        self.reach = SUPPORT * fluid.h
        self.n_walls = fluid.n_walls
        if fluid.walls is not None:  # walls are fixed: their images once and for all
            wrap(fluid.walls.body["x"], self.x_min, self.x_max)
            fluid.x_all[fluid.nf:fluid.nf + fluid.n_walls] = fluid.walls.body["x"]
            self.wall_idx, self.wall_shift = images(fluid.walls.body["x"], self.x_min,
                                                    self.x_max, self.reach)
        else:
            self.wall_idx, self.wall_shift = np.zeros(0, np.int64), np.zeros(0)
        if fluid.walls is not None and self.n_walls:
            # the walls' outward normals over the wall set and its images: computed without
            # them (isph), the bed particles at the seams got the normals of a box's end,
            # (-1, 0) and (-0.71, 0.71), and the no-slip mirror there moved along the bed
            fluid.wall_n[:self.n_walls] = self._periodic_wall_normals(fluid)
        self.wall_n0 = fluid.wall_n[:self.n_walls].copy()
        self.fluid_idx = np.zeros(0, np.int64)
        self.fluid_shift = np.zeros(0)
        self.rows = np.zeros(0, np.int64)  # global rows of the images
        self.src = np.zeros(0, np.int64)   # global rows of their originals

    def _periodic_wall_normals(self, fluid):
        """The walls' normals (:meth:`IncompressibleFluid._fixed_wall_normals`) over the
        walls and their periodic images."""
        xw = fluid.walls.body["x"]
        xi = xw[self.wall_idx].copy()
        xi[:, 0] += self.wall_shift
        return fluid.fixed_wall_normals(np.vstack([xw, xi]))[:len(xw)]

    # ------------------------------------------------------------------ layout
    def rebuild(self, fluid):
        """Wrap the fluid positions, find the images and lay out the stacked arrays."""
        nf, nwall = fluid.nf, self.n_walls
        wrap(fluid.body["x"], self.x_min, self.x_max)
        self.fluid_idx, self.fluid_shift = images(fluid.body["x"], self.x_min, self.x_max,
                                                  self.reach)
        nfi = len(self.fluid_idx)
        ng = nfi + len(self.wall_idx)
        base = nf + nwall
        self.rows = base + np.arange(ng)
        self.src = np.concatenate([self.fluid_idx, nf + self.wall_idx])
        self.shift = np.concatenate([self.fluid_shift, self.wall_shift])
        n = base + ng
        if len(fluid.x_all) != n:
            def grow(a, fill=0.0):
                out = np.full((n,) + a.shape[1:], fill, dtype=a.dtype)
                m = min(len(a), base)
                out[:m] = a[:m]
                return out

            fluid.x_all = grow(fluid.x_all)
            fluid.v_all = grow(fluid.v_all)
            fluid.vol_all = grow(fluid.vol_all, fluid.dx * fluid.dx)
            fluid.nu_all = grow(fluid.nu_all)
            fluid.p_all = grow(fluid.p_all)
            nb = n - nf
            fluid.v_b = np.zeros((nb, 2))
            fluid.g_b = np.tile(fluid.gravity, (nb, 1))
            fluid.implicit = np.zeros(nb)
            fluid.wall_n = np.zeros((nb, 2))
            fluid.wall_n[:nwall] = self.wall_n0
            fluid.nw = nb
        # wall images: the wall's normal (kinematic guard); fluid images: none
        fluid.wall_n[nwall:] = 0.0
        fluid.wall_n[nwall + nfi:] = self.wall_n0[self.wall_idx]

    def sync(self, fluid):
        """Copy position (+ shift), velocity, pressure and viscosity of the originals."""
        r, s = self.rows, self.src
        fluid.x_all[r] = fluid.x_all[s]
        fluid.x_all[r, 0] += self.shift
        fluid.v_all[r] = fluid.v_all[s]
        fluid.p_all[r] = fluid.p_all[s]
        fluid.nu_all[r] = fluid.nu_all[s]
        k = len(self.fluid_idx)  # boundary velocity: the fluid's, or the wall's own
        fluid.v_b[r[:k] - fluid.nf] = fluid.v_all[s[:k]]
        fluid.v_b[r[k:] - fluid.nf] = fluid.v_b[s[k:] - fluid.nf]

    def fluid_images(self):
        """(global rows, global originals) of the fluid images."""
        k = len(self.fluid_idx)
        return self.rows[:k], self.src[:k]

    # ------------------------------------------------------------------ hooks
    def boundary_lists(self, fluid):
        """Neighbour lists of the boundary rows over the fluid and its images."""
        rows, _ = self.fluid_images()
        sources = np.concatenate([np.arange(fluid.nf), rows])
        start, j = find_neighbors(fluid.x_all[fluid.nf:], fluid.x_all[sources], self.reach)
        fluid.wf_start, fluid.wf_j = start, sources[j]

    def boundary_star(self, fluid, vb_star):
        """The fluid images enter ``div u*`` with their original's ``u*``."""
        rows, src = self.fluid_images()
        vb_star[rows - fluid.nf] = fluid.v_star[src]
        return vb_star

    def constrain(self, A, rhs, diag_ref):
        """Replace the image rows of the PPE by ``diag_ref (p_image - p_original) = 0``."""
        n = A.shape[0]
        ng = len(self.rows)
        if ng == 0:
            return A, rhs
        keep = np.ones(n)
        keep[self.rows] = 0.0
        G = sp.csr_array((np.concatenate([np.full(ng, diag_ref), np.full(ng, -diag_ref)]),
                          (np.concatenate([self.rows, self.rows]),
                           np.concatenate([self.rows, self.src]))), shape=(n, n))
        A = sp.csr_array(sp.diags_array(keep) @ A + G)
        A.eliminate_zeros()
        A.sort_indices()
        A.indices = A.indices.astype(np.int32)
        A.indptr = A.indptr.astype(np.int32)
        rhs = rhs.copy()
        rhs[self.rows] = 0.0
        return A, rhs
