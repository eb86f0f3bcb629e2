"""A scene's fluid split over MPI ranks: each rank steps its own particles and a deep halo.

Each rank owns the fluid particles of its strip of the domain (:mod:`.decomposition`) and
holds, besides them, copies of the other ranks' particles within ``HALO_SUPPORTS`` kernel
supports of its strip (the ghosts, :mod:`.halo`). At the start of every step the particles
that crossed a cut move to their new owner and the ghosts are copied anew from their owners
(one exchange of every field); the rank then runs the serial fluid step on its own particles
and ghosts together, with the serial code unchanged, except that the PPE is one global
system of the ranks' own rows, gathered and solved on rank 0 (:mod:`.ppe_gather`) or solved
by PETSc over the ranks (:mod:`.ppe_blocks`). A ghost near the halo's
outer edge has a truncated support and comes out wrong; that error travels inwards by one
support per operator that reads a neighbour's result, so a halo deeper than the step's chain
of such operators leaves every owned particle exact, and the ghosts' results are dropped.
This trades redundant work in the halo (a strip of ``HALO_SUPPORTS`` supports on each side)
for one exchange per step instead of one per operator (docs/parallel.md, with the
measurement behind ``HALO_SUPPORTS``).

The local rows are kept in global-id order (owned and ghosts interleaved), so every
neighbour list, every sum over it and the PPE gathered on rank 0 are those of the serial
run: with the gathered PPE the fluid on P ranks is the serial run bit for bit
(tests/parallel/test_fluid_ranks.py); with PETSc's, within its solver's tolerance.

Supported: the fluid with its fixed walls, its coupled elastic structures and its free
bodies, in a fixed or a shaken tank, Newtonian or granular (walls and structures are small:
every rank holds all of them, the structures sub-cycled on every rank from the same force;
each wall or structure particle is owned, as a row of the PPE, for the structure's
interface force and for the free bodies' rigid-body terms (:mod:`.low_rank`), by the rank
of its strip; the implicit viscous step is gathered to rank 0, :mod:`.viscous_gather`), and
Drucker-Prager soils alone (:mod:`.split`). A fluid with a soil and periodic images are not
split yet (:func:`check_scene`).
"""

from __future__ import annotations

import math
import time

import numpy as np

from fsi_sph.errors import SimulationError
from fsi_sph.parallel.comm import gather_rows, global_reduce
from fsi_sph.parallel.open_ranks import exchange_open
from fsi_sph.parallel.ppe_blocks import numbering, petsc_numbering
from fsi_sph.parallel.ppe_gather import GatheredPressureSolver, RowNumbering
from fsi_sph.parallel.split import BodyOnRanks, SoilOnRanks, replace_rows
from fsi_sph.parallel.viscous_gather import GatheredViscousSolve
from fsi_sph.simulation import Simulation
from fsi_sph.sph.kernels import SUPPORT

#: halo depth in kernel supports (docs/parallel.md: the smallest depth at which the dam
#: break on 2 ranks repeats the serial run bit for bit, plus a margin)
HALO_SUPPORTS = 4
#: the same for a fluid with a viscosity law or the implicit viscous step, whose step reads
#: neighbours' results more times over (the granular collapse on 2 ranks: 5 supports
#: repeat the serial run bit for bit over 100 steps, 4 do not), and for a fluid with open
#: boundaries, whose viscous term reads the walls' no-slip velocity, itself a Shepard average
#: of the fluid (Turek-Hron FSI2 at D/dx 10 on 2 ranks, 100 steps: 4 supports part from the
#: serial run at step 50 by one rounding in div u* of a particle beside the cut; 5 and 6
#: repeat it bit for bit)
HALO_SUPPORTS_VISCOUS = 6
#: how far (kernel supports) an owned particle may stray outside its strip before the
#: particles move to their strips' ranks: the halos above are one support deeper than
#: measured necessary, so a particle that far out still has every neighbour it reads
STRAY_SUPPORTS = 1


def halo_supports(sim):
    """The halo depth the scene's fluid needs (:data:`HALO_SUPPORTS` or, with a viscosity
    law, the implicit viscous step or open boundaries, :data:`HALO_SUPPORTS_VISCOUS`)."""
    fl = sim.fluid
    deep = fl is not None and (fl.viscous is not None or fl.open is not None)
    return HALO_SUPPORTS_VISCOUS if deep else HALO_SUPPORTS


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


