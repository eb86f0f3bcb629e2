"""Simulation: builds the bodies a scene declares and advances them.

:meth:`Simulation.step` is the one place where the order of operations of a time step is
written (DESIGN.md §4). A scene may hold an ISPH fluid with its walls (``[fluid]``,
``[walls]``), TLSPH solids (``[solid.NAME]``), Drucker-Prager soils (``[soil.NAME]`` with the
plane walls of ``[boundary]``), and the fluid-structure coupling (``[coupling]``).
"""

from __future__ import annotations

import logging
import math
import time
from collections import defaultdict
from pathlib import Path

from fsi_sph.config import Config
from fsi_sph.coupling.fsi import substeps
from fsi_sph.errors import SimulationError
from fsi_sph.frame import frame_of, peak_gravity
from fsi_sph.guard import Guard
from fsi_sph.probes import make_probe
from fsi_sph.progress import Progress
from fsi_sph.soil.drucker_prager import DruckerPragerBody
from fsi_sph.solid.tlsph import ElasticBody
from fsi_sph.step_table import StepTable

log = logging.getLogger(__name__)


class Simulation:
    """A scene in memory: its bodies, probes, clock and timers."""

    def __init__(self, cfg: Config):
        self.cfg = cfg
        t0 = time.perf_counter()
        c = cfg.case
        self.structures = {name: ElasticBody(name, sec, c.dx, cfg.sph, c.gravity)
                           for name, sec in cfg.solid.items()}
        coupled = [self.structures[n] for n in cfg.coupling.structures] if cfg.coupling else []
        self.fluid = None
        self.coupling = None
        if cfg.fluid is not None:  # imported only when a scene has a fluid
            from fsi_sph.fluid.isph import IncompressibleFluid

            self.fluid = IncompressibleFluid(cfg.fluid, cfg.walls, c.dx, cfg.sph, c.gravity,
                                             coupled)
            if self.fluid.walls is not None:  # rigid bodies stop at the fixed walls
                for body in coupled:
                    body.touch_walls(self.fluid.walls.body["x"], c.dx)
        if cfg.coupling is not None:
            from fsi_sph.coupling.fsi import FsiCoupling

            self.coupling = FsiCoupling(cfg.coupling, self.fluid, coupled,
                                        cfg.structure_scheme())
        walls = cfg.boundary.walls if cfg.boundary is not None else ()
        for name, sec in cfg.soil.items():  # [soil.NAME] present -> a Drucker-Prager body
            self.structures[name] = DruckerPragerBody(name, sec, c.dx, cfg.sph, c.gravity,
                                                      walls)
        self.probes = [make_probe(p, self.bodies()) for p in cfg.probes]
        self.step_table = StepTable(self.fluid, self.coupling)
        fixed = []
        if self.fluid is not None and self.fluid.walls is not None:
            fixed.append(self.fluid.walls.body["x"])
        self.frame = frame_of(c)  # a shaken scene's frame (its body force), or None
        self.guard = Guard(cfg.guard, self.bodies(), peak_gravity(self.frame, c.gravity), fixed)
        self.t = 0.0
        self.n_steps = 0
        self.particle_steps = 0
        self.next_out = 0.0  # time of the next snapshot
        self.next_probe = 0.0  # time of the next probe sample
        self.last_good = None  # (clock, state) at the last passed guard check
        self.timings: dict[str, float] = defaultdict(float)
        self.timings["setup"] = time.perf_counter() - t0

    def bodies(self) -> dict:
        """Every moving physics object, by name (each has ``.body``): the fluid and the
        structures. (Walls are fixed: they are in the snapshots, not here.)"""
        out = dict(self.structures)
        if self.fluid is not None:
            out["fluid"] = self.fluid
        return out

    @property
    def n_particles(self) -> int:
        n = sum(b.body.n for b in self.structures.values())
        return n + (self.fluid.n if self.fluid is not None else 0)

    def _timed(self, phase, fn, *args):
        t0 = time.perf_counter()
        out = fn(*args)
        self.timings[phase] += time.perf_counter() - t0
        return out

    # ------------------------------------------------------------------ the time step
    def step_limits(self):
        """Every body's stability limit and the macro step's: the fluid's when there is a
        fluid (the structures are sub-cycled inside its step), else the stiffest body's."""
        limits = [b.stable_dt() for b in self.structures.values()]
        if self.fluid is not None:
            limits.append(self.fluid.stable_dt())
            return limits, limits[-1]
        return limits, min(limits)

    def stable_dt(self) -> float:
        """The stable macro step in the current state."""
        return self.step_limits()[1]

    def step(self, dt_max=math.inf, to_end=False):
        """Advance every body by one macro step; returns (dt, {body: n_sub}).

        ``to_end``: ``dt_max`` is the time left to the end of the run; when it is between one
        and two stable steps, half of it is taken, so that the last step is not a sliver (the
        PPE's source scales with 1/dt and 1/dt^2: a last step of 0.39 dt left the Bagnold
        layer's final pressure field at 2.4 times the hydrostatic one)."""
        # 1. time step: the fluid's when there is a fluid; else the stiffest structure's
        fluid = self.fluid
        limits, dt = self.step_limits()
        dt = min(dt_max, dt)
        if to_end and dt < dt_max < 2.0 * dt:
            dt = 0.5 * dt_max
        if self.frame is not None:  # the frame's body force at the middle of the step
            self.frame.apply(self.t + 0.5 * dt, self.bodies())
        if not all(d > 0.0 for d in limits):  # NaN or collapsed: let the guard name the culprit
            self.guard.check(self.t, self.n_steps, self.bodies())
            raise SimulationError(f"time step {dt:.3g} s at t = {self.t:.6g} s, step "
                                  f"{self.n_steps}: no stable step is possible")
        # 2. fluid (PHYSICS.md §2-3): one projection step; coupled structures are moving
        #    boundary particles of it (their positions, averaged velocity, acceleration)
        coupling = self.coupling
        if fluid is not None:
            if fluid.open is not None:  # particles across the open lines; buffer velocities
                # (first: the structures' rows are laid out after the new fluid count)
                self._timed("open_boundaries", self.exchange_open_boundaries, self.t, dt)
            if coupling is not None:
                coupling.before_fluid()
            self._timed("neighbours", fluid.update_neighbors)
            self._timed("free_surface", fluid.detect_free_surface)
            if fluid.shifting_enabled:
                self._timed("shift", fluid.shift, dt)
            self._timed("predict", fluid.predict, dt)
            stats = self._timed("ppe", fluid.solve_pressure, dt)
            # interface forces [F 46-47] from p^{n+1}: the fluid's share now, the
            # structures' share held over their sub-steps below
            on_fluid = self._timed("coupling", coupling.forces) if coupling else None
            self._timed("correct", fluid.correct, dt, on_fluid)
            self.timings["ppe_assemble"] += stats.assemble_time
            self.timings["ppe_setup"] += stats.setup_time
            self.timings["ppe_solve"] += stats.solve_time
            self.particle_steps += fluid.n
        # 3. structures, each sub-cycled to its own stability limit
        n_sub = _advance_structures(self, dt)
        self.t += dt
        self.n_steps += 1
        return dt, n_sub

    def exchange_open_boundaries(self, t, dt):
        """The fluid's open boundaries at the start of the step ``t -> t + dt`` (over ranks:
        :meth:`RankSimulation.exchange_open_boundaries`)."""
        self.fluid.exchange_open_boundaries(t, dt)

    # ------------------------------------------------------------------ guard, state
    writes_output = True  # this process writes the run file (fsi_sph/parallel/ranks.py)

    def gather_view(self):
        """Every body's whole state in this process's bodies, for the guard, the probes and
        the output (a run split over ranks gathers it here: fsi_sph/parallel/ranks.py)."""

    def check(self):
        """Run the blow-up guard (:mod:`fsi_sph.guard`); on success remember this state as
        the last good one. Raises :class:`SimulationError` naming time, step, body, particle
        and quantity."""
        self.gather_view()
        self.guard.check(self.t, self.n_steps, self.bodies())
        self.last_good = (self.clock(), self.state())

    def clock(self) -> dict:
        return {"t": self.t, "step": self.n_steps, "particle_steps": self.particle_steps,
                "next_out": self.next_out, "next_probe": self.next_probe}

    def state(self) -> dict:
        """Everything the step needs to continue: a copy of every body's arrays."""
        out = {name: {k: v.copy() for k, v in o.body.arrays.items()}
               for name, o in self.bodies().items()}
        for name, o in self.bodies().items():  # state outside the body arrays
            if hasattr(o, "extra_state"):
                out[f"{name}.extra"] = o.extra_state()
        return out

    def load_state(self, clock: dict, state: dict):
        """Put a saved state back (restart); the bodies must match the saved ones."""
        bodies = self.bodies()
        extra = {k: state[k] for k in state if k.endswith(".extra")}
        state = {k: v for k, v in state.items() if not k.endswith(".extra")}
        if set(state) != set(bodies):
            raise SimulationError(f"restart: the saved bodies {sorted(state)} are not the "
                                  f"scene's {sorted(bodies)}")
        for key, arrays in extra.items():  # first: the fluid's count may change with it
            bodies[key.removesuffix(".extra")].load_extra_state(arrays)
        for name, arrays in state.items():
            b = bodies[name].body
            for k, v in arrays.items():
                if k not in b.arrays or b.arrays[k].shape != v.shape:
                    raise SimulationError(
                        f"restart: body {name!r} field {k!r} has shape {v.shape} in the file "
                        f"but {b.arrays[k].shape if k in b.arrays else 'none'} in the scene")
                b.arrays[k][...] = v
        self.t = float(clock["t"])
        self.n_steps = int(clock["step"])
        self.particle_steps = int(clock["particle_steps"])
        self.next_out = float(clock["next_out"])
        self.next_probe = float(clock["next_probe"])

    # ------------------------------------------------------------------ run
    def run(self, out_dir=None, max_steps=None, progress=True, case_file=None, resume=None):
        """Step to ``case.t_end`` (or ``max_steps``), writing ``out_dir/run.h5`` if given.

        ``resume``: a run file to continue: its latest restart state is loaded and the run
        appends to it (or writes ``out_dir/run.h5`` when ``out_dir`` is given).
        Returns a summary dict (steps, wall times, particle-steps per second, status).
        """
        c = self.cfg.case
        writer = _open_writer(self, out_dir, case_file, resume)
        steps0, particle_steps0 = self.n_steps, self.particle_steps  # a restart's clock
        rows = {p.name: (p.columns, []) for p in self.probes}
        step_rows = []
        eps = 1e-12 * c.t_end
        last_snapshot = [-1.0 if resume is None else self.t]

        def sample():
            self.gather_view()
            for p in self.probes if self.writes_output else ():
                rows[p.name][1].append([self.t, *p.sample()])

        def flush(snapshot, status="running", restart_point=None):
            # restart points: scheduled snapshots and a completed run's end (kept solver
            # state reset there, as a restart starts); a --max-steps stop is only a snapshot
            nonlocal step_rows
            restart_point = snapshot if restart_point is None else restart_point
            t0 = time.perf_counter()
            self.gather_view()
            if snapshot:  # output or not, so that the physics never depends on the output
                for o in self.bodies().values():
                    if hasattr(o, "at_snapshot"):
                        o.at_snapshot()
            if writer is not None:
                snap = None
                if snapshot:
                    last_snapshot[0] = self.t
                    snap = self.snapshot()
                writer.write(self.t, self.n_steps, snap, rows, step_rows, _timing_attrs(self),
                             status,
                             restart=(self.clock(), self.state()) if restart_point else None)
            for _, r in rows.values():
                r.clear()
            step_rows = []
            self.timings["output"] += time.perf_counter() - t0

        bar = Progress(c.t_end, self.t) if progress and self.writes_output else None
        loop_t0 = time.perf_counter()
        status = "completed"
        try:
            if resume is None:
                self.check()
                sample()
                self.next_probe += c.probe_every
                # the clock of the initial restart point must already name the next output
                # (a run restarted from it would otherwise write a snapshot, and reset the
                # kept solver state, one step after the start)
                self.next_out += c.output_every
                flush(True)
            while self.t < c.t_end - eps:
                if max_steps is not None and self.n_steps - steps0 >= max_steps:
                    status = f"stopped at max_steps = {max_steps}"
                    break
                dt, n_sub = self.step(dt_max=c.t_end - self.t, to_end=True)
                step_rows.append(self.step_table.row(self.t, dt, n_sub))
                if bar is not None:
                    bar.update(self.t)
                t0 = time.perf_counter()
                snapshot_due = self.t >= self.next_out - eps
                if snapshot_due or self.n_steps % self.cfg.guard.check_every == 0:
                    self.check()
                if self.t >= self.next_probe - eps:
                    sample()
                    self.next_probe = max(self.next_probe + c.probe_every, self.t)
                self.timings["guard_probes"] += time.perf_counter() - t0
                if snapshot_due:
                    self.next_out += c.output_every
                    flush(True)
            self.check()
        except SimulationError as e:
            if " at t = " not in str(e):  # (a solver's failure does not know the clock)
                e = SimulationError(f"{e}, in the step from t = {self.t:.6g} s (step "
                                    f"{self.n_steps + 1})")
            status = f"failed: {e}"
            raise e from None
        except KeyboardInterrupt:
            status = "failed: interrupted by the user"
            raise
        finally:
            self.timings["loop"] = time.perf_counter() - loop_t0 - self.timings["output"]
            if bar is not None:
                bar.close()
            self.gather_view()
            if writer is not None:
                if status.startswith("failed"):
                    flush(False, status)
                    _write_last_good(self, writer, status)
                else:
                    flush(last_snapshot[0] < self.t, status,
                          restart_point=status == "completed" and last_snapshot[0] < self.t)
                writer.finish(status, _timing_attrs(self))
        # steps and particle-steps count from t = 0 (a restarted run's too); the throughput
        # is this call's: its particle-steps over its loop time
        summary = {"status": status, "steps": self.n_steps, "t": self.t,
                   "steps_this_run": self.n_steps - steps0,
                   "n_particles": self.n_particles, "particle_steps": self.particle_steps,
                   "loop_time_s": self.timings["loop"], "setup_time_s": self.timings["setup"],
                   "particle_steps_per_s": ((self.particle_steps - particle_steps0)
                                            / max(self.timings["loop"], 1e-12)),
                   "output": str(writer.path) if writer else None}
        return summary

    def snapshot(self):
        """Every body's (and the walls') output arrays now."""
        snap = {n: b.snapshot() for n, b in self.bodies().items()}
        if self.fluid is not None and self.fluid.walls is not None:
            snap["walls"] = self.fluid.wall_snapshot()
        return snap


