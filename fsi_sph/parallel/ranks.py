"""A scene's fluid split over MPI ranks: each rank steps its own particles and a deep halo.

Each rank owns the fluid particles of its strip of the domain (:mod:`.decomposition`) and
holds, besides them, copies of the other ranks' particles within ``HALO_SUPPORTS`` kernel
supports of its strip (the ghosts, :mod:`.halo`). At the start of every step the particles
that crossed a cut move to their new owner and the ghosts are copied anew from their owners
(one exchange of every field); the rank then runs the serial fluid step on its own particles
and ghosts together, with the serial code unchanged, except that the PPE is one global
system (:mod:`.ppe_gather`: each rank's own rows, solved together). A ghost near the halo's
outer edge has a truncated support and comes out wrong; that error travels inwards by one
support per operator that reads a neighbour's result, so a halo deeper than the step's chain
of such operators leaves every owned particle exact, and the ghosts' results are dropped.
This trades redundant work in the halo (a strip of ``HALO_SUPPORTS`` supports on each side)
for one exchange per step instead of one per operator (docs/parallel.md, with the
measurement behind ``HALO_SUPPORTS``).

The local rows are kept in global-id order (owned and ghosts interleaved), so every
neighbour list, every sum over it and the PPE gathered on rank 0 are those of the serial
run: the fluid on P ranks is the serial run bit for bit (tests/parallel/test_fluid_ranks.py).

Supported: the fluid with its fixed walls (the walls are small and every rank holds all of
them; each is owned, as a row of the PPE, by the rank of its strip). Structures, soils, open
boundaries, periodic images and moving frames are not split yet (:func:`check_scene`).
"""

from __future__ import annotations

import math
import time

import numpy as np

from fsi_sph.errors import SimulationError
from fsi_sph.parallel.decomposition import Strips, needs_rebalance
from fsi_sph.parallel.halo import Halo, migrate
from fsi_sph.parallel.ppe_blocks import numbering, petsc_numbering
from fsi_sph.parallel.ppe_gather import GatheredPressureSolver, RowNumbering
from fsi_sph.simulation import Simulation
from fsi_sph.sph.kernels import SUPPORT

#: halo depth in kernel supports (docs/parallel.md: the smallest depth at which the dam
#: break on 2 ranks repeats the serial run bit for bit, plus a margin)
HALO_SUPPORTS = 4
#: how the PPE of a split fluid is solved: gathered to rank 0 (ppe_gather.py) or by PETSc
#: over the ranks (ppe_blocks.py, petsc_ppe.py)
ENGINES = {"gather": "the PPE gathered to rank 0 and solved there by pyamg",
           "petsc": "the PPE solved by PETSc over the ranks"}


def ppe_engine(choice="auto"):
    """``"petsc"`` when asked or (``"auto"``) when petsc4py is installed, else
    ``"gather"``; asking for PETSc without it raises :class:`SimulationError`."""
    from fsi_sph.parallel import petsc_ppe

    if choice not in ("auto", "petsc", "gather"):
        raise SimulationError(f"PPE engine {choice!r}: allowed auto, petsc, gather")
    if choice == "petsc" and not petsc_ppe.available():
        raise SimulationError("PPE engine petsc: petsc4py is not installed "
                              "(docs/parallel.md, Install)")
    if choice == "auto":
        return "petsc" if petsc_ppe.available() else "gather"
    return choice


def engine_text(choice="auto"):
    """What the PPE on several ranks will be (``fsi-sph info``)."""
    from fsi_sph.parallel import petsc_ppe

    engine = ppe_engine(choice)
    return ENGINES[engine] + (f" ({petsc_ppe.engine()})" if engine == "petsc" else
                              " (petsc4py not installed)")
#: the strips are cut anew when the busiest rank has this much more than the mean (issue 32)
REBALANCE = 0.10