def not_split(sim):
    """What a scene holds that is not split over ranks yet (empty: every part is). Split: a
    fluid (Newtonian or granular) with its fixed walls, coupled structures, free bodies and
    open boundaries (fixed or shaken tank), or Drucker-Prager soils alone."""
    fl = sim.fluid
    missing = []
    solids = [n for n, b in sim.structures.items() if b.body.kind != "soil"]
    if fl is None and not sim.structures:
        missing.append("a scene without a fluid or a soil")
    if solids and fl is None:
        missing.append("structures without a fluid (" + ", ".join(solids) + ")")
    if fl is not None and len(solids) < len(sim.structures):
        missing.append("a fluid and a soil together")
    if fl is not None and fl.periodic is not None:
        missing.append("periodic fluid")
    return missing


def check_scene(sim):
    """Raise :class:`SimulationError` naming what a scene holds that is not split over
    ranks yet (:func:`not_split`; the run works on one rank)."""
    missing = not_split(sim)
    if missing:
        raise SimulationError("not yet on several MPI ranks: " + "; ".join(missing)
                              + " (run it on one rank)")


def set_fluid_rows(fl, arrays):
    """The fluid body of ``fl`` becomes the rows ``arrays`` (every field of the body, same
    names: a rank's own particles and its ghosts); the stacked arrays are laid out anew
    with the walls' rows carried over (:meth:`FluidParticles.restack`) and the parts' work
    arrays follow the new count."""
    replace_rows(fl.body, arrays)
    fl.restack(fl.p_all[fl.nf + fl.n_fixed:fl.nf + fl.n_walls].copy())  # (the buffers')
    fl.resized()


