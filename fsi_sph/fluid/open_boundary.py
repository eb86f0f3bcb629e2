"""Open boundaries of the ISPH fluid: inflow and outflow buffers of particles
(``[[fluid.inflow]]``, ``[[fluid.outflow]]``; config in ``fsi_sph/config/open_boundary.py``).

Each open line ``x = x_b`` over ``[y0, y1]`` has a buffer one kernel support deep
(``ceil(2h / dx)`` lattice columns), so that a fluid particle next to the line has a full
support. Buffer particles are boundary rows of the fluid's solve, stacked after the fixed
walls (``[fluid | walls | inflow buffers | outflow buffers | structures]``; ``ps.n_walls``
counts the fixed walls and the buffers, ``ps.n_fixed`` the walls alone):

- **inflow** (behind the line, ``x_b - 2h <= x < x_b``): a moving wall with the prescribed
  velocity ``u(y, t)`` (Adami's extrapolation row with ``g - a_b``, ``a_b`` the profile's
  rate of change; in ``div u*`` at ``u_b + dt (g - a_b)``, as the walls; the no-slip target
  of the viscous term), i.e. a Dirichlet velocity and a zero-gradient pressure. A buffer
  particle that crosses the line becomes a fluid particle with the profile's velocity and
  the buffer particle goes back one buffer depth: the inflow's lattice columns stream in
  without gaps or overlaps.
- **outflow** (beyond the line): a Dirichlet pressure (the row ``p = p_out`` in the
  solve) and a zero-gradient velocity (each buffer particle takes the Shepard average of the
  fluid velocity at its mirror image ``2 x_b - x`` about the line). A fluid particle that
  crosses the line becomes a buffer particle; one that leaves the buffer's far side is
  deleted.

(The treatment of Tafuni et al. 2018, CMAME 342:604, with the zero-order mirror
extrapolation and the pressure condition as a row of the incompressible solve; no equation
in PHYSICS.md.) The fluid particle count changes at :meth:`exchange`, before the neighbour
search of a step; the mass that entered and left is recorded per step.
"""

from __future__ import annotations

import math

import numpy as np

from fsi_sph.fluid import _kernels as K
from fsi_sph.neighbors import find_neighbors
from fsi_sph.sph.kernels import SUPPORT


def line_rows(y_range, dx):
    """Lattice row heights ``y0 + (j + 1/2) dx`` over a line's ``[y0, y1]``."""
    n = max(int(round((y_range[1] - y_range[0]) / dx)), 1)
    return y_range[0] + (np.arange(n) + 0.5) * dx


def buffer_columns(x_line, y_range, dx, layers, sign):
    """Lattice points of a buffer: ``layers`` columns at ``x_line + sign (c + 1/2) dx``."""
    y = line_rows(y_range, dx)
    cols = [np.column_stack([np.full(len(y), x_line + sign * (c + 0.5) * dx), y])
            for c in range(layers)]
    return np.vstack(cols)


