"""The kinematic guard: no fluid particle moves into a wall or a structure surface (its
inward velocity or shift within the guard distance is removed, :func:`_kernels.
boundary_guard`); at a structure the momentum taken goes to the structure as ``force``."""

from __future__ import annotations

import numpy as np

from fsi_sph.fluid import _kernels as K


class KinematicGuard:
    """The guard of a particle set ``ps``."""

    def __init__(self, ps):
        self.ps = ps
        self.force = np.zeros((ps.ns, 2))  # N/m per structure particle (velocities)
        self.dv = np.zeros((ps.nf, 2))  # work arrays
        self.row = np.zeros(ps.nf, dtype=np.int64)
        self.scratch = np.zeros((ps.nf, 2))
        self.zero_b = np.zeros((ps.nw, 2))  # (grown when periodic images are added)

    def resize(self):
        """A new fluid particle count (open boundaries): the work arrays follow."""
        ps = self.ps
        self.dv = np.zeros((ps.nf, 2))
        self.row = np.zeros(ps.nf, dtype=np.int64)
        self.scratch = np.zeros((ps.nf, 2))
        self.zero_b = np.zeros((ps.nw, 2))

    def ranges(self):
        """The kinematic guard's source ranges and distances: the fixed walls (and their
        periodic images) from dx/2, the coupled structures from 2h/3, where the cubic
        spline's kernel gradient peaks. Closer to a structure than that, the pair repulsion
        [F 46-47] weakens as a fluid particle approaches, the fluid pressure behind it wins,
        and it drifts into the surface layer (seen on the gate's upstream face: particles
        sliding down it at 0.3-0.5 dx from its particles, some ending between them). (The
        walls keep dx/2: thick layers, no such drift seen.)"""
        ps = self.ps
        nf, nwall = ps.nf, ps.nw - ps.ns
        return ((nf, nf + nwall, 0.5 * ps.dx), (nf + nwall, nf + ps.nw, 2.0 * ps.h / 3.0))

    def walls(self, dt, v_old, v, stop=False, rows=None, displacement=False):
        """The kinematic guard at the fixed walls (and their periodic images); on the fluid
        rows ``rows`` only if given. ``displacement``: ``v`` is a displacement (the shift),
        swept with the walls at rest and ``dt = 1``."""
        ps = self.ps
        nf = ps.nf
        (wlo, whi, wgap), _ = self.ranges()
        if whi <= wlo:
            return
        v_b = (self.zero_b if displacement else ps.v_b)[:whi - nf]
        w_new = 0.5 if displacement else ps.w_new  # (v_old = v for a displacement)
        if rows is None:
            K.boundary_guard(ps.x_all, ps.ff_start, ps.ff_j, nf, wlo, whi, ps.wall_n[:whi - nf],
                             v_b, wgap, dt, v_old, v, self.dv, self.row, stop, w_new)
        elif len(rows):
            K.boundary_guard_rows(rows, ps.x_all, ps.ff_start, ps.ff_j, wlo, whi,
                                  ps.wall_n[:whi - nf], v_b, wgap, dt, v_old, v, self.dv,
                                  self.row, stop, w_new)

    def walls_again(self, dt, v_old, v, displacement=False):
        """The fixed walls' guard once more on the rows the structures' guard just changed
        (``self.row >= 0``): a particle squeezed between a structure and a wall keeps out of
        the wall (the structure's guard alone, applied last, pushed a particle trapped under
        a landing block through the floor: measured, the zoo's sinking body). The walls are
        fixed: what they take is not passed on. A contact rule, not in PHYSICS.md
        (tests/unit/test_coupling_fluid.py, the squeezed particle)."""
        self.walls(dt, v_old, v, rows=np.flatnonzero(self.row >= 0), displacement=displacement)

    def inelastic_contact(self, dt):
        """The kinematic guard (:func:`_kernels.boundary_guard` with ``stop``, swept over
        the step ``dt u*``) applied to the intermediate velocity ``u*`` at the fixed walls,
        before the pressure solve: a particle in the guard's band or reaching it within the
        step loses its whole velocity into the wall (restitution 0), so the projection does
        not stop it with an impulsive pressure ``~ rho u_n dx / dt`` that its neighbours
        also feel (at a granular front 5-10 kPa against a hydrostatic 0.1-0.2 kPa, which
        pushed the tip particles ahead; other kicks at the thin front remain,
        docs/numerics/fluid.md, "Wall contact"). No equation in PHYSICS.md: a contact rule
        for grains."""
        ps = self.ps
        self.scratch[:] = ps.v_star  # (free outside the shift's guard)
        self.walls(dt, self.scratch, ps.v_star, stop=True)

    def shift(self, dr):
        """No shift into a boundary: within the guard distance of a wall or structure surface
        (:meth:`ranges`) the inward part of the shift ``dr`` is removed. Close to a
        boundary particle the colour gradient of the shift weakens as the kernel gradient
        does, and the shift alone walked particles into the gate's surface layer (measured)."""
        ps = self.ps
        nf = ps.nf
        if len(self.zero_b) < ps.nw:  # periodic images change the boundary count
            self.zero_b = np.zeros((ps.nw, 2))
        for lo, hi, gap in self.ranges():
            if hi > lo:  # boundary at rest for a shift, swept as a displacement (dt = 1)
                self.scratch[:] = dr
                K.boundary_guard(ps.x_all, ps.ff_start, ps.ff_j, nf, lo, hi,
                                 ps.wall_n[lo - nf:hi - nf], self.zero_b[lo - nf:hi - nf],
                                 gap, 1.0, self.scratch, dr, self.dv,
                                 self.row)
        if ps.ns:  # structure rows last: the walls again on the rows it moved
            self.scratch[:] = dr
            self.walls_again(1.0, self.scratch, dr, displacement=True)

    def velocities(self, dt, v):
        """The kinematic guard (:func:`_kernels.boundary_guard`, :meth:`ranges`) at the
        fixed walls, then at the coupled structures' surfaces; there the fluid's momentum
        change goes to the structure particles as ``self.force`` (N/m per structure
        particle), opposite and equal."""
        ps = self.ps
        nf = ps.nf
        self.walls(dt, ps.v_old, v)
        _, (slo, shi, sgap) = self.ranges()
        if shi > slo:
            K.boundary_guard(ps.x_all, ps.ff_start, ps.ff_j, nf, slo, shi,
                             ps.wall_n[slo - nf:], ps.v_b[slo - nf:], sgap, dt, ps.v_old,
                             v, self.dv, self.row, False, ps.w_new)
            self.force[:] = 0.0
            hit = self.row >= 0
            if hit.any():
                np.add.at(self.force, self.row[hit],
                          -(ps.body["m"][hit] / dt)[:, None] * self.dv[hit])
                self.walls_again(dt, ps.v_old, v)