class FluidOnRanks(BodyOnRanks):
    """The split of ``sim.fluid`` over the ranks of ``comm`` (module docstring): its walls,
    held whole by every rank, and its PPE, one global system."""

    def __init__(self, sim, comm, halo_supports=HALO_SUPPORTS, ppe="auto"):
        fl = sim.fluid
        super().__init__(comm, fl, halo_supports * SUPPORT * fl.h,
                         STRAY_SUPPORTS * SUPPORT * fl.h)
        self.fluid = fl
        self.x_walls = fl.x_all[fl.nf:fl.nf + fl.n_fixed].copy()
        self.engine = ppe_engine(ppe)
        if self.engine == "petsc":
            from fsi_sph.parallel.ppe_blocks import BlockPressureSolver

            self.ppe = BlockPressureSolver(fl.cfg.ppe, comm, self)
        else:
            self.ppe = GatheredPressureSolver(fl.cfg.ppe, comm)
        self.ppe_engine = ENGINES[self.engine]
        fl.pressure.ppe = self.ppe
        fl.pressure.increments.ppe = self.ppe
        if fl.viscous is not None:  # the implicit viscous step's solve, gathered to rank 0
            fl.viscous.implicit_solve = GatheredViscousSolve(comm, self)
        self.x_start = None  # the rows' positions at the start of the last step
        self.wall_own = None

    @property
    def nf_global(self):
        """The number of fluid particles over all ranks."""
        return self.n_global

    @property
    def n_boundary(self):
        """The number of boundary rows: fixed walls, open boundaries' buffers, structures."""
        return self.fluid.n_walls + self.fluid.ns

    def boundary_x(self):
        """The boundary rows' positions: the fixed walls, the open boundaries' buffers and
        the structures, which every rank holds whole (the structures as they stand at the
        start of the step)."""
        fl = self.fluid
        buffers = [fl.open.positions()] if fl.open is not None else []
        return np.vstack([self.x_walls, *buffers, *[s.body["x"] for s in fl.structures]])

    def owned_structure_rows(self, values):
        """Per structure particle, ``values`` (one row each) as the rank that owns the
        particle computed them (its fluid neighbours are all its own particles or exact
        ghosts, in the serial order); collective."""
        mine = self.wall_own[self.fluid.n_walls:]
        return gather_rows(self.comm, np.flatnonzero(mine), values[mine], len(values))

    def fluid_power(self, force, velocity):
        """``sum_i F_i . v_i`` over every rank's own fluid particles, summed as the serial
        run sums it (the products in global-id order, on rank 0; its value to every rank);
        collective."""
        from fsi_sph.coupling.fsi import interface_power

        own = self.is_own
        parts = self.comm.gather((self.gid[own], force[own], velocity[own]), root=0)
        power = None
        if self.comm.rank == 0:
            gid = np.concatenate([p[0] for p in parts])
            order = np.argsort(gid, kind="stable")
            power = interface_power(np.concatenate([p[1] for p in parts])[order],
                                    np.concatenate([p[2] for p in parts])[order])
        return self.comm.bcast(power, root=0)

    def numbered(self, own):
        """With PETSc, each owned particle's row of the PPE goes with the ghosts."""
        self.wall_owner = self.strips.owner(self.boundary_x())
        if self.engine == "petsc":  # PETSc's rows: a block per rank (ppe_blocks.py)
            own["prow"], self.wall_rows, self.ppe.row_start, self.n_rows = petsc_numbering(
                self.comm, own["gid"], self.wall_owner)
        return own

    def relayout(self, arrays):
        set_fluid_rows(self.fluid, arrays)

    def own_from_body(self):
        """:meth:`BodyOnRanks.own_from_body`, with the incremental projection's last
        increment (the next solve's warm start) carried by each particle."""
        super().own_from_body()
        if self.obj.pressure.incremental:
            phi = self.obj.pressure.increments.phi_all
            self.own["phi"] = phi[:self.n_global][self.own["gid"]]

    def carried_increment(self, own, ghost):
        """The increment ``phi`` of the new rows (carried with the particles), the boundary
        rows' (the same on every rank) kept."""
        inc = self.fluid.pressure.increments
        walls = inc.phi_all[len(inc.phi_all) - self.n_boundary:]
        fluid = np.concatenate([own["phi"], ghost["phi"]])[self.order]
        inc.phi_all = np.concatenate([fluid, walls])

    def distribute(self):
        """:meth:`BodyOnRanks.distribute`, then the PPE's global numbering of the rows."""
        own, ghost = super().distribute()
        self.rows_numbered(own, ghost)

    def rows_numbered(self, own, ghost):
        """After the rows were laid out (:meth:`lay_out`): the carried increments, the
        step's start positions and the PPE's global numbering of the rows."""
        if "phi" in own:
            self.carried_increment(own, ghost)
        self.x_start = self.fluid.body["x"].copy()
        self.wall_own = self.wall_owner == self.comm.rank
        self.fluid.pressure.boundary.owned_structures = self.wall_own[self.fluid.n_walls:]
        if self.engine == "petsc":
            prow = np.concatenate([own["prow"], ghost["prow"]])[self.order]
            self.ppe.rows = numbering(prow, self.wall_rows, self.is_own, self.wall_own,
                                      self.n_rows, self.nf_global)
            return
        global_row = np.concatenate([self.gid, self.nf_global + np.arange(self.n_boundary)])
        owned = np.flatnonzero(np.concatenate([self.is_own, self.wall_own]))
        self.ppe.rows = RowNumbering(global_row, owned, self.nf_global + self.n_boundary,
                                     self.nf_global)

    def spread(self, x):
        """A solution over this rank's block (its own fluid rows in global-id order, then
        its walls) to every stacked row: the ghosts' values from their owners (the halo),
        the walls' from every rank (an all-gather). Collective."""
        n_fluid = int(np.count_nonzero(self.is_own))
        own_vals = np.empty(self.n_own)
        own_vals[self.order[self.is_own]] = x[:n_fluid]
        ghost_vals = self.halo.exchange(own_vals)
        walls = gather_rows(self.comm, np.flatnonzero(self.wall_own), x[n_fluid:],
                            self.n_boundary)
        return np.concatenate([np.concatenate([own_vals, ghost_vals])[self.order], walls])

    def collect(self):
        super().collect()
        self.own["x_start"] = self.x_start[self.is_own]
        if self.fluid.pressure.incremental:
            self.own["phi"] = self.fluid.pressure.increments.phi_all[:len(self.is_own)][
                self.is_own]
            self.exact_wall_pressure()

    def exact_wall_pressure(self):
        """The fixed walls' pressure from the ranks that own them, on every rank. With the
        incremental projection a wall's ``p^{n+1} = p^n + phi`` takes ``p^n`` extrapolated
        anew by each rank from the fluid it holds, which is right only for the walls beside
        its own particles (the ones its own rows read); the output reads them all."""
        fl = self.fluid
        nf, n_fixed = len(self.is_own), self.x_walls.shape[0]
        mine = np.flatnonzero(self.wall_own[:n_fixed])
        p = gather_rows(self.comm, mine, fl.p_all[nf + mine], n_fixed)
        fl.p_all[nf:nf + n_fixed] = p
        fl.walls.body["p"][:] = p

    def global_view(self):
        """Every fluid particle in rank 0's fluid body in global-id order, with the step's
        neighbour lists (built at the step's start positions, as the serial run's); the
        guard, the probes and the output read the fluid there as in a serial run. The other
        ranks' bodies keep their rows. Collective."""
        fl = self.fluid
        whole = {k: self.gathered(k, root_only=True) for k in fl.body.arrays}
        x_start = self.gathered("x_start", root_only=True) if self.x_start is not None else None
        phi = self.gathered("phi", root_only=True) if "phi" in self.own else None
        if self.comm.rank != 0:
            return
        if phi is not None:  # (the restart state holds the serial layout)
            inc = fl.pressure.increments
            inc.phi_all = np.concatenate([phi, inc.phi_all[len(inc.phi_all)
                                                            - self.n_boundary:]])
        set_fluid_rows(fl, whole)
        if x_start is not None:
            fl.body["x"][:] = x_start
        fl.update_neighbors()
        fl.body["x"][:] = whole["x"]
        fl.sync()