def check_scene(sim):
    """Raise :class:`SimulationError` naming what a scene holds that is not split over
    ranks yet (the run works on one rank)."""
    fl = sim.fluid
    missing = []
    if fl is None:
        missing.append("a scene without a fluid")
    if sim.structures:
        missing.append("structures or soils (" + ", ".join(sim.structures) + ")")
    if fl is not None and fl.open is not None:
        missing.append("open boundaries")
    if fl is not None and fl.periodic is not None:
        missing.append("periodic fluid")
    if sim.frame is not None:
        missing.append("a moving frame")
    if fl is not None and fl.pressure.incremental:
        missing.append("fluid.projection = \"incremental\"")
    if missing:
        raise SimulationError("not yet on several MPI ranks: " + "; ".join(missing)
                              + " (run it on one rank)")


def set_fluid_rows(fl, arrays):
    """The fluid body of ``fl`` becomes the rows ``arrays`` (every field of the body, same
    names: a rank's own particles and its ghosts); the stacked arrays are laid out anew
    with the walls' rows carried over (:meth:`FluidParticles.restack`) and the parts' work
    arrays follow the new count."""
    b = fl.body
    b.select(np.zeros(b.n, dtype=bool), len(arrays["x"]))
    for k in b.arrays:
        b[k][:] = arrays[k]
    fl.restack(np.zeros(0))
    fl.resized()


class FluidOnRanks:
    """The split of ``sim.fluid`` over the ranks of ``comm`` (module docstring)."""

    def __init__(self, sim, comm, halo_supports=HALO_SUPPORTS, ppe="auto"):
        check_scene(sim)
        self.comm = comm
        self.fluid = fl = sim.fluid
        self.width = halo_supports * SUPPORT * fl.h
        x = fl.body["x"]
        self.nf_global = fl.nf
        self.x_walls = fl.x_all[fl.nf:fl.nf + fl.n_fixed].copy()
        self.strips = Strips.balanced(comm, x if comm.rank == 0 else x[:0])
        self.own_from_body()
        self.engine = ppe_engine(ppe)
        if self.engine == "petsc":
            from fsi_sph.parallel.ppe_blocks import BlockPressureSolver

            self.ppe = BlockPressureSolver(fl.cfg.ppe, comm, self)
        else:
            self.ppe = GatheredPressureSolver(fl.cfg.ppe, comm)
        self.ppe_engine = ENGINES[self.engine]
        fl.pressure.ppe = self.ppe
        fl.pressure.increments.ppe = self.ppe
        self.is_own = None
        self.halo = None
        self.rebalanced = 0  # times the strips were cut anew
        self.x_start = None  # the rows' positions at the start of the last step
        self.traffic = [0, 0]  # bytes and messages this rank sent in the ghost exchanges

    def distribute(self):
        """Owned particles to their strips, ghosts copied anew, the fluid's rows laid out
        in global-id order, the PPE's global numbering set."""
        comm, fl = self.comm, self.fluid
        if needs_rebalance(comm, len(self.own["gid"]), REBALANCE):
            self.strips = Strips.balanced(comm, self.own["x"])
            self.rebalanced += 1
        own = migrate(comm, self.strips, self.own)
        wall_own = self.strips.owner(self.x_walls)
        if self.engine == "petsc":  # PETSc's rows: a block per rank (ppe_blocks.py)
            own["prow"], wall_rows, self.ppe.row_start, n_rows = petsc_numbering(
                comm, own["gid"], wall_own)
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
        set_fluid_rows(fl, {k: np.concatenate([own[k], ghost[k]])[order]
                            for k in fl.body.arrays})
        self.x_start = fl.body["x"].copy()
        self.wall_own = wall_own == comm.rank
        n_global = self.nf_global + len(self.x_walls)
        if self.engine == "petsc":
            prow = np.concatenate([own["prow"], ghost["prow"]])[order]
            self.ppe.rows = numbering(prow, wall_rows, self.is_own, self.wall_own, n_rows,
                                      self.nf_global)
            return
        global_row = np.concatenate([self.gid, self.nf_global + np.arange(len(self.x_walls))])
        owned = np.flatnonzero(np.concatenate([self.is_own, self.wall_own]))
        self.ppe.rows = RowNumbering(global_row, owned, n_global, self.nf_global)

    def spread(self, x):
        """A solution over this rank's block (its own fluid rows in global-id order, then
        its walls) to every stacked row: the ghosts' values from their owners (the halo),
        the walls' from every rank (an all-gather). Collective."""
        n_fluid = int(np.count_nonzero(self.is_own))
        own_vals = np.empty(self.n_own)
        own_vals[self.order[self.is_own]] = x[:n_fluid]
        ghost_vals = self.halo.exchange(own_vals)
        out = np.empty(len(self.order) + len(self.x_walls))
        out[:len(self.order)] = np.concatenate([own_vals, ghost_vals])[self.order]
        walls = self.comm.allgather((np.flatnonzero(self.wall_own), x[n_fluid:]))
        for index, vals in walls:
            out[len(self.order) + index] = vals
        return out

    def collect(self):
        """After the step: the owned particles' fields from the fluid body (the ghosts'
        results are dropped)."""
        b = self.fluid.body
        self.own = {k: a[self.is_own].copy() for k, a in b.arrays.items()}
        self.own["gid"] = self.gid[self.is_own]
        self.own["x_start"] = self.x_start[self.is_own]

    def own_from_body(self):
        """This rank's particles taken from the fluid body when it holds every particle in
        global-id order (at the start, after a restart's state was loaded)."""
        b = self.fluid.body
        mine = self.strips.owner(b["x"]) == self.comm.rank
        self.own = {k: a[mine].copy() for k, a in b.arrays.items()}
        self.own["gid"] = np.flatnonzero(mine).astype(np.int64)

    def global_view(self):
        """Every fluid particle's fields in the fluid body, in global-id order (the serial
        run's layout), with neighbour lists for it; collective. The guard, the probes and
        the output read the fluid there, as in a serial run; the next step starts from the
        owned particles again."""
        fl = self.fluid
        whole = {k: self.gathered(k) for k in fl.body.arrays}
        set_fluid_rows(fl, whole)
        if self.x_start is not None:  # the step's lists: at its start, as the serial run's
            fl.body["x"][:] = self.gathered("x_start")
        fl.update_neighbors()
        fl.body["x"][:] = whole["x"]
        fl.sync()

    def gathered(self, name):
        """Field ``name`` of every fluid particle in global-id order, on every rank."""
        parts = self.comm.allgather((self.own["gid"], self.own[name]))
        gid = np.concatenate([p[0] for p in parts])
        out = np.empty((self.nf_global, *self.own[name].shape[1:]), self.own[name].dtype)
        out[gid] = np.concatenate([p[1] for p in parts])
        return out


