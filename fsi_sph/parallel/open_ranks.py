"""The open boundaries of a fluid split over MPI ranks (fsi_sph/fluid/open_boundary.py for
the boundaries themselves, fsi_sph/parallel/ranks.py for the split).

Every rank holds the inflow and outflow buffers whole, like the fixed walls, and keeps them
identical to the serial run's: at the start of each step (where the serial step calls
:meth:`IncompressibleFluid.exchange_open_boundaries`)

1. the fluid particles that leave (past an outflow line, back through an inflow line) are
   found by the ranks that own them and sent to every rank in global-id order, the order
   in which the serial run's outflow buffers take them in;
2. every rank runs the serial exchange (:meth:`OpenBoundaries.exchange`) on those particles
   and on its own copy of the buffers, so the inflow particles that cross their line become
   the same new fluid particles on every rank;
3. the global ids follow the serial run's rows: the kept particles keep their order (an id
   drops by the number of leaving particles with a smaller id), the new ones come last in
   the order of their buffer rows; each new particle is owned by the rank whose strip holds
   it, and the ghosts are copied anew from the owners (one more halo exchange, on the steps
   at which a particle crossed a line);
4. the PPE's kept hierarchy follows the whole fluid's map of old to new rows on the rank
   that solves (:meth:`GatheredPressureSolver.remap_rows`);
5. the outflow buffers' velocities (the fluid's velocity at each buffer particle's mirror
   image) are taken from the rank whose strip holds the buffer particle, which holds every
   fluid particle within the halo's depth of it, and searched on the whole fluid's cell grid
   (so each Shepard sum runs in the serial order).

A run on P ranks with the gathered PPE is then the serial run bit for bit
(tests/parallel/test_fluid_ranks.py: the Poiseuille channel and the Turek-Hron channel).
"""

from __future__ import annotations

import numpy as np

from fsi_sph.parallel.comm import gather_rows, global_reduce


def leaving_particles(ranks, leaving):
    """``(gid, x, v)`` of the fluid particles that leave (``leaving``: one flag per local
    row), from the ranks that own them, on every rank in global-id order. Collective."""
    fl = ranks.fluid
    mine = leaving & ranks.is_own
    parts = ranks.comm.allgather((ranks.gid[mine], fl.body["x"][mine], fl.body["v"][mine]))
    gid = np.concatenate([p[0] for p in parts]).astype(np.int64)
    order = np.argsort(gid, kind="stable")
    x = np.concatenate([p[1] for p in parts]).reshape(-1, 2)[order]
    v = np.concatenate([p[2] for p in parts]).reshape(-1, 2)[order]
    return gid[order], x, v


def exchange_open(ranks, t, dt):
    """The open boundaries' exchange of the step ``t -> t + dt`` over the ranks (module
    docstring), then the buffers' velocities. Collective."""
    fl = ranks.fluid
    op = fl.open
    leaving = op.leaving(fl.body["x"])
    gid_out, x_out, v_out = leaving_particles(ranks, leaving)
    lo = fl.nf + fl.n_fixed
    p_buffer = fl.p_all[lo:lo + op.n].copy()
    _, new_x, new_v, new_p, p_buffer = op.exchange(x_out, v_out, p_buffer,
                                                   fl.rho * fl.dx * fl.dx)
    if len(new_x) or len(gid_out) or len(p_buffer) != fl.n_walls - fl.n_fixed:
        renumber(ranks, leaving, gid_out, new_x, new_v, new_p, p_buffer)
    buffer_velocities(ranks, t, dt)


def renumber(ranks, leaving, gid_out, new_x, new_v, new_p, p_buffer):
    """The fluid's rows after particles left and entered (steps 3-4 of the module
    docstring): the local layout, the global ids, the owners, the ghosts, the PPE's rows."""
    fl = ranks.fluid
    keep_all = np.ones(ranks.n_global, dtype=bool)
    keep_all[gid_out] = False
    old_rows = fl.rows_before_exchange(keep_all, gid_out[fl.open.joined_rows])
    new_gid = np.cumsum(keep_all) - 1
    n_kept = ranks.n_global - len(gid_out)
    keep = ~leaving
    gid = np.concatenate([new_gid[ranks.gid[keep]], n_kept + np.arange(len(new_x))])
    is_own = np.concatenate([ranks.is_own[keep],
                             ranks.strips.owner(new_x) == ranks.comm.rank])
    fl.relayout(keep, new_x, new_v, new_p, p_buffer)  # (the new particles' fields, buffers)
    ranks.n_global = n_kept + len(new_x)
    ranks.ppe.remap_rows(old_rows)
    own = {k: a[is_own].copy() for k, a in fl.body.arrays.items()}
    own["gid"] = gid[is_own]
    ranks.own = own
    ranks.rows_numbered(*ranks.lay_out(own))


def buffer_velocities(ranks, t, dt):
    """The buffers' velocities (:meth:`IncompressibleFluid.buffer_velocities`), each outflow
    buffer particle's from the rank whose strip holds it. Collective."""
    fl = ranks.fluid
    op = fl.open
    x = fl.body["x"]  # (every local row is some rank's particle: the ranks' least is the fluid's)
    corner = np.min(x, axis=0) if len(x) else np.full(2, np.inf)
    fl.buffer_velocities(t, dt, global_reduce(ranks.comm, corner, "min"))
    if len(op.x_out):
        mine = np.flatnonzero(ranks.strips.owner(op.x_out) == ranks.comm.rank)
        op.v_out = gather_rows(ranks.comm, mine, op.v_out[mine], len(op.x_out))
        fl.buffer_rows()