class RankSimulation(Simulation):
    """A :class:`Simulation` whose fluid, or whose soils, are split over the ranks of
    ``comm``: every rank builds the scene, keeps its strips' particles, and steps them with
    the others (``self.split``: one :class:`BodyOnRanks` per split body; ``self.ranks``:
    the fluid's, or the first soil's)."""

    def __init__(self, cfg, comm, halo=None, ppe="auto"):
        super().__init__(cfg)
        check_scene(self)
        self.comm = comm
        halo = halo_supports(self) if halo is None else halo
        if self.fluid is not None:
            self.split = {"fluid": FluidOnRanks(self, comm, halo, ppe)}
        else:
            self.split = {name: SoilOnRanks(comm, body, halo * SUPPORT * body.h,
                                            STRAY_SUPPORTS * SUPPORT * body.h)
                          for name, body in self.structures.items()}
        self.ranks = next(iter(self.split.values()))
        if self.fluid is not None:  # the step table's fluid count: every rank's particles
            self.step_table.fluid_count = lambda: self.split["fluid"].n_global
        if self.coupling is not None:  # the structures: whole on every rank
            self.coupling.owned_rows = self.ranks.owned_structure_rows
            self.coupling.fluid_power = self.ranks.fluid_power
        self.writes_output = comm.rank == 0
        self.viewed = 0  # the step whose global state the bodies hold (None: none)

    def gather_view(self):
        """Every split body holds every particle (:meth:`BodyOnRanks.global_view`), once per
        step; collective."""
        if self.viewed != self.n_steps:
            for part in self.split.values():
                part.global_view()
            self.viewed = self.n_steps

    def check(self):
        """The blow-up guard on rank 0's whole view (the serial run's check and message),
        its verdict to every rank; rank 0 keeps the last good state (it writes the run
        file). Collective."""
        self.gather_view()
        failure = None
        if self.comm.rank == 0:
            try:
                self.guard.check(self.t, self.n_steps, self.bodies())
            except SimulationError as e:
                failure = str(e)
        failure = self.comm.bcast(failure, root=0)
        if failure is not None:
            raise SimulationError(failure)
        self.last_good = (self.clock(), self.state()) if self.comm.rank == 0 else None

    def load_state(self, clock, state):
        """A restart: the whole state is loaded as in a serial run, then each rank takes
        its strips' particles (the file holds them by global id, whatever the ranks that
        wrote it)."""
        super().load_state(clock, state)
        for part in self.split.values():
            part.own_from_body()
        self.viewed = self.n_steps

    def step_limits(self):
        """The stable step over all ranks (each rank's limit over its own particles and
        ghosts: the minimum of the ranks' limits is the serial run's)."""
        limits, dt = super().step_limits()
        dt = float(global_reduce(self.comm, np.array([dt]), "min")[0])
        lim = self.fluid.dt_limits if self.fluid is not None else {}
        if lim:  # the fluid's recorded limits (step table) over every rank, as the serial
            keys = [k for k in lim if k != "nu_max"]
            low = global_reduce(self.comm, np.array([lim[k] for k in keys]), "min")
            lim.update(zip(keys, low.tolist(), strict=True))
            lim["nu_max"] = float(global_reduce(self.comm, np.array([lim["nu_max"]]),
                                                "max")[0])
        return limits, dt

    def exchange_open_boundaries(self, t, dt):
        """The open boundaries over the ranks (:mod:`.open_ranks`). Collective."""
        exchange_open(self.split["fluid"], t, dt)

    def step(self, dt_max=math.inf, to_end=False):
        """One step of every rank's particles (:meth:`Simulation.step` on the rank's own
        particles and ghosts); the particle-steps counted are the owned ones over all
        ranks."""
        t0 = time.perf_counter()
        for part in self.split.values():
            part.distribute()
        self.timings["exchange"] += time.perf_counter() - t0
        self.viewed = None
        dt, n_sub = super().step(dt_max, to_end)
        local = {name: part.obj.body.n for name, part in self.split.items()}  # (the step's)
        self.particle_steps += sum((part.n_global - local[name]) * n_sub.get(name, 1)
                                   for name, part in self.split.items())
        for part in self.split.values():
            part.collect()
        return dt, n_sub