def _advance_structures(sim, dt):
    """The structures' part of :meth:`Simulation.step`: each sub-cycled to its own
    stability limit (TLSPH solids and Drucker-Prager soils alike; timed per body kind), the
    coupled ones by the coupling [F 48] (sub-cycled, force held, averaged velocity back).
    Returns ``{name: sub-steps}``."""
    n_sub = {}
    if sim.coupling is not None:
        t0 = time.perf_counter()
        n_sub.update(sim.coupling.advance(dt))
        sim.particle_steps += sum(n * sim.structures[k].body.n for k, n in n_sub.items())
        sim.timings["solid"] += time.perf_counter() - t0
    for name, body in sim.structures.items():
        if name in n_sub:
            continue
        t0 = time.perf_counter()
        n = max(1, math.ceil(dt / body.stable_dt() - 1e-12))
        substeps(body, dt, n)
        n_sub[name] = n
        sim.particle_steps += n * body.body.n
        sim.timings[body.body.kind] += time.perf_counter() - t0
    return n_sub


def _write_last_good(sim, writer, status):
    """After a failure: write the last state that passed the guard as a snapshot (attr
    ``last_good``) and as the restart state, so the user can look at it and restart."""
    if sim.last_good is None or sim.last_good[0]["t"] <= writer.last_snapshot_t:
        return
    good_clock, good_state = sim.last_good
    failed_clock, failed_state = sim.clock(), sim.state()
    sim.load_state(good_clock, good_state)
    snap = sim.snapshot()
    sim.load_state(failed_clock, failed_state)  # the object keeps the failed state
    writer.write(good_clock["t"], good_clock["step"], snap, {}, [], _timing_attrs(sim),
                 status, restart=(good_clock, good_state), last_good=True)


