"""Contact of a rigid body with the fixed walls: a body particle closer than one spacing to a
wall particle (their surfaces touch at that distance: each stands half a spacing inside its
own body) may not approach it further. The approach velocity at each contact point is taken
away by an impulse on the body, frictionless and perfectly inelastic (restitution 0, like the
fluid's collision model), the walls being immovable. The impulses of several contact points
are found by sweeping over them, each contact's accumulated impulse kept non-negative, until
none approaches and none pulls (projected Gauss-Seidel for the contact conditions;
Newton-Euler in the plane, not in PHYSICS.md; tested in tests/unit/test_rigid_contact.py).

Without it a body heavier than water sank through the tank's floor (the scene zoo's sinking
block left the domain at 0.99 s).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


class WallContact:
    """The wall particles a rigid body can touch, and the contact impulses."""

    def __init__(self, wall_x, spacing, sweeps=100):
        self.tree = cKDTree(np.asarray(wall_x, dtype=np.float64))
        self.distance = 1.001 * float(spacing)   # touching at one spacing (lattice rounding)
        self.sweeps = sweeps

    def contacts(self, x):
        """(body particle, unit normal from the wall to it) of every touching pair."""
        dist, j = self.tree.query(x, k=1, distance_upper_bound=self.distance)
        touching = np.flatnonzero(np.isfinite(dist) & (dist > 0.0))
        n = x[touching] - self.tree.data[j[touching]]
        n /= np.linalg.norm(n, axis=1)[:, None]
        return touching, n

    def resolve(self, x, xc, vc, omega, mass, inertia):
        """Centre velocity and spin after the contact impulses (restitution 0)."""
        touching, normals = self.contacts(x)
        if len(touching) == 0:
            return vc, omega
        vc = np.array(vc, dtype=np.float64)
        r = x[touching] - xc
        rn = r[:, 0] * normals[:, 1] - r[:, 1] * normals[:, 0]   # r x n
        k = 1.0 / mass + rn * rn / inertia                        # 1 / effective mass
        total = np.zeros(len(touching))  # each contact's impulse so far, >= 0 (it only pushes)
        for _ in range(self.sweeps):
            change = 0.0
            for c in range(len(touching)):
                vn = ((vc[0] - omega * r[c, 1]) * normals[c, 0]
                      + (vc[1] + omega * r[c, 0]) * normals[c, 1])
                new = max(0.0, total[c] - vn / k[c])
                d = new - total[c]
                total[c] = new
                vc += d * normals[c] / mass
                omega += rn[c] * d / inertia
                change = max(change, abs(d) * k[c])   # the velocity it changed
            if change < 1e-12 * (1.0 + float(np.hypot(*vc))):
                break
        return vc, omega
