"""One body's particles split over MPI ranks (the fluid's and a soil's alike;
fsi_sph/parallel/ranks.py has the design): strips or boxes cut for equal work
(:mod:`.boxes`), the owned particles, their migration, the ghosts of a deep halo, the rows
in global-id order, and the whole body gathered for the guard, the probes and the output."""

from __future__ import annotations

import numpy as np

from fsi_sph.parallel.boxes import partition
from fsi_sph.parallel.comm import gather_rows, gather_rows_to_root, global_reduce
from fsi_sph.parallel.decomposition import needs_rebalance
from fsi_sph.parallel.halo import Halo, migrate

#: the strips are cut anew when the busiest rank has this much more than the mean (issue 32)
REBALANCE = 0.10


def replace_rows(body, arrays):
    """``body`` holds the rows ``arrays`` from now on (every field of it, same names)."""
    body.select(np.zeros(body.n, dtype=bool), len(arrays["x"]))
    for k in body.arrays:
        body[k][:] = arrays[k]


class BodyOnRanks:
    """The particles of ``obj.body`` (its serial row is a particle's global id) split over
    the ranks of ``comm`` with a halo ``width`` deep. Subclasses lay the rows out in their
    body (:meth:`relayout`) and may add fields to the exchange (:meth:`numbered`)."""

    def __init__(self, comm, obj, width, slack=0.0):
        self.comm = comm
        self.obj = obj
        self.width = width
        self.slack = slack  # how far an owned particle may stray from its strip
        x = obj.body["x"]
        self.n_global = len(x)
        self.strips = partition(comm, x if comm.rank == 0 else x[:0], width)
        self.own_from_body()
        self.is_own = self.order = self.gid = self.halo = None
        self.n_own = 0
        self.rebalanced = 0  # times the strips were cut anew
        self.migrations = 0  # steps at which particles moved to their strips' ranks
        self.traffic = [0, 0]  # bytes and messages this rank sent in the ghost exchanges

    def own_from_body(self):
        """This rank's particles taken from the body when it holds every particle in
        global-id order (at the start, after a restart's state was loaded)."""
        b = self.obj.body
        self.n_global = b.n
        mine = self.strips.owner(b["x"]) == self.comm.rank
        self.own = {k: a[mine].copy() for k, a in b.arrays.items()}
        self.own["gid"] = np.flatnonzero(mine).astype(np.int64)

    def distribute(self):
        """Owned particles to their strips (cut anew past ``REBALANCE``), ghosts copied
        anew from their owners, the body's rows laid out in global-id order; returns
        ``(own, ghost)``, the exchanged dicts (a subclass numbers rows from them)."""
        comm = self.comm
        rebalance = needs_rebalance(comm, len(self.own["gid"]), REBALANCE)
        if rebalance:
            self.strips = partition(comm, self.own["x"], self.width)
            self.rebalanced += 1
        own = dict(self.own)
        if rebalance or self.strayed():
            own = migrate(comm, self.strips, self.own)
            self.migrations += 1
        return self.lay_out(own)

    def lay_out(self, own):
        """The owned particles ``own`` (a dict of fields with ``gid``) and the ghosts copied
        anew from their owners laid out in the body in global-id order; returns ``(own,
        ghost)``. Collective."""
        comm = self.comm
        own = self.numbered(own)
        self.halo = Halo.build(comm, self.strips, own["x"], self.width)
        ghost = {}
        for k, a in own.items():
            ghost[k] = self.halo.exchange(a)
            self.traffic[0] += self.halo.bytes_last
            self.traffic[1] += self.halo.messages_last
        gid = np.concatenate([own["gid"], ghost["gid"]])
        self.order = order = np.argsort(gid, kind="stable")
        self.n_own = len(own["gid"])
        self.is_own = order < self.n_own
        self.gid = gid[order]
        self.relayout({k: np.concatenate([own[k], ghost[k]])[order]
                       for k in self.obj.body.arrays})
        return own, ghost

    def strayed(self):
        """True when an owned particle on any rank lies farther than ``slack`` outside its
        rank's strip: then every particle goes to the strip it is in. Between, the owners
        stay, and with them the rows of the PPE (PETSc keeps its preconditioner while they
        do); a halo ``slack`` deeper than the step needs keeps every owned particle exact.
        Collective."""
        x = self.own["x"]
        far = float(np.max(self.strips.distance(x, self.comm.rank), initial=0.0))
        return float(global_reduce(self.comm, np.array([far]), "max")[0]) > self.slack

    def numbered(self, own):
        """The owned particles' dict before the ghost exchange (a subclass adds fields)."""
        return own

    def relayout(self, arrays):
        """The body becomes the rows ``arrays`` (every field of the body)."""
        raise NotImplementedError

    def collect(self):
        """After the step: the owned particles' fields from the body (the ghosts' results
        are dropped)."""
        b = self.obj.body
        self.own = {k: a[self.is_own].copy() for k, a in b.arrays.items()}
        self.own["gid"] = self.gid[self.is_own]

    def gathered(self, name, root_only=False):
        """Field ``name`` of every particle in global-id order, on every rank (``root_only``:
        on rank 0, None on the others)."""
        gather = gather_rows_to_root if root_only else gather_rows
        return gather(self.comm, self.own["gid"], self.own[name], self.n_global)

    def global_view(self):
        """Every particle's fields in rank 0's body, in global-id order (the serial run's
        layout), for the guard, the probes and the output, which rank 0 alone runs; the
        other ranks' bodies keep their rows. Collective."""
        whole = {k: self.gathered(k, root_only=True) for k in self.obj.body.arrays}
        if self.comm.rank == 0:
            self.relayout(whole)


class SoilOnRanks(BodyOnRanks):
    """A Drucker-Prager soil body split over ranks: each rank sub-steps its own particles
    and ghosts by the serial sub-step (one sub-step per step in a soil scene)."""

    def __init__(self, comm, obj, width, slack=0.0):
        super().__init__(comm, obj, width, slack)
        obj.grid_origin = self.lowest_corner

    def lowest_corner(self, corner):
        """The serial run's cell grid for the neighbour search: the lowest corner over the
        ranks (the order of the neighbours within a row, and so every sum over them,
        follows the grid; collective)."""
        return global_reduce(self.comm, np.asarray(corner, dtype=np.float64), "min")

    def relayout(self, arrays):
        replace_rows(self.obj.body, arrays)
        self.obj.resized()