class RankSimulation(Simulation):
    """A :class:`Simulation` whose fluid is split over the ranks of ``comm``: every rank
    builds the scene, keeps its strip's particles, and steps them with the others."""

    def __init__(self, cfg, comm, halo_supports=HALO_SUPPORTS, ppe="auto"):
        super().__init__(cfg)
        self.ranks = FluidOnRanks(self, comm, halo_supports, ppe)
        self.writes_output = comm.rank == 0
        self.viewed = 0  # the step whose global state the fluid body holds (None: none)

    def gather_view(self):
        """The fluid body holds every particle (:meth:`FluidOnRanks.global_view`), once per
        step; collective."""
        if self.viewed != self.n_steps:
            self.ranks.global_view()
            self.viewed = self.n_steps

    def load_state(self, clock, state):
        """A restart: the whole state is loaded as in a serial run, then each rank takes
        its strip's particles (the file holds them by global id, whatever the ranks that
        wrote it)."""
        super().load_state(clock, state)
        self.ranks.own_from_body()
        self.viewed = self.n_steps

    def step_limits(self):
        """The stable step over all ranks (each rank's limit over its own particles and
        ghosts: the minimum of the ranks' limits is the serial run's)."""
        limits, dt = super().step_limits()
        from mpi4py import MPI

        return limits, self.ranks.comm.allreduce(dt, op=MPI.MIN)

    def step(self, dt_max=math.inf, to_end=False):
        """One step of every rank's particles (:meth:`Simulation.step` on the rank's own
        particles and ghosts); the particle-steps counted are the owned ones over all
        ranks."""
        t0 = time.perf_counter()
        self.ranks.distribute()
        self.timings["exchange"] += time.perf_counter() - t0
        self.viewed = None
        counted = self.particle_steps
        out = super().step(dt_max, to_end)
        self.particle_steps = counted + self.ranks.nf_global
        self.ranks.collect()
        return out