class OpenBoundaries:
    """The inflow and outflow buffers of a ``FluidSection`` ``cfg`` (spacing ``dx``,
    smoothing length ``h``)."""

    def __init__(self, cfg, dx, h):
        self.dx = dx
        self.layers = math.ceil(SUPPORT * h / dx - 1e-9)
        self.depth = self.layers * dx
        self.h = h
        self.in_line = np.array([f.x for f in cfg.inflow], dtype=float)
        self.in_y = np.array([f.y_range for f in cfg.inflow], dtype=float).reshape(-1, 2)
        self.profiles = [f.velocity.function(f.y_range) for f in cfg.inflow]
        self.out_line = np.array([f.x for f in cfg.outflow], dtype=float)
        self.out_y = np.array([f.y_range for f in cfg.outflow], dtype=float).reshape(-1, 2)
        self.p_out = np.array([f.pressure for f in cfg.outflow], dtype=float)
        pts = [buffer_columns(f.x, f.y_range, dx, self.layers, -1.0) for f in cfg.inflow]
        self.x_in = np.vstack(pts) if pts else np.zeros((0, 2))
        self.in_of = np.repeat(np.arange(len(pts)), [len(p) for p in pts])
        pts = [buffer_columns(f.x, f.y_range, dx, self.layers, 1.0) for f in cfg.outflow]
        self.x_out = np.vstack(pts) if pts else np.zeros((0, 2))
        self.out_of = np.repeat(np.arange(len(pts)), [len(p) for p in pts])
        self.v_in = np.zeros((len(self.x_in), 2))
        self.a_in = np.zeros((len(self.x_in), 2))
        self.v_out = np.zeros((len(self.x_out), 2))
        self.mass_in = 0.0  # kg/m entered / left at the last exchange
        self.mass_out = 0.0
        self.u_max = 0.0  # largest inflow speed so far (the guard's energy supply)

    @property
    def n(self):
        return len(self.x_in) + len(self.x_out)

    @property
    def n_in(self):
        return len(self.x_in)

    def positions(self):
        return np.vstack([self.x_in, self.x_out])

    def velocities(self):
        return np.vstack([self.v_in, self.v_out])

    def body_force(self, gravity):
        """``g - a_b`` of the buffer rows (Adami's extrapolation): the inflow profile's
        rate of change, none for the outflow."""
        return np.vstack([gravity - self.a_in, np.tile(gravity, (len(self.x_out), 1))])

    # ------------------------------------------------------------------ regions
    def _line_of(self, x, lines, ys, lo, hi):
        """Index of the line whose strip ``lines + [lo, hi)`` (over its y range) holds each
        point, -1 for none."""
        out = np.full(len(x), -1, dtype=np.int64)
        for k in range(len(lines)):
            inside = ((x[:, 0] >= lines[k] + lo) & (x[:, 0] < lines[k] + hi)
                      & (x[:, 1] >= ys[k, 0]) & (x[:, 1] <= ys[k, 1]))
            out[inside & (out < 0)] = k
        return out

    def inside(self, x):
        """Points inside any buffer (fluid particles placed there at t = 0 are dropped)."""
        behind = self._line_of(x, self.in_line, self.in_y, -self.depth, 0.0) >= 0
        beyond = self._line_of(x, self.out_line, self.out_y, 0.0, self.depth) >= 0
        return behind | beyond

    def _past_outflow(self, x_fluid):
        """Index of the outflow line each fluid particle has passed, -1 for none."""
        return self._line_of(x_fluid, self.out_line, self.out_y, 0.0, math.inf)

    def _back_through_inflow(self, x_fluid):
        """The fluid particles that went back through an inflow line."""
        return self._line_of(x_fluid, self.in_line, self.in_y, -math.inf, 0.0) >= 0

    def leaving(self, x_fluid):
        """The fluid particles that leave the fluid at the next :meth:`exchange`: past an
        outflow line (they join its buffer) or back through an inflow line (deleted)."""
        return (self._past_outflow(x_fluid) >= 0) | self._back_through_inflow(x_fluid)

    # ------------------------------------------------------------------ the step
    def exchange(self, x_fluid, v_fluid, p_buffer, mass):
        """Particles that crossed a line during the last move: inflow buffer particles past
        their line become fluid (their buffer particle goes back one depth); fluid particles
        past an outflow line join its buffer; buffer particles past its far side, and fluid
        particles that went back through an inflow line, are deleted.

        ``p_buffer``: the buffer rows' pressures (stacked inflow, outflow). Returns ``(keep,
        new_x, new_v, new_p, p_buffer)``: the fluid rows kept, the new fluid particles and
        the buffer rows' pressures in their new order (``crossed``: the inflow buffer rows
        that became the new fluid particles, in their order); ``mass`` (kg/m per particle)
        counts ``mass_in`` and ``mass_out``."""
        n_in = self.n_in
        crossed = self.x_in[:, 0] >= self.in_line[self.in_of]
        self.crossed = np.flatnonzero(crossed)  # (the new fluid particles' buffer rows)
        new_x = self.x_in[crossed].copy()
        new_v = self.v_in[crossed].copy()
        new_p = p_buffer[:n_in][crossed].copy()
        self.x_in[crossed, 0] -= self.depth
        leaving = self._past_outflow(x_fluid)
        gone = self.x_out[:, 0] >= self.out_line[self.out_of] + self.depth
        stay = ~gone
        joined = leaving >= 0
        self.keep = keep = ~(joined | self._back_through_inflow(x_fluid))
        self.stay = stay
        self.joined_rows = np.flatnonzero(joined)
        self.x_out = np.vstack([self.x_out[stay], x_fluid[joined]])
        self.out_of = np.concatenate([self.out_of[stay], leaving[joined]])
        self.v_out = np.vstack([self.v_out[stay], v_fluid[joined]])
        p_out = np.concatenate([p_buffer[n_in:][stay], self.p_out[leaving[joined]]])
        self.mass_in = mass * float(np.count_nonzero(crossed))
        self.mass_out = mass * float(np.count_nonzero(~keep))
        return keep, new_x, new_v, new_p, np.concatenate([p_buffer[:n_in], p_out])

    def set_velocities(self, t, dt, x_fluid, v_fluid, kind, fluid_corner=None):
        """Buffer velocities for the step ``t -> t + dt``: the inflow profile at ``t + dt``
        (the velocity the boundary rows carry at the step's end) and its rate of change over
        the step; the outflow's zero-gradient extrapolation from the fluid (Shepard average
        at the mirror image about the line; a particle without fluid there keeps its
        velocity). ``fluid_corner``: the lower corner of the whole fluid when ``x_fluid``
        holds part of it (a fluid split over ranks), so that the neighbour search's cell
        grid, and with it the order of each Shepard sum, is the whole fluid's."""
        for k, u in enumerate(self.profiles):
            rows = self.in_of == k
            y = self.x_in[rows, 1]
            u1 = u(y, t + dt)
            self.a_in[rows, 0] = (u1 - u(y, t)) / dt
            self.v_in[rows, 0] = u1
            self.u_max = max(self.u_max, float(np.max(np.abs(u1), initial=0.0)))
        if not len(self.x_out) or not len(x_fluid):
            return
        mirror = self.x_out.copy()
        mirror[:, 0] = 2.0 * self.out_line[self.out_of] - mirror[:, 0]
        radius = SUPPORT * self.h
        origin = None
        if fluid_corner is not None:  # (find_neighbors' own corner, over the whole fluid)
            origin = np.minimum(np.min(mirror, axis=0), fluid_corner) - radius
        start, j = find_neighbors(mirror, x_fluid, radius, origin=origin)
        out = np.empty(len(mirror))
        for c in range(2):
            K.shepard_at(mirror, x_fluid, np.ascontiguousarray(v_fluid[:, c]), start, j,
                         self.h, kind, out)
            self.v_out[:, c] = np.where(np.isfinite(out), out, self.v_out[:, c])

    def move(self, dt):
        """The buffers move with their velocities over the step."""
        self.x_in += dt * self.v_in
        self.x_out += dt * self.v_out

    def hold_pressure(self, A, rhs, first_row, diag_ref):
        """The outflow buffer rows of the assembled solve ``A p = rhs`` become ``p = p_out``
        (rows ``first_row + n_in ..``; in place, the diagonal scaled like the other rows)."""
        rows = first_row + self.n_in + np.arange(len(self.x_out))
        if not len(rows):
            return
        at = slice(A.indptr[rows[0]], A.indptr[rows[-1] + 1])  # consecutive rows: one range
        row = np.repeat(rows, np.diff(A.indptr[rows[0]:rows[-1] + 2]))
        A.data[at] = np.where(A.indices[at] == row, diag_ref, 0.0)
        rhs[rows] = diag_ref * self.p_out[self.out_of]

    # ------------------------------------------------------------------ state
    def state(self):
        return {"x_in": self.x_in.copy(), "x_out": self.x_out.copy(),
                "out_of": self.out_of.copy(), "v_in": self.v_in.copy(),
                "v_out": self.v_out.copy(), "a_in": self.a_in.copy(),
                "u_max": np.array(self.u_max)}

    def load_state(self, s):
        self.x_in = np.array(s["x_in"])
        self.x_out = np.array(s["x_out"]).reshape(-1, 2)
        self.out_of = np.array(s["out_of"], dtype=np.int64)
        self.v_in = np.array(s["v_in"])
        self.v_out = np.array(s["v_out"]).reshape(-1, 2)
        self.a_in = np.array(s["a_in"])
        self.u_max = float(s["u_max"])