def _open_writer(sim, out_dir, case_file, resume):
    """The run file's writer (None without output); with ``resume``, first load its restart
    state into ``sim`` (and append to that file unless ``out_dir`` is given)."""
    from fsi_sph.output import RunWriter, read_restart

    writer = None
    if resume is not None:
        sim.load_state(*read_restart(resume))
    if not sim.writes_output:
        return None
    if resume is not None:
        if out_dir is None:
            writer = RunWriter.reopen(resume, sim.t)
    if out_dir is not None:
        static = {n: b.static() for n, b in sim.bodies().items()}
        if sim.fluid is not None and sim.fluid.walls is not None:
            static["walls"] = sim.fluid.walls.static()
        writer = RunWriter(Path(out_dir) / "run.h5", sim.cfg.to_json(), case_file, static,
                           step_columns=sim.step_table.columns)
    return writer


def _timing_attrs(sim):
    """The run's wall times per phase, steps and particle-steps (output attributes)."""
    out = {f"{k}_s": float(v) for k, v in sim.timings.items()}
    out["steps"] = sim.n_steps
    out["particle_steps"] = sim.particle_steps
    return out


def run(case, out_dir=None, overrides=None, max_steps=None, progress=True):
    """Load ``case`` (a path), build the simulation and run it; returns the summary."""
    from fsi_sph.config import load_config

    cfg = load_config(case, overrides)
    sim = Simulation(cfg)
    return sim.run(out_dir=out_dir, max_steps=max_steps, progress=progress, case_file=str(case))
